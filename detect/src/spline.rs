//! Catmull-Rom segments with the real knot sequence (Yuksel, Schaefer & Keyser 2011).
//!
//! The segment between `P1` and `P2` uses `P0..P3` with knot gaps `dt_j = |P_{j+1} - P_j|^alpha`
//! (`alpha` 0 uniform, 0.5 centripetal, 1 chordal). In Hermite form over `u` in [0, 1]:
//!
//! ```text
//! m1 = dt1 * ((P1 - P0)/dt0 - (P2 - P0)/(dt0 + dt1) + (P2 - P1)/dt1)
//! m2 = dt1 * ((P2 - P1)/dt1 - (P3 - P1)/(dt1 + dt2) + (P3 - P2)/dt2)
//! C(u) = c0 + c1 u + c2 u^2 + c3 u^3,  c0 = P1, c1 = m1,
//!        c2 = 3 (P2 - P1) - 2 m1 - m2,  c3 = 2 (P1 - P2) + m1 + m2
//! ```
//!
//! This is the Barry-Goldman pyramid of the thesis (its equations 3-9) evaluated exactly; its
//! Bezier control points `P1, P1 + m1/3, P2 - m2/3, P2` bound the curve (convex hull).
//!
//! Degenerate input never divides by zero: a zero chord next to the segment is replaced by the
//! reflection of the segment (as at the two ends of a body, where `P0` or `P3` is missing), and
//! a zero-length segment is the constant point.

use crate::broad::aabb::Aabb;
use crate::V3;

/// One cubic segment `C(u) = c[0] + c[1] u + c[2] u^2 + c[3] u^3`, `u` in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cubic {
    pub c: [V3; 4],
}

impl Default for Cubic {
    fn default() -> Self {
        Self { c: [V3::zeros(); 4] }
    }
}

/// Knot gap `d^alpha` for a chord of length `d`, with the three named cases exact and cheap.
#[inline]
fn gap(d: f32, alpha: f32) -> f32 {
    if alpha == 0.5 {
        d.sqrt()
    } else if alpha == 0.0 {
        1.0
    } else if alpha == 1.0 {
        d
    } else {
        d.powf(alpha)
    }
}

impl Cubic {
    /// The segment from `p[1]` to `p[2]`; `p[0]` / `p[3]` are `None` at a body's ends.
    pub fn catmull_rom(p0: Option<V3>, p1: V3, p2: V3, p3: Option<V3>, alpha: f32) -> Self {
        let d1 = (p2 - p1).norm();
        let d0 = p0.map_or(0.0, |p| (p1 - p).norm());
        let d2 = p3.map_or(0.0, |p| (p - p2).norm());
        // Chords below this are "coincident": relative, so the unit never matters.
        let tiny = 1e-6 * d0.max(d1).max(d2);
        if d1 <= tiny {
            return Self { c: [p1, V3::zeros(), V3::zeros(), V3::zeros()] };
        }
        let (p0, d0) = match p0 {
            Some(p) if d0 > tiny => (p, d0),
            _ => (p1 * 2.0 - p2, d1),
        };
        let (p3, d2) = match p3 {
            Some(p) if d2 > tiny => (p, d2),
            _ => (p2 * 2.0 - p1, d1),
        };
        let (t0, t1, t2) = (gap(d0, alpha), gap(d1, alpha), gap(d2, alpha));
        // The formulas above with the common factor t1 folded into five scalar ratios: five
        // divisions instead of eighteen per segment.
        let m1 = (p1 - p0) * (t1 / t0) - (p2 - p0) * (t1 / (t0 + t1)) + (p2 - p1);
        let m2 = (p2 - p1) - (p3 - p1) * (t1 / (t1 + t2)) + (p3 - p2) * (t1 / t2);
        Self { c: [p1, m1, (p2 - p1) * 3.0 - m1 * 2.0 - m2, (p1 - p2) * 2.0 + m1 + m2] }
    }

    /// Segment `i` (from point `i` to `i + 1`) of a chain of `n` points read through `at`.
    #[inline]
    pub fn of_chain(at: impl Fn(usize) -> V3, n: usize, i: usize, alpha: f32) -> Self {
        let p0 = (i > 0).then(|| at(i - 1));
        let p3 = (i + 2 < n).then(|| at(i + 2));
        Self::catmull_rom(p0, at(i), at(i + 1), p3, alpha)
    }

    /// Position at `u`.
    #[inline]
    pub fn at(&self, u: f32) -> V3 {
        let c = &self.c;
        c[0] + (c[1] + (c[2] + c[3] * u) * u) * u
    }

    /// Derivative `dC/du` at `u`.
    #[inline]
    pub fn tangent(&self, u: f32) -> V3 {
        let c = &self.c;
        c[1] + (c[2] * 2.0 + c[3] * (3.0 * u)) * u
    }

    /// The Bezier control points, whose hull holds the whole segment.
    #[inline]
    pub fn bezier(&self) -> [V3; 4] {
        let c = &self.c;
        let p1 = c[0];
        let p2 = c[0] + c[1] + c[2] + c[3];
        let m2 = c[1] + c[2] * 2.0 + c[3] * 3.0;
        [p1, p1 + c[1] / 3.0, p2 - m2 / 3.0, p2]
    }

    /// A box holding the whole segment.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::of_points(&self.bezier())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> V3 {
        V3::new(x, y, z)
    }

    #[test]
    fn interpolates_its_ends_and_uniform_matches_the_matrix_form() {
        let p = [v(0., 0., 0.), v(1., 2., 0.), v(3., 3., 1.), v(4., 0., 2.)];
        for alpha in [0.0, 0.5, 1.0] {
            let c = Cubic::catmull_rom(Some(p[0]), p[1], p[2], Some(p[3]), alpha);
            assert!((c.at(0.0) - p[1]).norm() < 1e-6);
            assert!((c.at(1.0) - p[2]).norm() < 1e-5);
        }
        // Thesis equation 10 (uniform): 0.5 * [1 t t^2 t^3] M [P0..P3].
        let c = Cubic::catmull_rom(Some(p[0]), p[1], p[2], Some(p[3]), 0.0);
        let t = 0.3f32;
        let w = [0.5 * (-t + 2. * t * t - t * t * t), 0.5 * (2. - 5. * t * t + 3. * t * t * t), 0.5 * (t + 4. * t * t - 3. * t * t * t), 0.5 * (-t * t + t * t * t)];
        let m = p[0] * w[0] + p[1] * w[1] + p[2] * w[2] + p[3] * w[3];
        assert!((c.at(t) - m).norm() < 1e-5);
    }

    #[test]
    fn centripetal_matches_barry_goldman_pyramid() {
        // Thesis equations 3-9, evaluated literally with knots t0 = 0.
        let p = [v(0., 0., 0.), v(0.2, 1.0, 0.), v(3., 1.5, 0.5), v(3.2, 5., 0.)];
        let mut t = [0f32; 4];
        for i in 1..4 {
            t[i] = t[i - 1] + (p[i] - p[i - 1]).norm().sqrt();
        }
        let lerp = |a: V3, b: V3, ta: f32, tb: f32, x: f32| a * ((tb - x) / (tb - ta)) + b * ((x - ta) / (tb - ta));
        let c = Cubic::catmull_rom(Some(p[0]), p[1], p[2], Some(p[3]), 0.5);
        for k in 0..=10 {
            let u = k as f32 / 10.0;
            let x = t[1] + u * (t[2] - t[1]);
            let a1 = lerp(p[0], p[1], t[0], t[1], x);
            let a2 = lerp(p[1], p[2], t[1], t[2], x);
            let a3 = lerp(p[2], p[3], t[2], t[3], x);
            let b1 = lerp(a1, a2, t[0], t[2], x);
            let b2 = lerp(a2, a3, t[1], t[3], x);
            let cc = lerp(b1, b2, t[1], t[2], x);
            assert!((c.at(u) - cc).norm() < 1e-5, "u = {u}: {} vs {}", c.at(u), cc);
        }
    }

    #[test]
    fn coincident_points_stay_finite() {
        let a = v(1., 1., 1.);
        let c = Cubic::catmull_rom(Some(a), a, v(2., 1., 1.), Some(v(2., 1., 1.)), 0.5);
        assert!(c.c.iter().all(|x| x.iter().all(|f| f.is_finite())));
        let c = Cubic::catmull_rom(Some(a), a, a, Some(a), 0.5);
        assert_eq!(c.at(0.7), a);
    }

    #[test]
    fn bezier_hull_bounds_the_curve() {
        let p = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(-3., 1., 0.)];
        let c = Cubic::catmull_rom(Some(p[0]), p[1], p[2], Some(p[3]), 0.5);
        let b = c.bounds();
        for k in 0..=100 {
            assert!(b.contains(c.at(k as f32 / 100.0)));
        }
    }
}
