//! Errors that say what was wrong and where.

use thiserror::Error;

/// A scene spec that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpecError {
    #[error("scene declares no bodies")]
    NoBodies,
    #[error("scene declares {got} bodies; at most {max} are allowed")]
    TooManyBodies { got: usize, max: usize },
    #[error("scene declares {got} pairs; at most {max} are allowed")]
    TooManyPairs { got: usize, max: usize },
    #[error("body {body:?}: {count} control points; between {min} and {max} are allowed")]
    PointCount { body: String, count: usize, min: usize, max: usize },
    #[error("body {body:?}: {count} radial vectors per ring; between {min} and {max} are allowed")]
    SpokeCount { body: String, count: usize, min: usize, max: usize },
    #[error("body {body:?}: rod radius #{index} is {value}; radii must be finite, > 0 and at most {max:e}", max = crate::limits::MAX_COORDINATE)]
    BadRadius { body: String, index: usize, value: f32 },
    #[error("body {body:?}: {got} radii given for {points} control points; give 1 or {points}")]
    RadiusCount { body: String, got: usize, points: usize },
    #[error("body #{index}'s name is {got} bytes (it begins {start:?}); at most {max} are allowed")]
    NameTooLong { index: usize, got: usize, start: String, max: usize },
    #[error("two bodies are named {0:?}; names must be unique")]
    DuplicateName(String),
    #[error("pair #{pair} names body {name:?}, which the scene does not declare")]
    UnknownBody { pair: usize, name: String },
    #[error("pair #{pair} ({a:?}, {b:?}): {reason}")]
    BadPair { pair: usize, a: String, b: String, reason: &'static str },
    #[error("precision x = {0}; between 1 and {max} samples per segment are allowed", max = crate::limits::MAX_PRECISION)]
    Precision(u32),
    #[error("refine = {0}; between 0 and {max} re-projections are allowed", max = crate::limits::MAX_REFINE)]
    Refine(u32),
    #[error("alpha = {0}; the Catmull-Rom parameter must lie in [0, 1]")]
    Alpha(f32),
    #[error("margin = {0}; the contact margin must be finite, >= 0 and at most {max:e}", max = crate::limits::MAX_COORDINATE)]
    Margin(f32),
    #[error("the state would hold {got} floats; at most {max} are allowed")]
    StateTooLarge { got: usize, max: usize },
}

/// A per-frame input that cannot be used. The frame is rejected; nothing else is affected.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InputError {
    #[error("state has {got} floats; the scene's layout needs exactly {expected}")]
    StateLength { expected: usize, got: usize },
    #[error("body {body:?}: control point {point} has a non-finite coordinate ({value})")]
    NonFinitePoint { body: String, point: usize, value: f32 },
    #[error("body {body:?}: radial vector {spoke} of ring {ring} has a non-finite coordinate ({value})")]
    NonFiniteSpoke { body: String, ring: usize, spoke: usize, value: f32 },
    #[error("body {body:?}: control point {point} has a coordinate of {value}, beyond the {max:e} the pipeline computes with", max = crate::limits::MAX_COORDINATE)]
    OutOfRangePoint { body: String, point: usize, value: f32 },
    #[error("body {body:?}: radial vector {spoke} of ring {ring} has a coordinate of {value}, beyond the {max:e} the pipeline computes with", max = crate::limits::MAX_COORDINATE)]
    OutOfRangeSpoke { body: String, ring: usize, spoke: usize, value: f32 },
    #[error("body {body:?}: the contact of sample {sample} came out non-finite (a degenerate configuration near it); the frame is refused rather than answered with it")]
    NonFiniteResult { body: String, sample: usize },
    #[error("body {body:?}: ring {ring} is not star-shaped about its control point (radial vectors {spoke} and {next} turn backwards)")]
    NotStarShaped { body: String, ring: usize, spoke: usize, next: usize },
}
