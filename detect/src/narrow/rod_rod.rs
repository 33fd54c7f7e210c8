//! Rod against rod; the test [`rod_self`](super::rod_self) shares.
//!
//! Candidates come from the dual traversal of the two rods' BVHs (leaves: Bezier hull grown by
//! the radius). Each sample of rod `a` is tested against the sampled polyline of rod `b` within
//! the candidate segments; per sample the deepest wins, so a sample gives at most one contact.
//!
//! Self contact skips sample pairs closer along the rod than `pi * (ra + rb) / 2`: a rod of
//! radius `r` cannot bend tighter than a half circle of radius `r` before its surface meets
//! itself, so anything nearer along the arc is the rod's own neighbourhood, not a loop.

use super::Emit;
use crate::broad::RodFrame;
use crate::V3;
use lumen_proto::contact::NO_SPOKE;
use lumen_proto::Contact;

/// Best contact found so far for one sample of rod `a`.
#[derive(Debug, Clone, Copy)]
pub struct Best {
    depth: f32,
    seg_b: u32,
    u_b: f32,
    point_b: V3,
    normal: V3,
}

impl Default for Best {
    fn default() -> Self {
        Self { depth: f32::NEG_INFINITY, seg_b: 0, u_b: 0.0, point_b: V3::zeros(), normal: V3::z() }
    }
}

/// The job of one pair of two rods: their slots, and each sample of `a`'s best contact so far.
#[derive(Debug, Clone, Default)]
pub struct RodRod {
    pub a: usize,
    pub b: usize,
    best: Vec<Best>,
}

impl RodRod {
    /// The job for rod slots `a` and `b` (`a != b`).
    pub fn new(a: usize, b: usize) -> Self {
        Self { a, b, best: Vec::new() }
    }

    /// This frame's contacts of `a`'s samples on `b`, appended to `out`; returns the candidate
    /// leaf pairs.
    #[inline]
    pub fn run(&mut self, a: RodFrame, b: RodFrame, emit: &Emit, out: &mut Vec<Contact>) -> u32 {
        rod_rod(a, b, false, &mut self.best, emit, out)
    }
}

/// Contacts between samples of `a` and the surface of `b` (`same`: `a` and `b` are one rod);
/// returns the candidate leaf pairs.
pub fn rod_rod(a: RodFrame, b: RodFrame, same: bool, best: &mut Vec<Best>, emit: &Emit, out: &mut Vec<Contact>) -> u32 {
    let (RodFrame { samples: a, bvh: a_bvh }, RodFrame { samples: b, bvh: b_bvh }) = (a, b);
    best.clear();
    best.resize(a.len(), Best::default());
    let mut candidates = 0;
    // On one rod, neighbouring segments always overlap: skip a leaf pair outright when no two
    // of its samples lie far enough apart along the rod (the exclusion below would reject
    // every sample pair anyway).
    let min_sep = std::f32::consts::PI * a.min_radius;
    a_bvh.pairs(b_bvh, |ja, jb| {
        let rb_range = b.of_segment(jb);
        if same {
            let ra_range = a.of_segment(ja);
            let far = (b.arc[rb_range.end - 1] - a.arc[ra_range.start]).abs().max((a.arc[ra_range.end - 1] - b.arc[rb_range.start]).abs());
            if far < min_sep {
                return;
            }
        }
        candidates += 1;
        for s in a.of_segment(ja) {
            let p = a.pos[s];
            let ra = a.radius[s];
            for m in rb_range.start..rb_range.end - 1 {
                let (q0, q1) = (b.pos[m], b.pos[m + 1]);
                let w = q1 - q0;
                let ww = w.norm_squared();
                let l = if ww > 0.0 { ((p - q0).dot(&w) / ww).clamp(0.0, 1.0) } else { 0.0 };
                let rb = b.radius[m] + (b.radius[m + 1] - b.radius[m]) * l;
                if same {
                    let arc = b.arc[m] + (b.arc[m + 1] - b.arc[m]) * l;
                    if (arc - a.arc[s]).abs() < std::f32::consts::FRAC_PI_2 * (ra + rb) {
                        continue;
                    }
                }
                let q = q0 + w * l;
                let v = q - p;
                let d = v.norm();
                let depth = ra + rb - d;
                if depth > best[s].depth {
                    let normal = if d > 0.0 { v / d } else { crate::section::any_perpendicular(w.try_normalize(0.0).unwrap_or(V3::x())) };
                    let (seg_b, base) = b.segment_of(m);
                    let u_b = base + l / b.x as f32;
                    // The polyline's last point belongs to the last segment at parameter 1.
                    best[s] = Best { depth, seg_b: seg_b as u32, u_b: u_b.min(1.0), point_b: q - normal * rb, normal };
                }
            }
        }
    });
    for (s, bst) in best.iter().enumerate() {
        if bst.depth > -emit.margin {
            let p = a.pos[s];
            let mut c = emit.contact(a, s, p + bst.normal * a.radius[s], bst.point_b, bst.normal, bst.depth);
            c.index_b = bst.seg_b;
            c.spoke_b = NO_SPOKE;
            c.param_b = bst.u_b;
            c.weights_b = [1.0 - bst.u_b, bst.u_b, 0.0, 0.0];
            out.push(c);
        }
    }
    candidates
}
