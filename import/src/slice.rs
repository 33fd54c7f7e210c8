//! Ring planes that never cross inside the lumen.
//!
//! A ring's section is the part of its plane (point `C_i`, unit normal `n_i` along the midline)
//! that the rays from `C_i` reach before the wall. The detector reads a point between the planes
//! of rings `i` and `i + 1` as lying in segment `i`, at `u = d_i / (d_i - d_{i+1})` with
//! `d_i = (P - C_i) . n_i`: the level sets of `u` are the planes through the line where the two
//! ring planes meet. Where that line passes through a section (a bend tighter than the lumen is
//! wide, on its inner side), the wall between the rings passes over itself and a point there
//! has two answers. So the model holds when no spoke reaches past another ring's plane within
//! that ring's reach ([`lumen_detect::model::fold_crossings`]): then every point of the lumen
//! lies in exactly one segment's wedge, at one `u`.
//!
//! **The choice: normals smoothed until they fan about an axis outside the lumen.** Ring `i`'s
//! normal is the midline's tangent averaged along the arc with a Gaussian of its own width
//! `sigma_i`:
//!
//! ```text
//! n_i = normalize( sum_m exp(-(s_m - s_i)^2 / (2 sigma_i^2)) t_m )
//! ```
//!
//! A turn of the tangent by `Theta` turns the smoothed normals by at most about
//! `Theta / (sigma sqrt(2 pi))` per unit of arc, and two planes `h` apart whose normals differ by
//! `delta` meet about `h / delta` from the midline: a width `sigma > rho Theta / sqrt(2 pi)`
//! puts the meeting line beyond a reach `rho` towards the bend's inside. Rather than estimate
//! `rho` and `Theta`, the import casts the rays, checks every spoke against the planes around
//! it, and widens `sigma` by [`GROW`] over the rings between each crossing pair and one width
//! around them, until no spoke ends past [`ROOM`] of its way to a crossing (room for a wall
//! that gives outward). Straight and gently bent stretches keep the import's tangent smoothing:
//! only bends tighter than their lumen is wide tilt their planes, spread over a longer arc.
//!
//! A ring whose normal would turn more than `acos(`[`MIN_COS`]`)` from its own tangent keeps its
//! width (its plane would lie along the tube): where no width clears a crossing, the crossing
//! stays, is counted in the import's report, and the quality gate refuses the model.
//!
//! Tried and left: shortening the spokes that reach past a crossing (`Tube::unfold`): on the
//! real colon's colonoscopy it made the penetration worse (the wall moved inward where the scope
//! was). Planes that follow the tangent with one global smoothing width: a width that clears the
//! flexures tilts every plane of the colon and cuts neighbouring loops.

use crate::geom::V3d;

/// Factor between consecutive widths tried.
pub const GROW: f64 = 1.5;

/// The widest smoothing tried (mm).
pub const WIDEST: f64 = 64.0;

/// Arc (mm) each way over which a ring's choice of width counts crossings.
pub const NEIGHBOURHOOD: f64 = 16.0;

/// Width (mm) of the smoothing of the chosen widths along the arc.
pub const BLEND: f64 = 8.0;

/// A spoke must end short of this fraction of its way to another ring's plane.
pub const ROOM: f64 = 0.9;

/// Unit plane normals: ring `i`'s is `raw`, the midline's unit tangents, averaged along the arc
/// with a Gaussian of width `sigma[i]` (window 3 widths, truncated at the ends; `sigma[i] <= 0`
/// keeps `raw[i]`).
pub fn normals(raw: &[V3d], arc: &[f64], sigma: &[f64]) -> Vec<V3d> {
    let n = raw.len();
    (0..n)
        .map(|i| {
            let w = sigma[i];
            if w <= 0.0 {
                return raw[i];
            }
            let lo = arc.partition_point(|&s| s < arc[i] - 3.0 * w);
            let hi = arc.partition_point(|&s| s <= arc[i] + 3.0 * w);
            let mut acc = V3d::zeros();
            for m in lo..hi {
                let d = (arc[m] - arc[i]) / w;
                acc += raw[m] * (-0.5 * d * d).exp();
            }
            acc.try_normalize(1e-12).unwrap_or(raw[i])
        })
        .collect()
}

/// The widths tried: `base` (the import's tangent smoothing; one ring spacing if 0) growing by
/// [`GROW`] up to [`WIDEST`].
pub fn ladder(base: f64, spacing: f64) -> Vec<f64> {
    let mut w = if base > 0.0 { base } else { spacing };
    let mut out = vec![w];
    while w * GROW <= WIDEST {
        w *= GROW;
        out.push(w);
    }
    out
}

/// Each ring's width: the rung of `ladder` at which the crossings `counts[rung][ring]`, summed
/// over the rings within [`NEIGHBOURHOOD`] of arc, are fewest (the narrowest such rung), then
/// smoothed along the arc (geometric mean, Gaussian of [`BLEND`]) so that neighbouring planes
/// change gradually. `counts` may stop short of the ladder's top (a rung with no crossing ends
/// the search).
pub fn choose(counts: &[Vec<u32>], ladder: &[f64], arc: &[f64]) -> Vec<f64> {
    let n = arc.len();
    let window = |c: &[u32]| -> Vec<u64> {
        let mut pre = vec![0u64; n + 1];
        for i in 0..n {
            pre[i + 1] = pre[i] + c[i] as u64;
        }
        (0..n)
            .map(|i| {
                let lo = arc.partition_point(|&s| s < arc[i] - NEIGHBOURHOOD);
                let hi = arc.partition_point(|&s| s <= arc[i] + NEIGHBOURHOOD);
                pre[hi] - pre[lo]
            })
            .collect()
    };
    let near: Vec<Vec<u64>> = counts.iter().map(|c| window(c)).collect();
    let log: Vec<f64> = (0..n)
        .map(|i| {
            let best = (0..near.len()).min_by_key(|&r| (near[r][i], r)).unwrap_or(0);
            ladder[best].ln()
        })
        .collect();
    let blended = crate::geom::smooth_scalar(&log, arc, BLEND);
    blended.into_iter().map(f64::exp).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_width_of_zero_keeps_the_tangents_and_a_wide_one_averages_them() {
        let raw: Vec<V3d> = (0..20).map(|i| if i < 10 { V3d::x() } else { V3d::y() }).collect();
        let arc: Vec<f64> = (0..20).map(f64::from).collect();
        assert_eq!(normals(&raw, &arc, &[0.0; 20]), raw);
        let wide = normals(&raw, &arc, &[1e3; 20]);
        for n in wide {
            assert!((n - V3d::new(1.0, 1.0, 0.0).normalize()).norm() < 1e-3, "{n}");
        }
    }

    #[test]
    fn each_ring_takes_the_narrowest_width_its_neighbourhood_crosses_least_at() {
        let ladder = ladder(4.0, 1.0);
        assert_eq!(ladder.first(), Some(&4.0));
        assert!(ladder.windows(2).all(|w| (w[1] / w[0] - GROW).abs() < 1e-12) && *ladder.last().unwrap() <= WIDEST);
        assert_eq!(super::ladder(0.0, 0.5)[0], 0.5);
        // 200 rings 1 mm apart; rings 100 to 110 cross at the first two rungs, not the third.
        let arc: Vec<f64> = (0..200).map(f64::from).collect();
        let mut counts = vec![vec![0u32; 200]; 3];
        for c in &mut counts[..2] {
            c[100..=110].iter_mut().for_each(|x| *x = 3);
        }
        let sigma = choose(&counts, &ladder, &arc);
        assert!((sigma[0] - 4.0).abs() < 1e-9 && (sigma[199] - 4.0).abs() < 1e-9, "{sigma:?}");
        assert!(sigma[105] > 6.0 && sigma[105] <= ladder[2] + 1e-9, "{}", sigma[105]);
    }
}
