#![doc = include_str!("../README.md")]
//!
//! ## Modules
//! - [`model`]: tubes and rods as owned data, their file formats and checks.
//! - [`spline`]: Catmull-Rom segments with the real knot sequence.
//! - [`broad`]: boxes, BVHs and each rod sample's place along a tube (broad phase).
//! - [`samples`]: rod samples, `x` per segment.
//! - [`section`]: tube coordinates and the signed gap to the wall.
//! - [`nearest`]: the nearest point of the continuous wall, from a section reading.
//! - [`around`]: every other wall of a sample's own section within reach, all around it.
//! - [`narrow`]: one job per pair, from located samples to contacts.
//! - [`detector`]: the per-scene object that runs a frame.
//! - [`wall`]: the continuous wall as a grid of points, for drawing it.

pub mod around;
pub mod broad;
pub mod detector;
pub mod model;
pub mod narrow;
pub mod nearest;
pub mod samples;
pub mod section;
pub mod spline;
pub mod view;
pub mod wall;

pub use detector::{Detector, FrameStats};
pub use lumen_proto as proto;
pub use lumen_proto::{Contact, ContactKind, InputError, Method, SceneSpec, SpecError, ValidScene};
pub use model::{Body, Rod, Scene, Tube};

/// The vector type of the pipeline: `f32`, in the scene's unit.
pub type V3 = nalgebra::Vector3<f32>;

/// The same vector in `f64`, for what accumulates error over many steps: midline arc lengths and
/// frames (import, scenes) and the physics's positions and velocities.
pub type V3d = nalgebra::Vector3<f64>;
