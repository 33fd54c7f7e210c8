//! How far an imported wall lies from the surface it was imported from.
//!
//! The tube's wall is the detector's continuous wall: the midline as a centripetal Catmull-Rom
//! curve `C(u)` and the radial vectors linear between rings, so a patch is
//! `S(i, u, k, l) = C_i(u) + (1 - l) V_k(u) + l V_{k+1}(u)`. Its kept rays end on the surface,
//! so the spoke tips lie on it; between them the wall cuts corners of the surface or bridges its
//! folds, and a broken import (a surface in the wrong units, rings borrowed everywhere) lies far
//! from it everywhere. [`wall_to_surface`] samples every patch at its corners and at its middles
//! (`u`, `l` in {0, 1/2}) and measures each sample's distance to the nearest triangle.
//!
//! Where the far part comes from is told apart: the points whose spokes (the one or two of its
//! ring, or of both rings, it is drawn between) were all kept measure the wall's resolution
//! (chords across folds between spokes, patches across tight bends), the others the repairs.

use lumen_detect::spline::Cubic;
use lumen_detect::{Tube, V3};
use parry3d::math::Vector;
use parry3d::query::PointQuery;
use parry3d::shape::TriMesh;

/// Centripetal Catmull-Rom, the detector's default midline.
const ALPHA: f32 = 0.5;

/// Distances of the wall to the surface, in the surface's unit: median, 99th percentile and
/// largest, over the samples of every patch.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Fidelity {
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
    /// Wall points measured.
    pub samples: usize,
    /// The 99th percentile over the points drawn between kept spokes only (no repaired spoke
    /// among those it interpolates).
    pub kept_p99: f64,
    /// Points drawn from at least one repaired spoke.
    pub near_repaired: usize,
}

/// The wall of `tube` with its radial vectors divided by `inflate` (inflation departs from the
/// surface on purpose; this measures the import itself) against `surface`. `repaired` marks the
/// spokes (ring after ring) that were not a ray's kept hit; empty when none were.
pub fn wall_to_surface(tube: &Tube, inflate: f32, surface: &TriMesh, repaired: &[bool]) -> Fidelity {
    let (n, b) = (tube.rings(), tube.spokes);
    let at = |i: usize| V3::from(tube.points[i]);
    let spoke = |i: usize, k: usize| V3::from(tube.spoke(i, k)) / inflate;
    let fixed = |i: usize, k: usize| repaired.get(i * b + k).copied().unwrap_or(false);
    let mut d: Vec<f64> = Vec::with_capacity(n * b * 4);
    let mut kept: Vec<f64> = Vec::with_capacity(n * b * 4);
    let mut near = 0;
    for i in 0..n {
        let us: &[f32] = if i + 1 < n { &[0.0, 0.5] } else { &[0.0] };
        let c = (i + 1 < n).then(|| Cubic::of_chain(at, n, i, ALPHA));
        for &u in us {
            let centre = c.map_or(at(i), |c| c.at(u));
            let j = if u == 0.0 { i } else { i + 1 };
            for k in 0..b {
                let k1 = (k + 1) % b;
                let v0 = spoke(i, k) * (1.0 - u) + spoke(j, k) * u;
                let v1 = spoke(i, k1) * (1.0 - u) + spoke(j, k1) * u;
                for l in [0.0, 0.5] {
                    let p = centre + v0 * (1.0 - l) + v1 * l;
                    let dist = surface.distance_to_local_point(Vector::new(p.x, p.y, p.z), false) as f64;
                    let ks: &[usize] = if l == 0.0 { &[k] } else { &[k, k1] };
                    let is: &[usize] = if u == 0.0 { &[i] } else { &[i, j] };
                    if is.iter().any(|&i| ks.iter().any(|&k| fixed(i, k))) {
                        near += 1;
                    } else {
                        kept.push(dist);
                    }
                    d.push(dist);
                }
            }
        }
    }
    if d.is_empty() {
        return Fidelity::default();
    }
    d.sort_by(f64::total_cmp);
    kept.sort_by(f64::total_cmp);
    let q = |v: &[f64], x: f64| if v.is_empty() { 0.0 } else { v[((v.len() - 1) as f64 * x).round() as usize] };
    Fidelity { p50: q(&d, 0.5), p99: q(&d, 0.99), max: d[d.len() - 1], samples: d.len(), kept_p99: q(&kept, 0.99), near_repaired: near }
}
