//! Support for haptic6d's tests and benches; a dev-dependency only, never linked into a
//! product.
//!
//! - [`CountingAllocator`] and [`count_allocations`]: the no-allocation tests' proof that a
//!   warmed-up haptic frame allocates nothing. Install the allocator in the test binary:
//!
//!   ```text
//!   #[global_allocator]
//!   static GLOBAL: devkit::CountingAllocator = devkit::CountingAllocator;
//!   ```
//!
//!   then wrap the code under test: `let (out, counts) = devkit::count_allocations(|| ...)`.
//! - [`thread_cpu_time`]: this thread's CPU time, for benches that must not count time the
//!   thread spent preempted on a loaded machine.
//! - [`Rng`]: the seeded SplitMix64 generator of the fuzz and long-run tests (a failure replays
//!   from its seed).
#![warn(missing_docs)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::Duration;

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    static DEALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    static LIVE_BYTES: Cell<i64> = const { Cell::new(0) };
}

/// The system allocator, counting what the calling thread does while it runs inside
/// [`count_allocations`]; other threads and other times are not counted.
pub struct CountingAllocator;

/// Adds `n` to `cell` when this thread is armed. `try_with`: thread-locals may be gone while
/// the thread is torn down, and the allocator must never panic.
fn note<T: Copy + std::ops::Add<Output = T>>(cell: &'static std::thread::LocalKey<Cell<T>>, n: T) {
    if ARMED.try_with(Cell::get).unwrap_or(false) {
        let _ = cell.try_with(|c| c.set(c.get() + n));
    }
}

fn size(layout: Layout) -> i64 {
    i64::try_from(layout.size()).unwrap_or(i64::MAX)
}

// SAFETY: every call is forwarded unchanged to the system allocator; the counters are plain
// thread-locals that never allocate.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(&ALLOCATIONS, 1);
        note(&LIVE_BYTES, size(layout));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note(&DEALLOCATIONS, 1);
        note(&LIVE_BYTES, -size(layout));
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(&ALLOCATIONS, 1);
        note(&LIVE_BYTES, size(layout));
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(&ALLOCATIONS, 1);
        note(
            &LIVE_BYTES,
            i64::try_from(new_size).unwrap_or(i64::MAX) - size(layout),
        );
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// What one thread allocated while counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AllocationCounts {
    /// Calls to `alloc`, `alloc_zeroed` and `realloc`.
    pub allocations: usize,
    /// Calls to `dealloc`.
    pub deallocations: usize,
    /// Bytes allocated minus bytes freed, bytes (negative when more was freed).
    pub live_bytes: i64,
}

impl AllocationCounts {
    /// Every call into the allocator: allocations and deallocations.
    pub fn events(&self) -> usize {
        self.allocations + self.deallocations
    }
}

/// Runs `f` on this thread with its allocations counted; returns `f`'s result and the counts.
/// Needs [`CountingAllocator`] as the binary's global allocator (else the counts stay zero:
/// check with a deliberate allocation, as the tests do).
pub fn count_allocations<T>(f: impl FnOnce() -> T) -> (T, AllocationCounts) {
    ALLOCATIONS.with(|c| c.set(0));
    DEALLOCATIONS.with(|c| c.set(0));
    LIVE_BYTES.with(|c| c.set(0));
    ARMED.with(|a| a.set(true));
    let out = f();
    ARMED.with(|a| a.set(false));
    let counts = AllocationCounts {
        allocations: ALLOCATIONS.with(Cell::get),
        deallocations: DEALLOCATIONS.with(Cell::get),
        live_bytes: LIVE_BYTES.with(Cell::get),
    };
    (out, counts)
}

/// CPU time this thread has used (Linux: `clock_gettime(CLOCK_THREAD_CPUTIME_ID)`): unlike
/// wall time it does not grow while the thread waits preempted, so a bench on a loaded machine
/// still measures the code.
///
/// # Panics
/// If the clock cannot be read (never on Linux): a bench must not report made-up times.
pub fn thread_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we own; the clock id is valid on Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    Duration::new(
        u64::try_from(ts.tv_sec).unwrap_or(0),
        u32::try_from(ts.tv_nsec).unwrap_or(0),
    )
}

/// Page faults this thread has taken so far, minor and major (Linux:
/// `getrusage(RUSAGE_THREAD)`): a first write to memory the kernel has not yet mapped stops the
/// thread for a few microseconds, which a haptic frame must not do.
///
/// # Panics
/// If the counters cannot be read (never on Linux).
pub fn thread_page_faults() -> u64 {
    // SAFETY: an all-zero `rusage` is a valid value of the plain C struct getrusage fills in.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: getrusage writes into the struct we own; RUSAGE_THREAD is valid on Linux.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_THREAD, &mut usage) };
    assert_eq!(rc, 0, "getrusage(RUSAGE_THREAD) failed");
    u64::try_from(usage.ru_minflt + usage.ru_majflt).unwrap_or(0)
}

/// SplitMix64 (Steele, Lea and Flood, 2014): a tiny seeded generator, plenty for driving
/// fuzz mutations and random devices; the same seed gives the same sequence everywhere.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator starting from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// A number in `[0, 1)` with 53 random bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A number in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[global_allocator]
    static GLOBAL: CountingAllocator = CountingAllocator;

    #[test]
    fn counts_what_the_closure_allocates_and_frees() {
        let (v, c) = count_allocations(|| std::hint::black_box(vec![0u8; 100]));
        assert!(c.allocations >= 1 && c.live_bytes >= 100, "{c:?}");
        let (_, c) = count_allocations(|| drop(v));
        assert_eq!((c.deallocations, c.live_bytes), (1, -100), "{c:?}");
        let (n, c) = count_allocations(|| std::hint::black_box(2) + 2);
        assert_eq!((n, c.events()), (4, 0));
    }

    #[test]
    fn rng_is_seeded_and_in_range() {
        let (mut a, mut b) = (Rng::new(7), Rng::new(7));
        assert_eq!(a.next_u64(), b.next_u64());
        assert_ne!(Rng::new(8).next_u64(), Rng::new(7).next_u64());
        for _ in 0..1000 {
            assert!(a.below(10) < 10);
            let x = a.range(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&x));
        }
        assert_eq!(a.below(0), 0);
    }

    #[test]
    fn thread_cpu_time_grows_with_work() {
        let t0 = thread_cpu_time();
        let mut x = 0u64;
        while thread_cpu_time() - t0 < Duration::from_millis(2) {
            x = std::hint::black_box(x.wrapping_add(1));
        }
        assert!(x > 0);
    }
}
