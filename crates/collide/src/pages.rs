//! Storage a haptic frame may write, made resident before the first frame.
//!
//! The kernel maps reserved memory lazily: a buffer reserved with `Vec::with_capacity`, or
//! zero-filled with `vec![0.0; n]` (fresh zero pages), takes a page fault on the first write to
//! each of its pages. Reserving up front keeps a frame from allocating, but a frame that first
//! writes past a buffer's high-water mark (a near list longer than any before it, a region of
//! more rows) still stops for a few microseconds per 4 KiB page: measured in `haptic6d run`,
//! 22–101 frames a run took 224–789 faults, up to 62 in one frame.

use std::mem::{size_of, MaybeUninit};

/// The smallest page size of the platforms served (bytes): touching one byte in every span
/// this long touches every page, whatever the page size.
pub const PAGE_BYTES: usize = 4096;

/// Writes to every page of `v`'s storage, its elements kept as they are and its unused
/// capacity filled with zero bytes (still unused: `v`'s length does not change). Not
/// real-time: for set-up, after the buffer is reserved.
pub fn touch_pages<T: Copy>(v: &mut Vec<T>) {
    if size_of::<T>() == 0 {
        // No storage (and a capacity without end).
        return;
    }
    // One element per page at least: the written elements start at most a page apart, and
    // the last one ends the storage (whose last page may hold no other's start).
    let stride = (PAGE_BYTES / size_of::<T>()).max(1);
    let touch = |x: &mut T| {
        // Written back through an opaque value, so that the store is not dropped as a no-op.
        *x = std::hint::black_box(*x);
    };
    v.iter_mut().step_by(stride).for_each(touch);
    if let Some(x) = v.last_mut() {
        touch(x);
    }
    let zero = |slot: &mut MaybeUninit<T>| {
        *slot = MaybeUninit::zeroed();
        std::hint::black_box(&*slot);
    };
    let spare = v.spare_capacity_mut();
    spare.iter_mut().step_by(stride).for_each(zero);
    if let Some(slot) = spare.last_mut() {
        zero(slot);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_keeps_the_elements_and_the_length_and_the_capacity() {
        let mut v: Vec<f64> = Vec::with_capacity(10_000);
        v.extend((0..1234).map(f64::from));
        let cap = v.capacity();
        touch_pages(&mut v);
        assert_eq!(v.len(), 1234);
        assert_eq!(v.capacity(), cap);
        assert!(v.iter().enumerate().all(|(i, &x)| x == i as f64));
        // Elements larger than a page, and zero-sized ones.
        let mut big: Vec<[u8; 5000]> = Vec::with_capacity(3);
        big.push([7; 5000]);
        touch_pages(&mut big);
        assert!(big[0].iter().all(|&b| b == 7));
        let mut unit: Vec<()> = Vec::with_capacity(5);
        touch_pages(&mut unit);
        assert!(unit.is_empty());
    }
}
