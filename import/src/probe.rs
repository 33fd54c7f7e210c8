//! Tube coordinates for checking scenes: where a point is along a [`Tube`], how far it is from
//! the midline, and how far the wall is in its direction.
//!
//! This is a checker, not the detection pipeline: between two rings the midline and the radial
//! vectors are interpolated linearly (the pipeline uses Catmull-Rom for the midline; with rings
//! a millimetre or so apart the two differ by hundredths of a millimetre). Each ring's plane has
//! the normal of its radial vectors (their area normal, oriented along the midline), so the
//! bracketing rings of a point are the two planes it lies between, as in
//! `lumen_detect::section`.

use crate::geom::{arc_lengths, d3, V3d};
use lumen_detect::Tube;

/// A tube's rings, prepared for queries.
#[derive(Debug, Clone)]
pub struct Lumen {
    points: Vec<V3d>,
    normals: Vec<V3d>,
    /// +1 where spokes turn counter-clockwise about the normal, -1 clockwise.
    orient: Vec<f64>,
    radial: Vec<V3d>,
    spokes: usize,
    arc: Vec<f64>,
}

/// Where a point is in a tube.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// The point lies between ring `ring` and `ring + 1` ...
    pub ring: usize,
    /// ... at this fraction.
    pub u: f64,
    /// Arc length of the midline there.
    pub s: f64,
    /// Distance from the midline in the section plane.
    pub rho: f64,
    /// Distance from the midline to the wall in the direction of the point.
    pub wall: f64,
}

impl Probe {
    /// `wall - rho`: positive inside the lumen, negative outside the wall.
    pub fn gap(&self) -> f64 {
        self.wall - self.rho
    }
}

impl Lumen {
    /// Prepares `tube` (at least two rings).
    pub fn new(tube: &Tube) -> Self {
        let n = tube.rings();
        let b = tube.spokes;
        let points: Vec<V3d> = tube.points.iter().map(|&p| d3(p)).collect();
        let radial: Vec<V3d> = tube.radial.iter().map(|&p| d3(p)).collect();
        let mut normals = Vec::with_capacity(n);
        let mut orient = Vec::with_capacity(n);
        for i in 0..n {
            let along = points[(i + 1).min(n - 1)] - points[i.saturating_sub(1)];
            let mut area = V3d::zeros();
            for k in 0..b {
                area += radial[i * b + k].cross(&radial[i * b + (k + 1) % b]);
            }
            let (nrm, o) = match area.try_normalize(1e-12) {
                Some(a) if a.dot(&along) >= 0.0 => (a, 1.0),
                Some(a) => (-a, -1.0),
                None => (along.try_normalize(1e-12).unwrap_or_else(V3d::x), 1.0),
            };
            normals.push(nrm);
            orient.push(o);
        }
        let arc = arc_lengths(&points);
        Self { points, normals, orient, radial, spokes: b, arc }
    }

    /// Number of rings.
    pub fn rings(&self) -> usize {
        self.points.len()
    }

    /// Arc length of the midline at each ring.
    pub fn arc(&self) -> &[f64] {
        &self.arc
    }

    /// Unit normal of ring `i`'s plane, along the midline.
    pub fn normal(&self, i: usize) -> V3d {
        self.normals[i]
    }

    /// Control point of ring `i`.
    pub fn point(&self, i: usize) -> V3d {
        self.points[i]
    }

    /// Radial vector `k` of ring `i`.
    pub fn spoke(&self, i: usize, k: usize) -> V3d {
        self.radial[i * self.spokes + k]
    }

    /// Longest radial vector of ring `i`.
    pub fn max_radius(&self, i: usize) -> f64 {
        (0..self.spokes).map(|k| self.spoke(i, k).norm()).fold(0.0, f64::max)
    }

    /// Distance to the wall from the midline at ring `i`, in-plane direction `dir`.
    pub fn wall_radius(&self, i: usize, dir: V3d) -> f64 {
        let spokes: Vec<V3d> = (0..self.spokes).map(|k| self.spoke(i, k)).collect();
        section_radius(&spokes, self.normals[i], self.orient[i], dir)
    }

    /// Locates `p`, walking ring planes from ring `hint`; `None` before the first ring's plane
    /// or past the last one.
    pub fn locate(&self, p: [f32; 3], hint: usize) -> Option<Probe> {
        let n = self.rings();
        if n < 2 {
            return None;
        }
        let p = d3(p);
        let mut i = hint.min(n - 2);
        let d = |j: usize| (p - self.points[j]).dot(&self.normals[j]);
        for _ in 0..=n {
            let (d0, d1) = (d(i), d(i + 1));
            if d0 < 0.0 {
                if i == 0 {
                    return None;
                }
                i -= 1;
            } else if d1 > 0.0 {
                if i + 2 == n {
                    return None;
                }
                i += 1;
            } else {
                let u = if d0 - d1 > 0.0 { d0 / (d0 - d1) } else { 0.0 };
                let c = self.points[i].lerp(&self.points[i + 1], u);
                let nrm = self.normals[i].lerp(&self.normals[i + 1], u).normalize();
                let mut q = p - c;
                q -= nrm * q.dot(&nrm);
                let b = self.spokes;
                let spokes: Vec<V3d> = (0..b).map(|k| self.spoke(i, k).lerp(&self.spoke(i + 1, k), u)).collect();
                let wall = section_radius(&spokes, nrm, self.orient[i], q);
                let s = self.arc[i] + u * (self.arc[i + 1] - self.arc[i]);
                return Some(Probe { ring: i, u, s, rho: q.norm(), wall });
            }
        }
        None
    }
}

/// Distance from the centre to the polygon of spoke tips along in-plane direction `dir`
/// (`nrm` the plane normal, `o` the turning sense of the spokes about it).
pub(crate) fn section_radius(spokes: &[V3d], nrm: V3d, o: f64, dir: V3d) -> f64 {
    let b = spokes.len();
    let proj = |v: V3d| v - nrm * v.dot(&nrm);
    let q = proj(dir);
    if q.norm() < 1e-12 {
        return proj(spokes[0]).norm();
    }
    for k in 0..b {
        let (a, c) = (proj(spokes[k]), proj(spokes[(k + 1) % b]));
        let s1 = o * a.cross(&q).dot(&nrm);
        let s2 = o * q.cross(&c).dot(&nrm);
        if s1 >= 0.0 && s2 >= 0.0 && s1 + s2 > 0.0 && (a + c).dot(&q) > -1e-12 * q.norm() {
            let l = s1 / (s1 + s2);
            let w = a + (c - a) * l;
            // length of w along q (w is on the ray through q)
            return w.dot(&q) / q.norm();
        }
    }
    // Not star-shaped about the centre: fall back to the nearest spoke by angle.
    let qn = q.normalize();
    spokes.iter().map(|&v| proj(v)).max_by(|a, c| a.normalize().dot(&qn).total_cmp(&c.normalize().dot(&qn))).map_or(0.0, |v| v.norm())
}

/// How close a tube's walls come to each other and how tight its bends are, from its midline
/// and the longest radial vector of each ring (conservative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clearance {
    /// Smallest `|P_i - P_j| - (R_i + R_j)` over ring pairs more than
    /// `max(40 mm, 1.5 (R_i + R_j))` apart along the arc (`R` = longest radial vector of the
    /// ring): below zero the walls of two loops overlap.
    pub min_wall_gap: f64,
    /// The ring pair where it occurs.
    pub at: (usize, usize),
    /// Smallest ratio of the midline's bend radius to the ring's longest radial vector: below
    /// one the rings of a bend cross inside the lumen.
    pub min_bend_ratio: f64,
    /// The ring where it occurs.
    pub bend_at: usize,
}

/// Measures [`Clearance`]. Curvature is taken over a chord of about `2 R` around each ring
/// (a wall follows its midline at that scale, not at the ring spacing's noise). The pair search
/// is quadratic in the rings; fine for thousands.
pub fn clearance(tube: &Tube) -> Clearance {
    let lm = Lumen::new(tube);
    let n = lm.rings();
    let r: Vec<f64> = (0..n).map(|i| lm.max_radius(i)).collect();
    let arc = &lm.arc;
    let mut best = (f64::INFINITY, (0, 0));
    for i in 0..n {
        for j in i + 1..n {
            let need = (1.5 * (r[i] + r[j])).max(40.0);
            if arc[j] - arc[i] <= need {
                continue;
            }
            let g = (lm.points[i] - lm.points[j]).norm() - (r[i] + r[j]);
            if g < best.0 {
                best = (g, (i, j));
            }
        }
    }
    let mut bend = (f64::INFINITY, 0);
    for i in 0..n {
        // points about R before and after
        let h = r[i].max(1e-3);
        let (a, b) = (arc[i] - h, arc[i] + h);
        if a < 0.0 || b > arc[n - 1] {
            continue;
        }
        let pa = crate::geom::at_arc(&lm.points, arc, a);
        let pb = crate::geom::at_arc(&lm.points, arc, b);
        let pc = lm.points[i];
        // circumradius of the three points
        let (x, y, z) = ((pa - pc).norm(), (pb - pc).norm(), (pa - pb).norm());
        let area2 = (pa - pc).cross(&(pb - pc)).norm();
        let rc = if area2 > 1e-12 { x * y * z / (2.0 * area2) } else { f64::INFINITY };
        let ratio = rc / r[i];
        if ratio < bend.0 {
            bend = (ratio, i);
        }
    }
    Clearance { min_wall_gap: best.0, at: best.1, min_bend_ratio: bend.0, bend_at: bend.1 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(r: f32, b: usize) -> Tube {
        let pts: Vec<[f32; 3]> = (0..11).map(|i| [0.0, 0.0, i as f32 * 10.0]).collect();
        let radial = (0..11)
            .flat_map(|_| {
                (0..b).map(move |k| {
                    let a = k as f32 * std::f32::consts::TAU / b as f32;
                    [r * a.cos(), r * a.sin(), 0.0]
                })
            })
            .collect();
        Tube::new(pts, radial, b).unwrap()
    }

    #[test]
    fn locates_and_measures_in_a_straight_tube() {
        let t = straight(10.0, 64);
        let lm = Lumen::new(&t);
        let p = lm.locate([3.0, 4.0, 55.0], 0).unwrap();
        assert_eq!(p.ring, 5);
        assert!((p.u - 0.5).abs() < 1e-9);
        assert!((p.s - 55.0).abs() < 1e-9);
        assert!((p.rho - 5.0).abs() < 1e-9);
        // inscribed polygon: between 10 cos(pi/64) and 10
        assert!(p.wall > 9.98 && p.wall <= 10.0 + 1e-9, "{}", p.wall);
        assert!(lm.locate([0.0, 0.0, -1.0], 5).is_none());
        assert!(lm.locate([0.0, 0.0, 101.0], 5).is_none());
        let out = lm.locate([0.0, -13.0, 20.0], 9).unwrap();
        assert!(out.gap() < -2.9);
    }

    #[test]
    fn clearance_of_a_straight_tube_is_infinite_and_bend_free() {
        let c = clearance(&straight(10.0, 8));
        assert!(c.min_wall_gap > 0.0);
        assert!(c.min_bend_ratio > 1e6);
    }
}
