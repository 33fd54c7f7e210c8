//! Lumen from C: the embedded detector and the daemon's client behind a C ABI, as a static or shared library
//! (`liblumen_c.a`, `liblumen_c.so`) with its header `include/lumen.h`, generated from this
//! source by cbindgen (`tests/header.rs` keeps the two equal).
//!
//! - [`status`]: the status every call returns.
//! - [`error`]: the crate's error, what each status means in words.
//! - [`boundary`]: the guard every call runs in (no panic crosses into C) and the per-thread
//!   last error (`lumen_last_error`).
//! - [`handles`]: the table of live handles every call checks (NULL, freed or foreign
//!   pointers are errors) and the thread a local object belongs to.
//! - [`text`]: strings and scene specs coming in from C.
//! - [`detector`]: `lumen_detector_*`, a [`lumen_detect::Detector`] behind an opaque handle.
//! - [`client`], [`session`], [`observer`]: `lumen_client_*`, `lumen_session_*`,
//!   `lumen_observer_*`, the Rust client ([`lumen_client`]) behind opaque handles.
//!
//! Contacts cross as [`lumen_proto::Contact`] itself: the header's `LumenContact` is emitted
//! from proto's own declaration, so the two cannot drift apart.

pub mod boundary;
pub mod client;
pub mod detector;
pub mod error;
mod handles;
pub mod observer;
pub mod session;
pub mod status;
mod text;

pub use boundary::lumen_last_error;
pub use client::{lumen_client_free, lumen_client_local, lumen_client_zenoh, LumenClient, LumenTls};
pub use detector::{lumen_detector_detect, lumen_detector_floats, lumen_detector_free, lumen_detector_new, LumenDetector};
pub use error::Error;
pub use observer::{lumen_observer_free, lumen_observer_next, lumen_observer_open, LumenObserved, LumenObservedKind, LumenObserver};
pub use session::{lumen_session_close, lumen_session_contacts, lumen_session_frame, lumen_session_id, lumen_session_open, lumen_session_reconnects, lumen_session_submit, LumenReply, LumenSession};
pub use status::LumenStatus;
