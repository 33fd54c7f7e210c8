//! Narrow phases: from located samples and candidate places to contacts, one contact per rod
//! sample and pair (with the scene's `nearest`, an interior sample also gets one for each other
//! wall within the margin). One job per declared pair, resolved once ([`Job`]):
//!
//! - [`rod_in_tube`]: a rod inside a tube, the default signed method;
//! - [`thesis`]: a rod inside a tube, the published method (nearest-sample proximity list,
//!   unsigned sector test), kept as the baseline;
//! - [`rod_on_tube`]: a rod against the outside of a tube;
//! - [`rod_rod`]: rod against rod; [`rod_self`]: a rod against itself. Shared by both methods.

pub mod rod_in_tube;
pub mod rod_on_tube;
pub mod rod_rod;
pub mod rod_self;
pub mod thesis;

use crate::samples::RodSamples;
use crate::section::Gap;
use crate::V3;
use lumen_proto::contact::{FLAG_NOT_STAR, FLAG_OUTSIDE};
use lumen_proto::Contact;

/// What one declared pair computes each frame, resolved once from its kind, its bodies' shapes
/// and the method; each holds its bodies' slots and its buffers.
#[derive(Debug, Clone)]
pub enum Job {
    /// Interior, signed method.
    RodInTube(rod_in_tube::RodInTube),
    /// Interior, published method (boxed: its buffers are many).
    Thesis(Box<thesis::Thesis>),
    /// A rod against the outside of a tube.
    RodOnTube(rod_on_tube::RodOnTube),
    /// Two rods.
    RodRod(rod_rod::RodRod),
    /// A rod against itself.
    RodSelf(rod_self::RodSelf),
}

/// Tunables of the signed narrow phases.
#[derive(Debug, Clone, Copy)]
pub struct SignedParams {
    /// Axial re-projections of every section reading ([`crate::section::TubeCache::gap`]).
    pub refine: u32,
    /// Whether contacts are moved to the nearest point of the continuous wall.
    pub nearest: bool,
}

/// How much nearer than the margin the section reading of a sample must put it before its
/// nearest wall point is sought, in units of the margin: the section's foot is a wall point,
/// so the true distance is never larger than its distance, but the tangent-plane distance
/// the section reports can be (where the wall curves away along the tube).
pub const NEAREST_REACH: f32 = 2.0;

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
    /// A contact with sample `s` of rod `a` filled in; the caller fills `b`'s side.
    #[inline]
    pub(crate) fn contact(&self, a: &RodSamples, s: usize, point_a: V3, point_b: V3, normal: V3, depth: f32) -> Contact {
        let (seg_a, u_a) = a.segment_of(s);
        Contact {
            pair: self.pair,
            kind: self.kind,
            flags: 0,
            body_a: self.body_a,
            body_b: self.body_b,
            sample: s as u32,
            segment_a: seg_a as u32,
            param_a: u_a,
            point_a: arr(point_a + self.origin),
            point_b: arr(point_b + self.origin),
            normal: arr(normal),
            depth,
            ..Contact::default()
        }
    }

    /// A contact of sample `s` of `rod` against a tube wall (of `spokes` spokes) read as `g`;
    /// `normal` points from the rod towards the wall.
    pub(crate) fn on_tube(&self, rod: &RodSamples, s: usize, g: &Gap, depth: f32, normal: V3, spokes: usize) -> Contact {
        let r = rod.radius[s];
        let p = rod.pos[s];
        let mut c = self.contact(rod, s, p + normal * r, g.wall, normal, depth);
        c.index_b = g.seg as u32;
        c.spoke_b = g.k as u32;
        c.param_b = g.u;
        c.weights_b = g.weights();
        debug_assert!(g.k < spokes);
        c.flags = if g.not_star { FLAG_NOT_STAR } else { 0 } | if g.sd > 0.0 && self.kind == 0 { FLAG_OUTSIDE } else { 0 };
        c
    }
}
