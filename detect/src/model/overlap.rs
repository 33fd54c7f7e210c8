//! Spoke tips inside another part of the lumen: loops that overlap ([`Tube::overlaps`]).
//!
//! The fold check ([`super::fold`]) finds spokes that reach past a nearby ring's plane, where a
//! bend is tighter than the lumen. Two parts of the tube far apart along it can overlap too,
//! side by side, where their planes never cross inside either: two legs of a loop inflated
//! past the space between them (the real colon's sigmoid inflated four times). There a point of
//! the lumen lies in the sections of both parts, each part's wall runs through the other's
//! lumen, and a sample near it is read in one part one frame and in the other the next.
//!
//! A tip `T` of ring `i` lies inside the segment between rings `j` and `j + 1` (neither next
//! to `i`: `j != i - 1, i`) when it lies between their planes,
//!
//! ```text
//! d0 = (T - C_j) . n_j >= 0,   d1 = (T - C_{j+1}) . n_{j+1} <= 0,
//! ```
//!
//! and, at `u = d0 / (d0 - d1)` between them, inside the section there: the polygon of the
//! spokes `(1 - u) V_j + u V_{j+1}` about `(1 - u) C_j + u C_{j+1}` in the plane of normal
//! `(1 - u) n_j + u n_{j+1}`. A tube whose parts keep apart has none. Pure, in `f64`; each tip
//! is tested against the segments whose bounding sphere holds it.

use super::fold::{in_section, reaches, V};
use super::Tube;

/// What [`Tube::overlaps`] found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct OverlapReport {
    /// Spoke tips inside a segment that is not next to their ring.
    pub tips: usize,
    /// Rings with such a tip.
    pub rings: usize,
    /// The largest distance along the tube between a tip's ring and the segment it lies in,
    /// in rings.
    pub farthest: usize,
}

impl Tube {
    /// The spoke tips that lie inside a segment of the tube not next to their own ring (see
    /// the module): where two parts of the lumen overlap.
    pub fn overlaps(&self) -> OverlapReport {
        let (n, b) = (self.rings(), self.spokes);
        let mut report = OverlapReport::default();
        if n < 3 || b < 3 {
            return report;
        }
        let (points, normals, spokes) = self.in_f64();
        let reach = reaches(&spokes, n, b);
        // Each segment's bounding sphere: its middle, and the farthest a wall point can lie.
        let spheres: Vec<(V, f64)> = (0..n - 1).map(|j| ((points[j] + points[j + 1]) * 0.5, reach[j].max(reach[j + 1]) + (points[j + 1] - points[j]).norm() * 0.5)).collect();
        let mut polygon = vec![V::zeros(); b];
        for i in 0..n {
            let mut found = false;
            for k in 0..b {
                let t = points[i] + spokes[i * b + k];
                for (j, &(centre, radius)) in spheres.iter().enumerate() {
                    if j + 1 == i || j == i || (t - centre).norm_squared() > radius * radius {
                        continue;
                    }
                    let d0 = (t - points[j]).dot(&normals[j]);
                    let d1 = (t - points[j + 1]).dot(&normals[j + 1]);
                    if !(d0 >= 0.0 && d1 <= 0.0 && d0 - d1 > 0.0) {
                        continue;
                    }
                    let u = d0 / (d0 - d1);
                    let normal = (normals[j] * (1.0 - u) + normals[j + 1] * u).normalize();
                    let centre = points[j] * (1.0 - u) + points[j + 1] * u;
                    for (q, p) in polygon.iter_mut().enumerate() {
                        *p = spokes[j * b + q] * (1.0 - u) + spokes[(j + 1) * b + q] * u;
                    }
                    let x = t - centre;
                    if in_section(x - normal * x.dot(&normal), normal, &polygon) {
                        report.tips += 1;
                        report.farthest = report.farthest.max(i.abs_diff(j).max(i.abs_diff(j + 1)));
                        found = true;
                        break;
                    }
                }
            }
            report.rings += found as usize;
        }
        report
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two straight legs along y of `rings` round rings (radius `r`, 1 apart, 16 spokes), their
    /// axes `gap` apart along x, joined end to end as one tube (the second leg runs back): a
    /// hairpin whose turn is left out.
    fn legs(r: f64, gap: f64, rings: usize) -> Tube {
        let b = 16;
        let mut points = Vec::new();
        let mut radial = Vec::new();
        for leg in 0..2 {
            for m in 0..rings {
                let (x, y) = if leg == 0 { (0.0, m as f64) } else { (gap, (rings - 1 - m) as f64) };
                points.push([x as f32, y as f32, 0.0]);
                for k in 0..b {
                    let a = k as f64 * std::f64::consts::TAU / b as f64;
                    radial.push([(r * a.cos()) as f32, 0.0, (r * a.sin()) as f32]);
                }
            }
        }
        Tube::new(points, radial, b).unwrap()
    }

    #[test]
    fn legs_wider_than_the_space_between_them_overlap_and_apart_they_do_not() {
        // Radius 10, axes 30 apart: 10 of room between the walls.
        assert_eq!(Tube::overlaps(&legs(10.0, 30.0, 40)), OverlapReport::default());
        // Axes 15 apart: the spokes pointing at the other leg reach 5 into it. The legs' planes
        // are parallel (no fold), so the fold check sees nothing.
        let t = legs(10.0, 15.0, 40);
        assert_eq!(t.folds().spokes, 0);
        let o = t.overlaps();
        // Each leg's tips towards the other (within 60 degrees of it: 5 of 16), on every ring
        // but the ends.
        assert!(o.tips >= 2 * 30 * 3 && o.tips <= 2 * 40 * 5, "{o:?}");
        assert!(o.rings >= 60, "{o:?}");
        assert!(o.farthest >= 40, "{o:?}");
    }
}
