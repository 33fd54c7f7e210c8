//! A rod against the outside of a tube (the tube as a solid): candidates from the dual traversal
//! of both BVHs, each sample read in the section of every candidate segment whose ring planes
//! bracket it; per sample the deepest candidate wins.

use super::{Emit, SignedParams, NEAREST_REACH};
use crate::broad::{Counters, RodFrame, TubeFrame};
use crate::nearest::{nearest, Search};
use crate::section::Gap;
use lumen_proto::Contact;

/// The job of one exterior pair: the rod's slot, the tube's slot, and each sample's deepest
/// candidate this frame (depth, reading).
#[derive(Debug, Clone, Default)]
pub struct RodOnTube {
    pub rod: usize,
    pub tube: usize,
    best: Vec<(f32, Gap)>,
}

impl RodOnTube {
    /// The job for rod slot `rod` against the outside of tube slot `tube`.
    pub fn new(rod: usize, tube: usize) -> Self {
        Self { rod, tube, best: Vec::new() }
    }

    /// This frame's contacts of `rod` on the outside of `tube`, appended to `out`.
    #[inline]
    pub fn run(&mut self, tube: TubeFrame, rod: RodFrame, params: SignedParams, emit: &Emit, out: &mut Vec<Contact>, counters: &mut Counters) {
        exterior(tube, rod, &mut self.best, params, emit, out, counters);
    }
}

/// Contacts of a rod against the outside of a tube; `best` is per-sample scratch.
pub fn exterior(tube: TubeFrame, rod_frame: RodFrame, best: &mut Vec<(f32, Gap)>, params: SignedParams, emit: &Emit, out: &mut Vec<Contact>, counters: &mut Counters) {
    let TubeFrame { view: t, cache, bvh } = tube;
    let RodFrame { samples: rod, bvh: rod_bvh } = rod_frame;
    let t = &t;
    best.clear();
    best.resize(rod.len(), (f32::NEG_INFINITY, Gap::default()));
    let tree = bvh.ensure(t, cache);
    rod_bvh.pairs(tree, |j, i| {
        counters.candidates += 1;
        for s in rod.of_segment(j) {
            let p = rod.pos[s];
            let d0 = (p - t.point(i)).dot(&cache.ring(t, i).n);
            let d1 = (p - t.point(i + 1)).dot(&cache.ring(t, i + 1).n);
            if d0 < 0.0 || d1 > 0.0 {
                continue;
            }
            let u = if d0 - d1 > 0.0 { d0 / (d0 - d1) } else { 0.0 };
            let g = cache.gap(t, &p, i, u, None, params.refine);
            let depth = rod.radius[s] - g.sd;
            if depth > best[s].0 {
                best[s] = (depth, g);
            }
        }
    });
    for (s, &(depth, g)) in best.iter().enumerate() {
        let r = rod.radius[s];
        let (depth, g) = if params.nearest && depth > -NEAREST_REACH * emit.margin {
            let g = nearest(t, cache, &rod.pos[s], g, 0.0, 0.0, Search::Across { own: &[], nearby: &[] }).first;
            (r - g.sd, g)
        } else {
            (depth, g)
        };
        if depth > -emit.margin {
            out.push(emit.on_tube(rod, s, &g, depth, -g.normal, t.spokes));
        }
    }
}
