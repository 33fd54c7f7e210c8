//! Samples along a rod: `x` per segment on its Catmull-Rom midline, counted with integers.
//!
//! Segment `j` gives samples `j * x + s` at `u = s / x` for `s < x`; the last control point is
//! one more sample, so a rod of `A` points has `(A - 1) * x + 1` samples. Radii are interpolated
//! linearly between control points.

use crate::broad::aabb::Aabb;
use crate::spline::Cubic;
use crate::view::RodView;
use crate::V3;

/// One frame's samples of one rod, in local coordinates. Buffers are reused across frames.
#[derive(Debug, Clone, Default)]
pub struct RodSamples {
    pub pos: Vec<V3>,
    pub radius: Vec<f32>,
    /// Arc length from the first sample along the sampled polyline, once
    /// [`RodSamples::measure_arc`] has run this frame.
    pub arc: Vec<f32>,
    /// Cubic of each segment.
    pub cubic: Vec<Cubic>,
    /// Samples per segment.
    pub x: usize,
    /// Largest radius of the rod.
    pub max_radius: f32,
    /// Smallest radius of the rod.
    pub min_radius: f32,
}

impl RodSamples {
    /// Samples of `rod` with per-point radii from `radius(i)`.
    pub fn fill(&mut self, rod: &RodView, radius: impl Fn(usize) -> f32, x: usize, alpha: f32) {
        let segs = rod.points - 1;
        let n = segs * x + 1;
        self.x = x;
        self.pos.clear();
        self.radius.clear();
        self.arc.clear();
        self.cubic.clear();
        self.max_radius = 0.0;
        self.min_radius = f32::INFINITY;
        let inv = 1.0 / x as f32;
        for j in 0..segs {
            let c = Cubic::of_chain(|i| rod.point(i), rod.points, j, alpha);
            self.cubic.push(c);
            let (r0, r1) = (radius(j), radius(j + 1));
            self.max_radius = self.max_radius.max(r0).max(r1);
            self.min_radius = self.min_radius.min(r0).min(r1);
            for s in 0..x {
                let u = s as f32 * inv;
                self.pos.push(c.at(u));
                self.radius.push(r0 + (r1 - r0) * u);
            }
        }
        self.pos.push(rod.point(segs));
        self.radius.push(radius(segs));
        debug_assert_eq!(self.pos.len(), n);
    }

    /// Fills [`RodSamples::arc`] (only self contact needs it: a square root per sample).
    pub fn measure_arc(&mut self) {
        self.arc.clear();
        let mut acc = 0.0;
        self.arc.push(0.0);
        for w in self.pos.windows(2) {
            acc += (w[1] - w[0]).norm();
            self.arc.push(acc);
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Segment and parameter of sample `s`.
    #[inline]
    pub fn segment_of(&self, s: usize) -> (usize, f32) {
        let segs = self.cubic.len();
        let j = (s / self.x).min(segs - 1);
        (j, (s - j * self.x) as f32 / self.x as f32)
    }

    /// Samples belonging to segment `j`: its own `x` plus the next segment's first (its end).
    #[inline]
    pub fn of_segment(&self, j: usize) -> std::ops::Range<usize> {
        j * self.x..(j * self.x + self.x + 1).min(self.pos.len())
    }

    /// Conservative box of segment `j`: the Bezier hull grown by the radius and `pad`.
    #[inline]
    pub fn leaf(&self, j: usize, pad: f32) -> Aabb {
        self.cubic[j].bounds().inflate(self.max_radius + pad)
    }
}
