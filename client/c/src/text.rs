//! Text that comes in from C: NUL-terminated strings and the scene spec's bytes.

use crate::error::Error;
use lumen_proto::SceneSpec;
use std::ffi::{c_char, CStr};

/// A NUL-terminated UTF-8 argument; `None` for NULL.
///
/// # Safety
/// `ptr` is NULL or points to a NUL-terminated string that outlives `'a`.
pub(crate) unsafe fn optional<'a>(ptr: *const c_char, name: &'static str) -> Result<Option<&'a str>, Error> {
    if ptr.is_null() {
        return Ok(None);
    }
    // SAFETY: NUL-terminated and alive (the caller's contract).
    let bytes = unsafe { CStr::from_ptr(ptr) };
    bytes.to_str().map(Some).map_err(|error| Error::BadText { name, error })
}

/// A NUL-terminated UTF-8 argument that must be there.
///
/// # Safety
/// As [`optional`].
pub(crate) unsafe fn required<'a>(ptr: *const c_char, name: &'static str) -> Result<&'a str, Error> {
    // SAFETY: forwarded.
    unsafe { optional(ptr, name) }?.ok_or(Error::NullArgument(name))
}

/// The scene spec in `len` bytes of UTF-8 JSON (no NUL needed), parsed (not yet validated).
///
/// # Safety
/// `ptr` is NULL or points to `len` readable bytes.
pub(crate) unsafe fn spec(ptr: *const c_char, len: usize) -> Result<SceneSpec, Error> {
    if ptr.is_null() {
        return Err(Error::NullArgument("spec_json"));
    }
    // SAFETY: `len` readable bytes (the caller's contract).
    let bytes = unsafe { std::slice::from_raw_parts(ptr.cast::<u8>(), len) };
    let text = std::str::from_utf8(bytes).map_err(Error::BadUtf8)?;
    serde_json::from_str(text).map_err(|e| match text.strip_suffix('\0') {
        // `strlen + 1`, or `sizeof` of a string literal: the NUL is not part of the JSON.
        Some(json) if serde_json::from_str::<SceneSpec>(json).is_ok() => Error::TrailingNul { len },
        _ => Error::BadJson(e),
    })
}
