//! Bounds on every count a client can send. The daemon sizes shared memory from them, so a
//! client can never make it allocate without bound.

/// Fewest control points of a body: two make one straight segment.
pub const MIN_POINTS: usize = 2;
/// Most control points (rings) of one body.
pub const MAX_POINTS: usize = 65_536;
/// Fewest radial vectors per ring of a tube: a triangle is the smallest section.
pub const MIN_SPOKES: usize = 3;
/// Most radial vectors per ring of a tube.
pub const MAX_SPOKES: usize = 256;
/// Most bodies in one scene.
pub const MAX_BODIES: usize = 64;
/// Most declared pairs in one scene.
pub const MAX_PAIRS: usize = 256;
/// Highest precision `x` (samples per segment).
pub const MAX_PRECISION: u32 = 64;
/// Most axial re-projections (`refine`) of the signed method.
pub const MAX_REFINE: u32 = 4;
/// Most other walls an interior sample of the signed method is held by besides its nearest
/// one, each a contact flagged `FLAG_OTHER_WALL`: walls all around it where the lumen is
/// narrower than the rod's reach, and with `nearest` a corner's or a pocket's.
pub const MAX_OTHER_WALLS: usize = 3;
/// Longest body name and client name, in bytes (UTF-8): names are echoed in errors and in every
/// status report, so they are bounded well below the control request's 4 MiB.
pub const MAX_NAME_BYTES: usize = 128;
/// Most `f32` values in one frame's state (64 MiB of floats).
pub const MAX_STATE_FLOATS: usize = 16 * 1024 * 1024;

/// The largest magnitude a state value may have, in the scene's unit (1e9: a kilometre in
/// micrometres, a thousand kilometres in millimetres). The pipeline forms products of up to
/// four coordinates in `f32` (largest finite value about 3.4e38), so values beyond this could
/// overflow to infinity; frames holding one are refused with [`crate::wire::Status::OutOfRange`].
/// A spec's rod radii and `margin` are bounded by it too.
pub const MAX_COORDINATE: f32 = 1e9;
