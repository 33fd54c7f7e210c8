//! Spokes that reach past another ring's plane: the fold check ([`Tube::folds`]), and the tube
//! without them ([`Tube::clip_folds`], [`Tube::unfold`]).
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
//! `C_i` behind it) or behind an earlier one (`j < i`, `d . n_j < 0`), within [`WINDOW`] rings.
//!
//! - **The fold check** ([`Tube::folds`], [`Within::Section`]) counts a crossing where it lies
//!   inside ring `j`'s section, the polygon of its spoke tips, and before the spoke's own tip: a
//!   point of the lumen in two sections. Elsewhere the two planes meet outside the sections (a
//!   gentle bend's planes cross far outside the lumen; a loop's far along the tube, beyond its
//!   wall). [`Tube::clip_folds`] shortens each such spoke to [`CLIP`] of its way there, after
//!   which the check finds none; `lumen import` clips what its choice of planes leaves.
//! - **[`Tube::unfold`]** ([`Within::Reach`]), for the generated colons, counts a crossing
//!   within ring `j`'s own reach (its longest spoke) of `C_j`, and shortens each spoke longer
//!   than [`KEEP`] of its way to its nearest crossing to that. The room left is for the wall to
//!   give outward (a simulator moves spoke tips outward where the scope presses) without
//!   passing the crossing.
//!
//! Either shortens a spoke along its own direction, so it stays in its ring's plane; the rest
//! of the wall is left as it was.
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

/// The part of its way to a crossing inside another section a clipped spoke keeps
/// ([`Tube::clip_folds`]): short of it by more than `f32` rounding.
pub const CLIP: f64 = 0.995;

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

/// A vector in `f64`.
pub type V = nalgebra::Vector3<f64>;

fn v(a: [f32; 3]) -> V {
    V::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// Where a crossing of another ring's plane counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Within {
    /// Within that ring's longest spoke of its point (what [`Tube::unfold`] shortens against).
    Reach,
    /// Inside that ring's section, the polygon of its spoke tips, and before the spoke's own tip:
    /// a point of the lumen in two sections ([`Tube::folds`]).
    Section,
}

/// Each of `n` rings' longest spoke, the farthest its wall lies from its point (`b` spokes a
/// ring, ring-major in `spokes`).
pub(super) fn reaches(spokes: &[V], n: usize, b: usize) -> Vec<f64> {
    (0..n).map(|i| spokes[i * b..(i + 1) * b].iter().map(|s| s.norm()).fold(0.0, f64::max)).collect()
}

/// Whether `x` (relative to a ring's point, in its plane of unit normal `n`) lies inside the
/// polygon of the ring's spoke tips `s` (in order around `n`, either sense): in the sector
/// between two consecutive spokes, on the point's side of the edge between their tips.
pub(super) fn in_section(x: V, n: V, s: &[V]) -> bool {
    let b = s.len();
    let side = |a: &V, c: &V| a.cross(c).dot(&n);
    // The spokes' sense about n, from the polygon's area.
    let o = if (0..b).map(|k| side(&s[k], &s[(k + 1) % b])).sum::<f64>() < 0.0 { -1.0 } else { 1.0 };
    for k in 0..b {
        let (a, c) = (s[k], s[(k + 1) % b]);
        if o * side(&a, &x) >= 0.0 && o * side(&x, &c) >= 0.0 {
            // Inside the triangle (0, a, c): on the origin's side of the edge a-c.
            return o * side(&(c - a), &(x - a)) >= 0.0;
        }
    }
    false
}

/// The nearest crossing of every spoke that reaches past another ring's plane: for ring `i`,
/// spoke `k` (ring-major in `spokes`, `b` a ring, relative to `points[i]`), calls
/// `f(i, k, j, way)` with the ring `j` (within [`WINDOW`]) whose plane the spoke crosses first,
/// where `within` says, and the way along the spoke to there, when the spoke is
/// longer than `keep` times that way (`keep = 1`: the spoke's tip lies past the crossing).
/// `normals` are the rings' unit plane normals, oriented along the midline. Pure, in `f64`, so
/// the import's ring planes and the model's check read the same test.
pub fn crossings(points: &[V], normals: &[V], spokes: &[V], b: usize, keep: f64, within: Within, mut f: impl FnMut(usize, usize, usize, f64)) {
    let n = points.len();
    let reach = reaches(spokes, n, b);
    for i in 0..n {
        let c = points[i];
        for k in 0..b {
            let s = spokes[i * b + k];
            let len = s.norm();
            if len.is_nan() || len <= 0.0 {
                continue;
            }
            let d = s / len;
            let mut way = (f64::INFINITY, usize::MAX);
            for j in i.saturating_sub(WINDOW)..(i + WINDOW + 1).min(n) {
                if j == i {
                    continue;
                }
                let (nj, cj) = (normals[j], points[j]);
                let (dist, dn) = ((c - cj).dot(&nj), d.dot(&nj));
                let wrong_way = if j > i { dist < 0.0 && dn > 0.0 } else { dist > 0.0 && dn < 0.0 };
                if wrong_way {
                    let t = -dist / dn;
                    let x = c + d * t - cj;
                    let near = match within {
                        Within::Reach => x.norm() <= reach[j],
                        Within::Section => in_section(x, nj, &spokes[j * b..(j + 1) * b]),
                    };
                    if t < way.0 && near {
                        way = (t, j);
                    }
                }
            }
            // Beyond rounding: a spoke already shortened to `keep` of its way stays as it is.
            if way.1 != usize::MAX && keep * way.0 < len * (1.0 - 1e-6) {
                f(i, k, way.1, way.0);
            }
        }
    }
}

impl Tube {
    /// Shortens every spoke that reaches past another ring's plane within that ring's reach (see
    /// the module), to [`KEEP`] of its way there; says what it shortened. A tube whose ring
    /// planes cross nowhere inside its lumen is left exactly as it was.
    pub fn unfold(&mut self) -> FoldReport {
        let (report, shortened) = self.fold_check(KEEP, Within::Reach);
        for (at, s) in shortened {
            self.radial[at] = [s.x as f32, s.y as f32, s.z as f32];
        }
        report
    }

    /// The spokes whose tips lie past another ring's plane within that ring's reach: where the
    /// wall passes over itself. `spokes == 0` for a tube that never folds. `max_cut` is how far
    /// the deepest tip reaches past its crossing.
    pub fn folds(&self) -> FoldReport {
        self.fold_check(1.0, Within::Section).0
    }

    /// Shortens every spoke whose tip lies past another ring's plane inside that ring's section
    /// to [`CLIP`] of its way there, along itself (its ring's plane stays as it was); says what
    /// it shortened. Afterwards [`Tube::folds`] finds none: shortening only shrinks sections,
    /// so no crossing appears that was not there. Where two parts of an inflated lumen press on
    /// each other, this is their flattened wall.
    pub fn clip_folds(&mut self) -> FoldReport {
        let (report, shortened) = self.fold_check(CLIP, Within::Section);
        for (at, s) in shortened {
            self.radial[at] = [s.x as f32, s.y as f32, s.z as f32];
        }
        report
    }

    /// The spokes longer than `keep` of their way to a crossing, and each shortened to that.
    fn fold_check(&self, keep: f64, within: Within) -> (FoldReport, Vec<(usize, V)>) {
        let b = self.spokes;
        let (points, normals, spokes) = self.in_f64();
        let mut report = FoldReport::default();
        let mut shortened = Vec::new();
        let mut last_ring = usize::MAX;
        crossings(&points, &normals, &spokes, b, keep, within, |i, k, _, way| {
            let s = spokes[i * b + k];
            let len = s.norm();
            let cut = keep * way;
            shortened.push((i * b + k, s * (cut / len)));
            report.spokes += 1;
            report.max_cut = report.max_cut.max(len - cut);
            report.max_cut_fraction = report.max_cut_fraction.max(1.0 - cut / len);
            if last_ring != i {
                last_ring = i;
                report.rings += 1;
                report.ring_range = Some(report.ring_range.map_or((i, i), |(a, _)| (a, i)));
            }
        });
        (report, shortened)
    }

    /// The rings' points, plane normals ([`Tube::ring_normal`]) and spokes in `f64`, what the
    /// fold and overlap checks read.
    pub(super) fn in_f64(&self) -> (Vec<V>, Vec<V>, Vec<V>) {
        let normals = (0..self.rings()).map(|i| self.ring_normal(i)).collect();
        (self.points.iter().map(|&p| v(p)).collect(), normals, self.radial.iter().map(|&s| v(s)).collect())
    }

    /// Ring `i`'s plane normal as the detector reads it ([`ring_plane`]), in `f64`.
    pub fn ring_normal(&self, i: usize) -> V {
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

    #[test]
    fn folds_count_tips_inside_another_section_and_clipping_leaves_none() {
        // Bend radius 6 against a lumen of 10: the arc's planes cross 6 from the midline, inside
        // both sections; a bend of radius 60 folds nowhere.
        assert_eq!(bent(10.0, 60.0, 1.0, 30, 16).folds(), FoldReport::default());
        let mut t = bent(10.0, 6.0, 0.5, 40, 16);
        let before = t.clone();
        let folds = t.folds();
        assert!(folds.spokes > 10 && folds.max_cut > 1.0, "{folds:?}");
        assert_eq!(t, before, "counting changes nothing");
        let clipped = t.clip_folds();
        // Also those within CLIP of a crossing.
        assert!(clipped.spokes >= folds.spokes && clipped.spokes < folds.spokes + 10, "{clipped:?} {folds:?}");
        assert_eq!(t.folds(), FoldReport::default());
        // Only lengths change, never directions, and never longer.
        for (a, b) in t.radial.iter().zip(&before.radial) {
            let (a, b) = (v(*a), v(*b));
            assert!(a.norm() <= b.norm() + 1e-6 && (a.normalize() - b.normalize()).norm() < 1e-5);
        }
    }

    #[test]
    fn a_point_is_in_a_section_inside_the_polygon_of_its_tips() {
        let ring: Vec<V> = (0..8).map(|k| k as f64 * std::f64::consts::TAU / 8.0).map(|a| V::new(10.0 * a.cos(), 10.0 * a.sin(), 0.0)).collect();
        let reversed: Vec<V> = ring.iter().rev().copied().collect();
        for s in [&ring, &reversed] {
            assert!(in_section(V::new(3.0, 4.0, 0.0), V::z(), s));
            assert!(in_section(V::new(9.0, 0.5, 0.0), V::z(), s));
            // Between the tips at 0 and 45 degrees the edge passes 9.24 from the centre.
            let a = std::f64::consts::PI / 8.0;
            assert!(!in_section(V::new(9.5 * a.cos(), 9.5 * a.sin(), 0.0), V::z(), s));
            assert!(!in_section(V::new(-12.0, 0.0, 0.0), V::z(), s));
        }
    }
}
