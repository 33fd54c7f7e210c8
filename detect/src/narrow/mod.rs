//! Narrow phases: from candidate places to contacts, one contact per rod sample and pair (with
//! the scene's `nearest`, an interior sample also gets one for each other wall within the margin).
//!
//! - [`signed`]: the default interior and rod-against-tube-exterior tests (signed containment
//!   with temporal coherence);
//! - [`thesis`]: the published interior test (nearest-sample proximity list, unsigned sector
//!   test), kept as the baseline;
//! - [`rods`]: rod against rod and a rod against itself, shared by both methods.

pub mod rods;
pub mod signed;
pub mod thesis;

use crate::V3;
use lumen_proto::Contact;

/// What every narrow phase needs to emit a contact in world coordinates.
#[derive(Debug, Clone, Copy)]
pub struct Emit {
    pub pair: u16,
    pub kind: u8,
    pub body_a: u16,
    pub body_b: u16,
    /// Local-to-world offset.
    pub origin: V3,
    /// Contacts are kept while `depth > -margin`.
    pub margin: f32,
}

#[inline]
pub(crate) fn arr(v: V3) -> [f32; 3] {
    [v.x, v.y, v.z]
}

impl Emit {
    /// A contact with `a`'s sample data filled in; the caller fills `b`'s side.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn contact(&self, sample: usize, seg_a: usize, u_a: f32, point_a: V3, point_b: V3, normal: V3, depth: f32) -> Contact {
        Contact {
            pair: self.pair,
            kind: self.kind,
            flags: 0,
            body_a: self.body_a,
            body_b: self.body_b,
            sample: sample as u32,
            segment_a: seg_a as u32,
            param_a: u_a,
            point_a: arr(point_a + self.origin),
            point_b: arr(point_b + self.origin),
            normal: arr(normal),
            depth,
            ..Contact::default()
        }
    }
}
