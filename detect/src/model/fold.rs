//! Spokes that reach past another ring's plane, and the tube without them ([`Tube::unfold`]).
//!
//! Where a tube bends tighter than its lumen is wide, the planes of the rings around the bend
//! cross inside the lumen, on the inside of the bend. A spoke longer than its way to such a
//! crossing puts its stretch of wall on the far side of another ring's section, inside that
//! section: the swept wall passes over itself, and what lies beyond the crossing is a wall that
//! is not there (the lumen goes on, in the other section). Contacts read against it hold the
//! scope where nothing does, and a sample near it is read in one section one frame and in
//! another the next; the generated `tight-bend` colon's scope pressed 1.6 mm into such walls
//! (docs/measurements.md).
//!
//! A spoke of ring `i` from control point `C_i` along unit `d` meets the plane of ring `j`
//! (point `C_j`, unit normal `n_j` along the midline) at
//!
//! ```text
//! t_j = -((C_i - C_j) . n_j) / (d . n_j)
//! ```
//!
//! where it crosses to the wrong side: past the plane of a later ring (`j > i`, `d . n_j > 0`,
//! `C_i` behind it) or behind an earlier one (`j < i`, `d . n_j < 0`). A crossing counts only
//! where it lies within ring `j`'s own reach (its longest spoke) of `C_j`: elsewhere the two
//! planes meet outside both sections (a gentle bend's planes cross far outside the lumen). Each
//! spoke longer than [`KEEP`] of its nearest crossing within [`WINDOW`] rings is shortened to
//! that, along its own direction, so it stays in its ring's plane; the rest of the wall is left
//! as it was. The room left ([`KEEP`]) is for the wall to give outward (a simulator moves spoke
//! tips outward where the scope presses) without passing the crossing.
//!
//! The ring normals are the ones the detector reads ([`ring_plane`]): each ring's area normal
//! from four of its spokes, oriented along the chord through its neighbours, the chord itself
//! where the ring is collapsed. Shortening a spoke along itself leaves a planar ring's
//! plane as it was, so one pass is enough. Computed in `f64`, relative to each ring's point.

use super::Tube;
use crate::section::ring_plane;

/// Rings each way whose planes a spoke is checked against: a bend's planes cross within a few
/// centimetres of arc at the rings' usual millimetre spacing.
pub const WINDOW: usize = 64;

/// The part of its way to the nearest crossing a shortened spoke keeps.
pub const KEEP: f64 = 0.8;

/// What [`Tube::unfold`] shortened.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FoldReport {
    /// Spokes shortened.
    pub spokes: usize,
    /// Rings with a shortened spoke.
    pub rings: usize,
    /// First and last ring with a shortened spoke.
    pub ring_range: Option<(usize, usize)>,
    /// Largest shortening of one spoke (scene's unit), and the largest as a fraction of its
    /// length.
    pub max_cut: f64,
    pub max_cut_fraction: f64,
}

type V = nalgebra::Vector3<f64>;

fn v(a: [f32; 3]) -> V {
    V::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

impl Tube {
    /// Shortens every spoke that reaches past another ring's plane within that ring's reach (see
    /// the module), to [`KEEP`] of its way there; says what it shortened. A tube whose ring
    /// planes cross nowhere inside its lumen is left exactly as it was.
    pub fn unfold(&mut self) -> FoldReport {
        let (n, b) = (self.rings(), self.spokes);
        let normals: Vec<V> = (0..n).map(|i| self.ring_normal(i)).collect();
        let reach: Vec<f64> = (0..n).map(|i| (0..b).map(|k| v(self.spoke(i, k)).norm()).fold(0.0, f64::max)).collect();
        let mut report = FoldReport::default();
        let mut shortened = Vec::new();
        for i in 0..n {
            let c = v(self.points[i]);
            let mut any = false;
            for k in 0..b {
                let s = v(self.spoke(i, k));
                let len = s.norm();
                if len <= 0.0 {
                    continue;
                }
                let d = s / len;
                let mut way = f64::INFINITY;
                for j in i.saturating_sub(WINDOW)..(i + WINDOW + 1).min(n) {
                    if j == i {
                        continue;
                    }
                    let (nj, cj) = (normals[j], v(self.points[j]));
                    let (dist, dn) = ((c - cj).dot(&nj), d.dot(&nj));
                    let wrong_way = if j > i { dist < 0.0 && dn > 0.0 } else { dist > 0.0 && dn < 0.0 };
                    if wrong_way {
                        let t = -dist / dn;
                        if t < way && (c + d * t - cj).norm() <= reach[j] {
                            way = t;
                        }
                    }
                }
                let keep = KEEP * way;
                // Beyond rounding: a spoke already shortened here stays as it is.
                if keep < len * (1.0 - 1e-6) {
                    shortened.push((i * b + k, d * keep));
                    report.spokes += 1;
                    report.max_cut = report.max_cut.max(len - keep);
                    report.max_cut_fraction = report.max_cut_fraction.max(1.0 - keep / len);
                    any = true;
                }
            }
            if any {
                report.rings += 1;
                report.ring_range = Some(report.ring_range.map_or((i, i), |(a, _)| (a, i)));
            }
        }
        for (at, s) in shortened {
            self.radial[at] = [s.x as f32, s.y as f32, s.z as f32];
        }
        report
    }

    /// Ring `i`'s plane normal as the detector reads it ([`ring_plane`]), in `f64`.
    fn ring_normal(&self, i: usize) -> V {
        let (n, b) = (self.rings(), self.spokes);
        let chord = v(self.points[(i + 1).min(n - 1)]) - v(self.points[i.saturating_sub(1)]);
        ring_plane(chord, [0, b / 4, b / 2, 3 * b / 4].map(|k| v(self.spoke(i, k)))).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tube of `spokes` round rings of radius `r` every `h` along a quarter circle of radius
    /// `bend` (in the x-y plane, about the origin) between two straight runs of `run` rings.
    fn bent(r: f32, bend: f64, h: f64, run: usize, spokes: usize) -> Tube {
        let mut frames: Vec<(V, V)> = Vec::new(); // (point, tangent)
        for m in (1..=run).rev() {
            frames.push((V::new(bend, -(m as f64) * h, 0.0), V::y()));
        }
        let arc = ((std::f64::consts::FRAC_PI_2 * bend) / h).round() as usize;
        for m in 0..=arc {
            let a = std::f64::consts::FRAC_PI_2 * m as f64 / arc as f64;
            frames.push((V::new(bend * a.cos(), bend * a.sin(), 0.0), V::new(-a.sin(), a.cos(), 0.0)));
        }
        for m in 1..=run {
            frames.push((V::new(-(m as f64) * h, bend, 0.0), -V::x()));
        }
        let mut points = Vec::new();
        let mut radial = Vec::new();
        for (p, t) in frames {
            points.push([p.x as f32, p.y as f32, p.z as f32]);
            let e1 = t.cross(&V::z()).normalize();
            for k in 0..spokes {
                let a = std::f64::consts::TAU * k as f64 / spokes as f64;
                let s = (e1 * a.cos() + V::z() * a.sin()) * r as f64;
                radial.push([s.x as f32, s.y as f32, s.z as f32]);
            }
        }
        Tube::new(points, radial, spokes).unwrap()
    }

    #[test]
    fn a_bend_wider_than_the_lumen_is_left_as_it_was() {
        let mut t = bent(10.0, 60.0, 1.0, 30, 16);
        let before = t.clone();
        assert_eq!(t.unfold(), FoldReport::default());
        assert_eq!(t, before);
    }

    #[test]
    fn a_bend_tighter_than_the_lumen_keeps_every_spoke_before_the_crossings() {
        // Bend radius 6 against a lumen of 10: the arc's planes cross 6 from the midline, inside.
        let mut t = bent(10.0, 6.0, 0.5, 40, 16);
        let before = t.clone();
        let r = t.unfold();
        assert!(r.spokes > 0 && r.max_cut > 3.0, "{r:?}");
        let (first, last) = r.ring_range.unwrap();
        // Only rings near the bend change, and only their length: directions are kept.
        assert!(first > 10 && last < t.rings() - 10, "{r:?}");
        for (a, b) in t.radial.iter().zip(&before.radial) {
            let (a, b) = (v(*a), v(*b));
            assert!(a.norm() <= b.norm() + 1e-6 && (a.normalize() - b.normalize()).norm() < 1e-5);
        }
        // Outside the bend (away from the centre of curvature at the origin) nothing changed.
        for i in 0..t.rings() {
            let c = v(t.points[i]);
            for k in 0..t.spokes {
                if v(before.spoke(i, k)).dot(&-c) <= 0.0 {
                    assert_eq!(t.spoke(i, k), before.spoke(i, k), "ring {i} spoke {k}");
                }
            }
        }
        // Afterwards no spoke tip lies past a later ring's plane or behind an earlier one's within
        // that ring's reach: the check finds nothing more to shorten.
        assert_eq!(t.clone().unfold(), FoldReport::default());
        // The inner spokes at the bend's middle end before the centre of curvature (6 away).
        let mid = t.rings() / 2;
        let inner = (0..t.spokes).map(|k| v(t.spoke(mid, k))).map(|s| s.dot(&-v(t.points[mid]).normalize())).fold(0.0, f64::max);
        assert!(inner < 6.0, "{inner}");
    }

    #[test]
    fn scaling_the_tube_scales_the_cuts() {
        let (mut a, mut m) = (bent(10.0, 6.0, 0.5, 40, 16), bent(10.0, 6.0, 0.5, 40, 16));
        for p in m.points.iter_mut().chain(m.radial.iter_mut()) {
            *p = p.map(|c| c * 1e-3);
        }
        let (ra, rm) = (a.unfold(), m.unfold());
        assert_eq!((ra.spokes, ra.rings, ra.ring_range), (rm.spokes, rm.rings, rm.ring_range));
        assert!((rm.max_cut * 1e3 - ra.max_cut).abs() < 1e-3 * ra.max_cut, "{ra:?} {rm:?}");
    }
}
