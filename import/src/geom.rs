//! Midline geometry shared by the generator, the insertion and the importer: arc length,
//! resampling, Gaussian smoothing along the arc and rotation-minimising frames.

/// Double-precision vector used internally (the models store `f32`).
pub use lumen_detect::V3d;

#[inline]
pub fn d3(p: [f32; 3]) -> V3d {
    V3d::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[inline]
pub fn f3(p: V3d) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Cumulative arc length of a polyline, starting at 0.
pub fn arc_lengths(points: &[V3d]) -> Vec<f64> {
    let mut out = Vec::with_capacity(points.len());
    let mut s = 0.0;
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            s += (p - points[i - 1]).norm();
        }
        out.push(s);
    }
    out
}

/// The segment `i` (from `i` to `i + 1`) and fraction holding arc length `s` (clamped).
pub fn locate_arc(arc: &[f64], s: f64) -> (usize, f64) {
    let n = arc.len();
    if n < 2 || s <= arc[0] {
        return (0, 0.0);
    }
    if s >= arc[n - 1] {
        return (n - 2, 1.0);
    }
    let i = arc.partition_point(|&a| a <= s).saturating_sub(1).min(n - 2);
    let len = arc[i + 1] - arc[i];
    let u = if len > 0.0 { (s - arc[i]) / len } else { 0.0 };
    (i, u.clamp(0.0, 1.0))
}

/// Linear interpolation of per-point values at arc length `s`.
pub fn at_arc(values: &[V3d], arc: &[f64], s: f64) -> V3d {
    let (i, u) = locate_arc(arc, s);
    if values.len() == 1 {
        return values[0];
    }
    values[i] * (1.0 - u) + values[i + 1] * u
}

/// Same for scalars.
pub fn at_arc_scalar(values: &[f64], arc: &[f64], s: f64) -> f64 {
    let (i, u) = locate_arc(arc, s);
    if values.len() == 1 {
        return values[0];
    }
    values[i] * (1.0 - u) + values[i + 1] * u
}

/// Gaussian-weighted average of per-point values over arc length (`sigma` in the arc's unit,
/// window 3 sigma, truncated at the ends); `sigma <= 0` returns the input.
pub fn smooth_along(values: &[V3d], arc: &[f64], sigma: f64) -> Vec<V3d> {
    if sigma <= 0.0 || values.len() < 3 {
        return values.to_vec();
    }
    smooth_along_each(values, arc, &vec![sigma; values.len()])
}

/// [`smooth_along`] with its own `sigma` at every point (`sigmas[i] <= 0`: point `i` as it
/// is); `arc` must not decrease.
pub fn smooth_along_each(values: &[V3d], arc: &[f64], sigmas: &[f64]) -> Vec<V3d> {
    (0..values.len())
        .map(|i| {
            let sigma = sigmas[i];
            if sigma <= 0.0 {
                return values[i];
            }
            let lo = arc.partition_point(|&a| arc[i] - a > 3.0 * sigma);
            let hi = arc.partition_point(|&a| a - arc[i] <= 3.0 * sigma);
            let (mut acc, mut wsum) = (V3d::zeros(), 0.0);
            for j in lo..hi {
                let d = (arc[j] - arc[i]) / sigma;
                let w = (-0.5 * d * d).exp();
                acc += values[j] * w;
                wsum += w;
            }
            acc / wsum
        })
        .collect()
}

/// Same for scalars.
pub fn smooth_scalar(values: &[f64], arc: &[f64], sigma: f64) -> Vec<f64> {
    let v: Vec<V3d> = values.iter().map(|&x| V3d::new(x, 0.0, 0.0)).collect();
    smooth_along(&v, arc, sigma).into_iter().map(|p| p.x).collect()
}

/// Unit tangents of a polyline: Gaussian-smoothed chord directions (`sigma` along the arc),
/// normalised. With `sigma = 0` these are central differences.
pub fn tangents(points: &[V3d], arc: &[f64], sigma: f64) -> Vec<V3d> {
    let n = points.len();
    let raw: Vec<V3d> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (points[b] - points[a]).try_normalize(1e-12).unwrap_or_else(V3d::x)
        })
        .collect();
    smooth_along(&raw, arc, sigma).into_iter().zip(raw).map(|(t, r)| t.try_normalize(1e-9).unwrap_or(r)).collect()
}

/// A unit vector perpendicular to unit `t`.
pub fn any_perpendicular(t: V3d) -> V3d {
    let a = if t.x.abs() <= t.y.abs() && t.x.abs() <= t.z.abs() {
        V3d::x()
    } else if t.y.abs() <= t.z.abs() {
        V3d::y()
    } else {
        V3d::z()
    };
    (a - t * a.dot(&t)).normalize()
}

/// Rotation-minimising frame along a polyline by the double reflection method (Wang, Juttler,
/// Zheng & Liu 2008): returns the unit normals `n_i`, perpendicular to the unit tangents `t_i`,
/// starting from `n0` (projected onto the first normal plane). The binormal is `t x n`.
pub fn rotation_minimising(points: &[V3d], tangents: &[V3d], n0: V3d) -> Vec<V3d> {
    let n = points.len();
    let mut out = Vec::with_capacity(n);
    if n == 0 {
        return out;
    }
    let t0 = tangents[0];
    let mut r = (n0 - t0 * n0.dot(&t0)).try_normalize(1e-9).unwrap_or_else(|| any_perpendicular(t0));
    out.push(r);
    for i in 0..n - 1 {
        let (ti, tj) = (tangents[i], tangents[i + 1]);
        let v1 = points[i + 1] - points[i];
        let c1 = v1.dot(&v1);
        let (rl, tl) = if c1 > 1e-18 { (r - v1 * (2.0 / c1 * v1.dot(&r)), ti - v1 * (2.0 / c1 * v1.dot(&ti))) } else { (r, ti) };
        let v2 = tj - tl;
        let c2 = v2.dot(&v2);
        let mut rn = if c2 > 1e-18 { rl - v2 * (2.0 / c2 * v2.dot(&rl)) } else { rl };
        rn = (rn - tj * rn.dot(&tj)).try_normalize(1e-9).unwrap_or_else(|| any_perpendicular(tj));
        out.push(rn);
        r = rn;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_on_a_helix_is_orthonormal_and_does_not_spin() {
        // Helix: the RMF's rotation about the tangent between samples is ~0.
        let pts: Vec<V3d> = (0..400)
            .map(|i| {
                let a = i as f64 * 0.02;
                V3d::new(30.0 * a.cos(), 30.0 * a.sin(), 5.0 * a)
            })
            .collect();
        let arc = arc_lengths(&pts);
        let t = tangents(&pts, &arc, 0.0);
        let n = rotation_minimising(&pts, &t, V3d::z());
        for i in 0..pts.len() {
            assert!((n[i].norm() - 1.0).abs() < 1e-9);
            assert!(n[i].dot(&t[i]).abs() < 1e-9);
        }
        for i in 1..pts.len() - 1 {
            // angular velocity about the tangent: (dn/ds . b) must vanish
            let b = t[i].cross(&n[i]);
            let dn = (n[i + 1] - n[i - 1]) / (arc[i + 1] - arc[i - 1]);
            assert!(dn.dot(&b).abs() < 1e-4, "twist {} at {i}", dn.dot(&b));
        }
    }

    #[test]
    fn arc_helpers() {
        let pts = vec![V3d::zeros(), V3d::new(3.0, 4.0, 0.0), V3d::new(3.0, 4.0, 10.0)];
        let arc = arc_lengths(&pts);
        assert_eq!(arc, vec![0.0, 5.0, 15.0]);
        assert_eq!(locate_arc(&arc, 10.0), (1, 0.5));
        assert!((at_arc(&pts, &arc, 2.5) - V3d::new(1.5, 2.0, 0.0)).norm() < 1e-12);
        assert_eq!(at_arc(&pts, &arc, 99.0), pts[2]);
    }
}
