//! Lumen from C: the embedded detector behind a C ABI, as a static or shared library
//! (`liblumen_c.a`, `liblumen_c.so`) with its header `include/lumen.h`, generated from this
//! source by cbindgen (`tests/header.rs` keeps the two equal).
//!
//! - [`status`]: the status every call returns.
//! - [`error`]: the crate's error, what each status means in words.
//! - [`boundary`]: the guard every call runs in (no panic crosses into C) and the per-thread
//!   last error (`lumen_last_error`).
//! - [`detector`]: `lumen_detector_*`, a [`lumen_detect::Detector`] behind an opaque handle.
//!
//! Contacts cross as [`lumen_proto::Contact`] itself: the header's `LumenContact` is emitted
//! from proto's own declaration, so the two cannot drift apart.

pub mod boundary;
pub mod detector;
pub mod error;
pub mod status;

pub use boundary::lumen_last_error;
pub use detector::{lumen_detector_detect, lumen_detector_floats, lumen_detector_free, lumen_detector_new, LumenDetector};
pub use error::Error;
pub use status::LumenStatus;
