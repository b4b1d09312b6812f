//! Status codes, the thread's last error message, and the door every entry point goes through:
//! `catch_unwind`, null checks, and a message written without allocating.

use std::cell::RefCell;
use std::ffi::{c_char, CStr};
use std::fmt::{self, Write as _};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// What an `h6d_*` call did. Every entry point returns one of these as an `int32_t`; on
/// anything but `H6D_STATUS_OK`, `h6d_last_error_message()` says what went wrong, on one line.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum H6dStatus {
    /// Success.
    Ok = 0,
    /// A required pointer argument was NULL.
    NullArgument = 1,
    /// An argument is out of range or malformed: a setting outside its range (NaN included),
    /// an unknown enum value, a path that is not UTF-8, a non-finite pose or time.
    InvalidArgument = 2,
    /// A file does not exist or cannot be read.
    Io = 3,
    /// A scene, mesh, tree or trajectory file is malformed, or a scene name is unknown.
    Scene = 4,
    /// The engine refused its input: a tree it cannot use, or a start pose in collision with no
    /// free pose nearby.
    Engine = 5,
    /// A caller's buffer is too small: the count needed was written, the buffer holds the
    /// first entries that fit.
    BufferTooSmall = 6,
    /// A panic was caught at the door (a bug in haptic6d). An engine it happened in is
    /// poisoned: every later call on it returns this status; destroy it.
    Panic = 7,
}

impl H6dStatus {
    /// The status's name as in the header (`H6D_STATUS_OK`, ...).
    pub fn name(self) -> &'static CStr {
        match self {
            Self::Ok => c"H6D_STATUS_OK",
            Self::NullArgument => c"H6D_STATUS_NULL_ARGUMENT",
            Self::InvalidArgument => c"H6D_STATUS_INVALID_ARGUMENT",
            Self::Io => c"H6D_STATUS_IO",
            Self::Scene => c"H6D_STATUS_SCENE",
            Self::Engine => c"H6D_STATUS_ENGINE",
            Self::BufferTooSmall => c"H6D_STATUS_BUFFER_TOO_SMALL",
            Self::Panic => c"H6D_STATUS_PANIC",
        }
    }

    /// The status of a returned code; `None` for a code no call returns.
    pub fn from_code(code: i32) -> Option<Self> {
        [
            Self::Ok,
            Self::NullArgument,
            Self::InvalidArgument,
            Self::Io,
            Self::Scene,
            Self::Engine,
            Self::BufferTooSmall,
            Self::Panic,
        ]
        .into_iter()
        .find(|s| *s as i32 == code)
    }
}

/// Capacity of the message buffer, bytes (NUL included); longer messages are cut at a
/// character boundary and end in `...`.
const MESSAGE_CAP: usize = 1024;

/// A fixed buffer, so recording an error never allocates (the step reports a NaN pose from
/// inside the haptic frame). `repr(C)` with the text first: the pointer handed to C is the
/// struct's address.
#[repr(C)]
struct Message {
    buf: [u8; MESSAGE_CAP],
    len: usize,
    truncated: bool,
}

impl Message {
    const fn new() -> Self {
        Self {
            buf: [0; MESSAGE_CAP],
            len: 0,
            truncated: false,
        }
    }

    fn clear(&mut self) {
        self.len = 0;
        self.truncated = false;
        self.buf[0] = 0;
    }

    /// Ends the text with a NUL (and `...` when it was cut).
    fn finish(&mut self) {
        if self.truncated {
            let mut end = self.len.min(MESSAGE_CAP - 4);
            while end > 0 && (self.buf[end] & 0xC0) == 0x80 {
                end -= 1; // never cut inside a UTF-8 character
            }
            self.buf[end..end + 3].copy_from_slice(b"...");
            self.len = end + 3;
        }
        self.buf[self.len] = 0;
    }
}

impl fmt::Write for Message {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for ch in s.chars() {
            // Keep the message on one line whatever a file path or an OS error holds.
            let ch = if ch.is_control() { ' ' } else { ch };
            let mut tmp = [0u8; 4];
            let bytes = ch.encode_utf8(&mut tmp).as_bytes();
            if self.len + bytes.len() >= MESSAGE_CAP {
                self.truncated = true;
                return Ok(());
            }
            self.buf[self.len..self.len + bytes.len()].copy_from_slice(bytes);
            self.len += bytes.len();
        }
        Ok(())
    }
}

thread_local! {
    // `const` initialised and without a destructor: reading or writing it never allocates.
    static LAST_ERROR: RefCell<Message> = const { RefCell::new(Message::new()) };
}

/// Records `call: message` as this thread's last error and returns `status`.
pub(crate) fn record(call: &str, status: H6dStatus, message: fmt::Arguments<'_>) -> H6dStatus {
    LAST_ERROR.with(|m| {
        if let Ok(mut m) = m.try_borrow_mut() {
            m.clear();
            let _ = write!(m, "{call}: {message}");
            m.finish();
        }
    });
    status
}

/// The thread's last error message as Rust text (tests, the bench).
pub fn last_error() -> String {
    LAST_ERROR.with(|m| {
        let m = m.borrow();
        String::from_utf8_lossy(&m.buf[..m.len]).into_owned()
    })
}

/// A set-up failure whose message is already text (set-up may allocate; the haptic frame
/// records its failures with [`fail!`] instead).
#[derive(Debug)]
pub(crate) struct Failure {
    pub(crate) status: H6dStatus,
    pub(crate) message: String,
}

impl Failure {
    pub(crate) fn new(status: H6dStatus, message: String) -> Self {
        Self { status, message }
    }

    /// Records the failure under `call`'s name and gives its status.
    pub(crate) fn report(self, call: &str) -> H6dStatus {
        record(call, self.status, format_args!("{}", self.message))
    }
}

/// Records `call: message` (a `format_args!` message, so nothing is allocated) as the thread's
/// last error and gives the status: `fail!(call, InvalidArgument, "q_h[{i}] = {v}")`.
macro_rules! fail {
    ($call:expr, $status:ident, $($arg:tt)+) => {
        $crate::status::record($call, $crate::status::H6dStatus::$status, format_args!($($arg)+))
    };
}
pub(crate) use fail;

/// Runs one entry point: a panic becomes [`H6dStatus::Panic`] (never unwinds into C), a
/// failure is recorded as the thread's last error. `on_panic` runs after a caught panic (to
/// poison the handle the panic happened in).
pub(crate) fn door(
    call: &str,
    body: impl FnOnce() -> Result<(), H6dStatus>,
    on_panic: impl FnOnce(),
) -> i32 {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => H6dStatus::Ok as i32,
        Ok(Err(status)) => status as i32,
        Err(payload) => {
            on_panic();
            let what = payload
                .downcast_ref::<&str>()
                .copied()
                .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
                .unwrap_or("(no message)");
            record(
                call,
                H6dStatus::Panic,
                format_args!("panicked (a bug in haptic6d, please report it): {what}"),
            ) as i32
        }
    }
}

/// A required pointer argument, or [`H6dStatus::NullArgument`] naming it.
pub(crate) fn non_null<T>(call: &str, name: &str, p: *const T) -> Result<*const T, H6dStatus> {
    if p.is_null() {
        Err(fail!(call, NullArgument, "`{name}` is NULL"))
    } else {
        Ok(p)
    }
}

/// The message of the last `h6d_*` call that failed on this thread: one line of UTF-8 text,
/// naming the call, the argument or file, and what is wrong (empty before any failure).
/// Successful calls leave it as it was.
///
/// The pointer is valid until the next failing `h6d_*` call on this thread or the thread's
/// end; copy the text to keep it. Never NULL.
#[no_mangle]
pub extern "C" fn h6d_last_error_message() -> *const c_char {
    LAST_ERROR.with(|m| m.as_ptr().cast::<u8>().cast_const().cast())
}

/// The name of a status code (`"H6D_STATUS_OK"`, ...), or `"unknown status"` for a code no
/// call returns. A static string; never NULL.
#[no_mangle]
pub extern "C" fn h6d_status_name(status: i32) -> *const c_char {
    H6dStatus::from_code(status)
        .map_or(c"unknown status", H6dStatus::name)
        .as_ptr()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_a_status_and_a_message() {
        let mut poisoned = false;
        let code = door(
            "h6d_test",
            || -> Result<(), H6dStatus> { panic!("index 7 out of range") },
            || poisoned = true,
        );
        assert_eq!(code, H6dStatus::Panic as i32);
        assert!(poisoned);
        let m = last_error();
        assert!(m.starts_with("h6d_test: panicked"), "{m}");
        assert!(m.contains("index 7 out of range"), "{m}");
    }

    #[test]
    fn long_messages_are_cut_on_a_character_boundary() {
        let long = "é".repeat(2000);
        fail!("h6d_test", InvalidArgument, "{long}\nsecond line");
        let m = last_error();
        assert!(m.len() < MESSAGE_CAP, "{}", m.len());
        assert!(m.ends_with("é..."), "{}", &m[m.len() - 10..]);
        fail!("h6d_test", Io, "a\nb");
        assert_eq!(last_error(), "h6d_test: a b", "one line");
    }
}
