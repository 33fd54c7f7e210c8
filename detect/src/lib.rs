#![doc = include_str!("../README.md")]
//!
//! ## Modules
//! - [`model`]: tubes and rods as owned data, their file formats and checks.
//! - [`spline`]: Catmull-Rom segments with the real knot sequence.
//! - [`aabb`], [`bvh`]: boxes and the bottom-up chain BVH (broad phase).
//! - [`samples`]: rod samples, `x` per segment.
//! - [`section`]: tube coordinates and the signed gap to the wall.
//! - [`nearest`]: the nearest point of the continuous wall, from a section reading.
//! - [`narrow`]: the narrow phases (signed, thesis, rod-rod).
//! - [`detector`]: the per-scene object that runs a frame.

pub mod aabb;
pub mod bvh;
pub mod detector;
pub mod model;
pub mod narrow;
pub mod nearest;
pub mod samples;
pub mod section;
pub mod spline;
pub mod view;

pub use detector::{Detector, FrameStats};
pub use lumen_proto as proto;
pub use lumen_proto::{Contact, ContactKind, InputError, Method, SceneSpec, SpecError};
pub use model::{Body, Rod, Scene, Tube};

/// The vector type of the pipeline: `f32`, in the scene's unit.
pub type V3 = nalgebra::Vector3<f32>;
