//! Lumen's wire types, shared by the pipeline, the daemon and every client.
//!
//! - [`scene`]: what a client declares once: bodies, which pairs and contact kinds to compute,
//!   precision and method (serde, JSON-friendly).
//! - [`state`]: where each body's floats live in the flat per-frame `f32` slice.
//! - [`valid`]: a scene that passed validation, with its pairs and layout resolved once.
//! - [`contact`]: the `#[repr(C)]` contact record the pipeline emits.
//! - [`auth`]: the session secret and the BLAKE3 tags that prove ownership.
//! - [`limits`] and [`error`]: bounds on every count and the errors that name what was wrong.
//!
//! No I/O happens here.

pub mod auth;
pub mod contact;
pub mod error;
pub mod limits;
pub mod scene;
pub mod session;
pub mod state;
pub mod valid;
pub mod wire;
#[cfg(feature = "iceoryx2")]
pub mod zero_copy;

pub use contact::{Contact, ContactKind};
pub use error::{InputError, SpecError};
pub use scene::{BodySpec, Method, PairSpec, SceneSpec, Shape};
pub use state::{BodyLayout, StateLayout};
pub use valid::{PairIndex, ValidScene};
