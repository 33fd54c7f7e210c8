//! Axis-aligned boxes.

use crate::V3;

/// An axis-aligned box; the empty box has `min > max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: V3,
    pub max: V3,
}

impl Aabb {
    /// The box holding nothing: the identity of [`Aabb::merge`].
    pub const EMPTY: Aabb = Aabb { min: V3::new(f32::INFINITY, f32::INFINITY, f32::INFINITY), max: V3::new(f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY) };

    /// The tightest box around `points`.
    #[inline]
    pub fn of_points(points: &[V3]) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.add(*p);
        }
        b
    }

    /// Grows the box to hold `p`.
    #[inline]
    pub fn add(&mut self, p: V3) {
        self.min = self.min.inf(&p);
        self.max = self.max.sup(&p);
    }

    /// The smallest box holding both.
    #[inline]
    pub fn merge(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.inf(&o.min), max: self.max.sup(&o.max) }
    }

    /// The box grown by `r` on every side.
    #[inline]
    pub fn inflate(&self, r: f32) -> Aabb {
        let d = V3::repeat(r);
        Aabb { min: self.min - d, max: self.max + d }
    }

    /// Minkowski sum: every `a + b` with `a` in `self`, `b` in `o`.
    #[inline]
    pub fn minkowski(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min + o.min, max: self.max + o.max }
    }

    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.x <= o.max.x && o.min.x <= self.max.x && self.min.y <= o.max.y && o.min.y <= self.max.y && self.min.z <= o.max.z && o.min.z <= self.max.z
    }

    #[inline]
    pub fn contains(&self, p: V3) -> bool {
        self.overlaps(&Aabb { min: p, max: p })
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    pub fn distance2(&self, p: V3) -> f32 {
        let d = (self.min - p).sup(&(p - self.max)).sup(&V3::zeros());
        d.norm_squared()
    }
}
