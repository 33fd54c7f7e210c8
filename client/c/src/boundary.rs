//! The boundary between C and Rust: every `extern "C"` body runs in [`call`], which catches
//! any panic (unwinding into C is undefined behaviour) and turns every failure into a status,
//! keeping its text for `lumen_last_error` on the calling thread.

use crate::error::Error;
use crate::status::LumenStatus;
use std::any::Any;
use std::cell::RefCell;
use std::ffi::c_char;
use std::fmt::Write;
use std::panic::{catch_unwind, AssertUnwindSafe};

thread_local! {
    /// The text of the last failed call on this thread (empty before any).
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
}

/// Runs `body`, catching a panic; an error's text is kept for [`lumen_last_error`].
pub(crate) fn call(body: impl FnOnce() -> Result<(), Error>) -> LumenStatus {
    // Local objects another thread freed are dropped here, on their own thread.
    let _ = catch_unwind(crate::handles::drop_orphans);
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => LumenStatus::Ok,
        Ok(Err(e)) => fail(e),
        Err(payload) => fail(Error::Panic(panic_text(payload.as_ref()))),
    }
}

/// Records `e`'s text as this thread's last error and returns its status.
fn fail(e: Error) -> LumenStatus {
    let status = e.status();
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // `try_with`: the thread may be tearing down its locals; the status still goes back.
        let _ = LAST_ERROR.try_with(|last| {
            if let Ok(mut last) = last.try_borrow_mut() {
                last.clear();
                let _ = write!(last, "{e}");
                // C reads up to the first NUL: keep one that came in with the input visible.
                if last.contains('\0') {
                    *last = last.replace('\0', "\\0");
                }
            }
        });
    }));
    status
}

/// A panic's message, when it carries one.
fn panic_text(payload: &(dyn Any + Send)) -> String {
    match (payload.downcast_ref::<&str>(), payload.downcast_ref::<String>()) {
        (Some(s), _) => (*s).to_owned(),
        (_, Some(s)) => s.clone(),
        _ => "a panic without a message".to_owned(),
    }
}

/// Copies the text of the last call on this thread that did not return `LUMEN_STATUS_OK`
/// into `buf` (at most `len` bytes, always NUL-terminated when `len > 0`, cut at a UTF-8
/// character's boundary when too long) and returns the size the whole text needs, its NUL
/// included: a return above `len` means the copy was cut. With `buf` NULL or `len` 0 nothing
/// is written (ask the size first, then copy). Before any failure the text is empty
/// (returns 1). Successful calls leave the text as it is; each thread has its own.
///
/// # Safety
/// `buf` is NULL or points to `len` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn lumen_last_error(buf: *mut c_char, len: usize) -> usize {
    let copied = catch_unwind(AssertUnwindSafe(|| {
        LAST_ERROR
            .try_with(|last| {
                let last = last.try_borrow().map(|s| s.clone()).unwrap_or_default();
                if !buf.is_null() && len > 0 {
                    let mut n = last.len().min(len - 1);
                    while !last.is_char_boundary(n) {
                        n -= 1;
                    }
                    // SAFETY: the caller gives `len` writable bytes at `buf`; `n < len`.
                    unsafe {
                        std::ptr::copy_nonoverlapping(last.as_ptr(), buf.cast::<u8>(), n);
                        *buf.add(n) = 0;
                    }
                }
                last.len() + 1
            })
            .unwrap_or(1)
    }));
    copied.unwrap_or(1)
}
