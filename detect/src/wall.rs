//! The continuous wall as a grid of points, for drawing it (the live view, recordings that
//! standard tools open).
//!
//! The wall of segment `i` (rings `i` and `i + 1`) is
//!
//! ```text
//! S(i, u, k, l) = C_i(u) + (1 - l) V_k(u) + l V_{k+1}(u),   V_k(u) = (1 - u) V_{i,k} + u V_{i+1,k}
//! ```
//!
//! with `C_i` the detector's own Catmull-Rom segment ([`Cubic::of_chain`]). It is straight in
//! `l`, so a row of the `B` tips at one `u` joined by straight edges is exact around the tube;
//! only the `u` direction is sampled, `steps` rows per segment. The points are computed relative
//! to the tube's first control point and moved back, so a tube far from the origin keeps its
//! precision.

use crate::spline::Cubic;
use crate::view::TubeView;
use crate::V3;
use std::ops::Range;

/// Rows of the wall of one tube: row `r` holds the `spokes` tips at `u = m / steps` of segment
/// `first + r / steps` (`m = r % steps`); the tube's last ring closes the grid when the
/// segments reach it.
#[derive(Debug, Clone, Copy)]
pub struct WallGrid {
    /// Rows per segment (`u` steps), at least 1.
    pub steps: usize,
    /// Catmull-Rom parameter of the scene.
    pub alpha: f32,
}

impl WallGrid {
    /// Rows the segments `segments` take: `steps` each, plus one for the last ring when the
    /// range ends at the tube's last segment.
    pub fn rows(&self, rings: usize, segments: &Range<usize>) -> usize {
        let last = usize::from(segments.end + 1 == rings && !segments.is_empty());
        segments.len() * self.steps.max(1) + last
    }

    /// Appends the rows of `segments` (ring pairs `i, i + 1`, `i < rings - 1`) of the tube in
    /// `data` (`rings * (spokes + 1) * 3` floats of the frame state) to `out`, in the scene's
    /// unit and coordinates.
    pub fn append(&self, data: &[f32], rings: usize, spokes: usize, segments: Range<usize>, out: &mut Vec<[f32; 3]>) {
        if rings < 2 || data.len() != rings * (spokes + 1) * 3 {
            return;
        }
        let segments = segments.start.min(rings - 1)..segments.end.min(rings - 1);
        let origin = V3::new(data[0], data[1], data[2]);
        let tube = TubeView::new(data, rings, spokes, origin);
        let steps = self.steps.max(1);
        for i in segments.clone() {
            let c = Cubic::of_chain(|j| tube.point(j), rings, i, self.alpha);
            for m in 0..steps {
                let u = m as f32 / steps as f32;
                let centre = c.at(u) + origin;
                for k in 0..spokes {
                    let v = tube.spoke(i, k) * (1.0 - u) + tube.spoke(i + 1, k) * u;
                    out.push((centre + v).into());
                }
            }
        }
        if segments.end + 1 == rings && !segments.is_empty() {
            let centre = tube.point(rings - 1) + origin;
            for k in 0..spokes {
                out.push((centre + tube.spoke(rings - 1, k)).into());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Tube;

    /// A straight tube along x of radius `r`, rings 1 apart, far from the origin.
    fn straight(rings: usize, spokes: usize, r: f32, offset: f32) -> Vec<f32> {
        let points = (0..rings).map(|i| [offset + i as f32, offset, 0.0]).collect();
        let mut radial = Vec::new();
        for _ in 0..rings {
            for k in 0..spokes {
                let a = k as f32 / spokes as f32 * std::f32::consts::TAU;
                radial.push([0.0, r * a.cos(), r * a.sin()]);
            }
        }
        let mut out = Vec::new();
        Tube::new(points, radial, spokes).unwrap().write_state(&mut out);
        out
    }

    #[test]
    fn rows_lie_on_the_wall_at_their_u() {
        let (rings, spokes, steps) = (6, 8, 4);
        let data = straight(rings, spokes, 3.0, 1.0e4);
        let grid = WallGrid { steps, alpha: 0.5 };
        let mut out = Vec::new();
        grid.append(&data, rings, spokes, 0..rings - 1, &mut out);
        assert_eq!(out.len(), grid.rows(rings, &(0..rings - 1)) * spokes);
        assert_eq!(out.len(), ((rings - 1) * steps + 1) * spokes);
        for (n, p) in out.iter().enumerate() {
            let row = n / spokes;
            let x = 1.0e4 + row as f32 / steps as f32;
            // On a straight, evenly spaced midline the centripetal spline is the line itself.
            assert!((p[0] - x).abs() < 2e-3, "row {row}: x {} against {x}", p[0]);
            let r = ((p[1] - 1.0e4).powi(2) + p[2].powi(2)).sqrt();
            assert!((r - 3.0).abs() < 2e-3, "radius {r}");
        }
    }

    #[test]
    fn a_middle_range_matches_the_whole_grid() {
        let (rings, spokes, steps) = (7, 5, 3);
        let data = straight(rings, spokes, 2.0, 0.0);
        let grid = WallGrid { steps, alpha: 0.5 };
        let (mut all, mut part) = (Vec::new(), Vec::new());
        grid.append(&data, rings, spokes, 0..rings - 1, &mut all);
        grid.append(&data, rings, spokes, 2..4, &mut part);
        assert_eq!(part.len(), 2 * steps * spokes);
        assert_eq!(&all[2 * steps * spokes..4 * steps * spokes], &part[..]);
    }

    #[test]
    fn a_bent_midline_is_the_detectors_spline() {
        let (rings, spokes) = (4, 3);
        let pts = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [15.0, 8.0, 0.0], [15.0, 20.0, 1.0]];
        let mut data = Vec::new();
        for p in pts {
            data.extend_from_slice(&p);
            for _ in 0..spokes {
                data.extend_from_slice(&[0.0, 0.0, 0.0]);
            }
        }
        let grid = WallGrid { steps: 5, alpha: 0.5 };
        let mut out = Vec::new();
        grid.append(&data, rings, spokes, 1..2, &mut out);
        let c = Cubic::of_chain(|j| V3::from(pts[j]), rings, 1, 0.5);
        for m in 0..5 {
            let want = c.at(m as f32 / 5.0);
            let got = V3::from(out[m * spokes]);
            assert!((got - want).norm() < 1e-4, "u {m}/5: {got:?} against {want:?}");
        }
        // Bad input writes nothing rather than panicking.
        let mut none = Vec::new();
        grid.append(&data[..10], rings, spokes, 0..3, &mut none);
        assert!(none.is_empty());
    }
}
