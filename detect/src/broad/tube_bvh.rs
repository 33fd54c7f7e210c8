//! The tube's BVH: one leaf per segment holding its whole wall.

use super::aabb::Aabb;
use super::bvh::ChainBvh;
use crate::section::TubeCache;
use crate::view::TubeView;

/// The tube's BVH with conservative leaves (spline bulge + every spoke of both rings), refit at
/// most once per frame and only when something needs it.
#[derive(Debug, Clone, Default)]
pub struct TubeBvh {
    pub bvh: ChainBvh,
    /// The box of each ring's radial vectors this frame ([`TubeView::spoke_box`]).
    rings: Vec<Aabb>,
    fresh: bool,
}

impl TubeBvh {
    /// Marks the boxes stale for a new frame.
    pub fn begin(&mut self) {
        self.fresh = false;
    }

    /// Refits if stale. Leaf `i` holds segment `i`'s whole wall: the Minkowski sum of the
    /// midline's Bezier hull and the box of both rings' radial vectors. A refit reads the whole
    /// tube, so each ring's spokes are read once (a ring bounds the segments on both its sides).
    pub fn ensure(&mut self, t: &TubeView, cache: &mut TubeCache) -> &ChainBvh {
        if !self.fresh {
            self.rings.clear();
            self.rings.extend((0..t.rings).map(|i| t.spoke_box(i)));
            let rings = &self.rings;
            self.bvh.build(t.segments(), |i| cache.cubic(t, i).bounds().minkowski(&rings[i].merge(&rings[i + 1])));
            self.fresh = true;
        }
        &self.bvh
    }
}
