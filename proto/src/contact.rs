//! The contact record: one per rod sample in contact (and per other wall it touches, see
//! [`FLAG_OTHER_WALL`]), `#[repr(C)]` so it travels as plain bytes.

use serde::{Deserialize, Serialize};

/// Which contacts a pair computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum ContactKind {
    /// Rod inside a tube (the colonoscopy case): the wall keeps the rod in.
    Interior = 0,
    /// Rod against another rod, or against the outside of a tube.
    Exterior = 1,
    /// A rod against its own non-adjacent segments (a loop touching itself).
    #[serde(rename = "self")]
    SelfContact = 2,
}

impl ContactKind {
    /// The kind stored in [`Contact::kind`], if valid.
    pub fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::Interior),
            1 => Some(Self::Exterior),
            2 => Some(Self::SelfContact),
            _ => None,
        }
    }
}

/// Flag: the tube section involved is not star-shaped about its control point; the contact is
/// computed on the section as given but its geometry is unreliable.
pub const FLAG_NOT_STAR: u8 = 1;
/// Flag: the rod sample lies outside the wall (interior contacts) — the case the published
/// method loses.
pub const FLAG_OUTSIDE: u8 = 2;

/// Flag: another contact of the same rod sample with the same tube (interior contacts of the
/// signed method): another wall within the margin, facing the sample from a direction more
/// than 30 degrees from its first contact's and from its other ones' (a lumen narrower than
/// the rod, pressing on it all around; with the scene's `nearest` also the scope's end between
/// the side wall and a fold ahead of it, or in a pocket between several). Its depth, normal and
/// wall point are that wall's. A sample has at most four contacts per pair: its first (its
/// nearest wall, unflagged) and up to three flagged ones after it.
pub const FLAG_OTHER_WALL: u8 = 4;

/// `index_b`/`spoke_b` value meaning "not a tube".
pub const NO_SPOKE: u32 = u32::MAX;

/// One contact between a sample of rod `a` and body `b`.
///
/// Sign convention: `normal` points from `a` towards `b`'s surface at the contact (for an
/// interior contact: the wall's outward normal). `depth > 0` means the bodies overlap by that
/// much; separating them moves `a` by `-depth * normal` (or shares it with `b`).
/// Lengths are in the scene's unit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
pub struct Contact {
    /// Index of the pair in the scene spec.
    pub pair: u16,
    /// [`ContactKind`] as `u8`.
    pub kind: u8,
    /// `FLAG_*` bits.
    pub flags: u8,
    /// Body index of the rod.
    pub body_a: u16,
    /// Body index of the other body.
    pub body_b: u16,
    /// Sample index along rod `a` (segment * x + step).
    pub sample: u32,
    /// Rod segment (between control points `segment_a` and `segment_a + 1`).
    pub segment_a: u32,
    /// Parameter of the sample within that segment, in [0, 1].
    pub param_a: f32,
    /// Tube: the ring pair (`index_b`, `index_b + 1`). Rod: the segment.
    pub index_b: u32,
    /// Tube: the spoke pair (`spoke_b`, `spoke_b + 1` mod B). Rod: [`NO_SPOKE`].
    pub spoke_b: u32,
    /// Parameter along segment `index_b`, in [0, 1].
    pub param_b: f32,
    /// Tube: weights of the wall tips (ring, spoke), (ring, spoke+1), (ring+1, spoke),
    /// (ring+1, spoke+1), summing to 1. Rod: weights of control points `index_b` and
    /// `index_b + 1`, then zeros.
    pub weights_b: [f32; 4],
    /// The point of `a`'s surface deepest in `b`.
    pub point_a: [f32; 3],
    /// The nearest point on `b`'s surface.
    pub point_b: [f32; 3],
    /// Unit normal, from `a` towards `b` (see above).
    pub normal: [f32; 3],
    /// Penetration depth, positive when overlapping.
    pub depth: f32,
}

const _: () = assert!(std::mem::size_of::<Contact>() == 88);
const _: () = assert!(std::mem::align_of::<Contact>() == 4);
