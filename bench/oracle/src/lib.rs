//! Accuracy oracle for Lumen: the same continuous tube surface that `lumen-detect` models,
//! finely tessellated, with exact distances to the tessellation.
//!
//! A tube of `A` rings and `B` spokes per ring has the wall
//!
//! ```text
//! S(i, u, k, l) = C_i(u) + (1 - l) V_k(u) + l V_{k+1}(u),   V_k(u) = (1 - u) V_{i,k} + u V_{i+1,k}
//! ```
//!
//! with `C_i` the Catmull-Rom segment between rings `i` and `i + 1`
//! ([`lumen_detect::spline::Cubic::of_chain`]). [`Reference::new`] samples it at
//! `u = m / steps` on every spoke and joins consecutive tips by straight edges, which is exact in
//! `l` (the wall is straight between two tips at fixed `u`); only the `u` direction is
//! approximated. Each quad of the grid is split into two triangles.
//!
//! **Accuracy.** With `h = 1 / steps`, every point of the tessellation lies within
//!
//! ```text
//! e = max over cells of (h^2 max_u |C_i''(u)| + 2 h |T_{i,k}|) / 8,
//! T_{i,k} = (V_{i+1,k+1} - V_{i,k+1}) - (V_{i+1,k} - V_{i,k})
//! ```
//!
//! of the continuous surface at the same parameters, and conversely (linear interpolation on a
//! triangle of a function whose `l l` second derivative vanishes), so the Hausdorff distance
//! between the two is at most `e` and every unsigned distance this oracle returns is within `e`
//! of the distance to the continuous wall. [`Reference::bound`] returns `e`. `e` falls as
//! `1 / steps^2` for the curvature of the midline and as `1 / steps` for a wall that twists
//! between rings (the twist term is zero for a tube whose cross-section only translates and
//! bends, and small when spokes rotate slowly from ring to ring). All of this is in the
//! scene's own unit.
//!
//! **Numerics.** Everything is built in local coordinates (relative to the tube's first control
//! point) so a scene far from the origin keeps its precision. The midline cubic is the one
//! `lumen-detect` uses (its `f32` coefficients), evaluated in `f64`; vertices, triangle normals
//! and pseudo-normals are `f64`. parry3d's BVH ([`parry3d::partitioning::Bvh`], `f32` boxes
//! rounded outward) only prunes; every candidate triangle's nearest point, distance and feature
//! (face, edge or vertex) are computed in `f64`, and the nearest in `f64` wins. A query costs a
//! few microseconds near the wall and grows with the depth inside the lumen (the BVH must open
//! every triangle whose box is nearer than the wall).
//!
//! **Sign.** Distances and nearest points are to the wall only (the ends are open), but the
//! sign is that of the closed tube: the wall plus two caps (fans from the first and last control
//! point to their ring), with the angle-weighted pseudo-normal test of Baerentzen & Aanaes
//! (2005) at the nearest feature of that closed surface. A point past an end is therefore
//! outside (positive) even on the axis, and the sign flips across the cap planes while the
//! distance (to the open rim) does not. Triangles are oriented outward (away from the midline)
//! whichever way the spokes run around it.
//!
//! **Degenerate input** (coincident control points, zero spokes, collapsed rings) never panics:
//! vertices with identical coordinates are merged and zero-area triangles are dropped. A wall
//! with no area left at all is represented by its vertices (positive distances, never inside).

#![warn(missing_docs)]

use lumen_detect::spline::Cubic;
use lumen_detect::{Rod, Tube, V3};
use parry3d::bounding_volume::Aabb;
use parry3d::math::Vector;
use parry3d::partitioning::{Bvh, BvhBuildStrategy, BvhNode};
use std::collections::HashMap;

type D3 = [f64; 3];

#[inline]
fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
fn mul(a: D3, s: f64) -> D3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline]
fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
fn cross(a: D3, b: D3) -> D3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
#[inline]
fn norm(a: D3) -> f64 {
    dot(a, a).sqrt()
}
/// `a / |a|`, or `fallback` when `a` has no usable direction.
#[inline]
fn unit_or(a: D3, fallback: D3) -> D3 {
    let n = norm(a);
    if n > 0.0 && n.is_finite() {
        mul(a, 1.0 / n)
    } else {
        fallback
    }
}
#[inline]
fn to64(p: [f32; 3]) -> D3 {
    [p[0] as f64, p[1] as f64, p[2] as f64]
}
#[inline]
fn to32(p: D3) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, p[2] as f32]
}
#[inline]
fn v64(v: V3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// The largest `f32` not above `x`.
#[inline]
fn down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest `f32` not below `x`.
#[inline]
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// Distance from `p` to a BVH node's box (a lower bound of the distance to what it holds).
#[inline]
fn box_distance(node: &BvhNode, p: D3) -> f32 {
    let (lo, hi) = (node.mins(), node.maxs());
    let gap = |x: f64, l: f32, h: f32| (l as f64 - x).max(x - h as f64).max(0.0);
    let d = [gap(p[0], lo.x, hi.x), gap(p[1], lo.y, hi.y), gap(p[2], lo.z, hi.z)];
    down(norm(d))
}

/// A cubic's `f32` coefficients, evaluated in `f64`.
#[derive(Clone, Copy)]
struct Cubic64([D3; 4]);

impl Cubic64 {
    fn of(c: &Cubic) -> Self {
        Self(c.c.map(v64))
    }
    fn at(&self, u: f64) -> D3 {
        let c = &self.0;
        add(c[0], mul(add(c[1], mul(add(c[2], mul(c[3], u)), u)), u))
    }
    /// `max_u |C''(u)|` over [0, 1]: `C'' = 2 c2 + 6 c3 u` is linear, so an end attains it.
    fn max_second(&self) -> f64 {
        let c = &self.0;
        norm(mul(c[2], 2.0)).max(norm(add(mul(c[2], 2.0), mul(c[3], 6.0))))
    }
}

/// The answer of [`Reference::query`], in the scene's coordinates and unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefQuery {
    /// Signed distance from the point to the (open) wall: negative inside the closed tube.
    pub sd: f32,
    /// The nearest wall point.
    pub point: [f32; 3],
    /// Outward unit normal of the wall at `point`: the triangle's normal, or the angle-weighted
    /// pseudo-normal when `point` is on an edge or a vertex of the tessellation.
    pub normal: [f32; 3],
}

/// Where on a triangle its nearest point to a query lies.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Feature {
    /// Corner 0, 1 or 2.
    Vertex(usize),
    /// Edge 0 (corners 0-1), 1 (1-2) or 2 (2-0).
    Edge(usize),
    Face,
}

/// Nearest point of triangle `t` to `p` (Ericson, Real-Time Collision Detection, 5.1.5), with
/// the feature it lies on. The triangle must have a non-zero area.
fn closest_on_triangle(p: D3, t: [D3; 3]) -> (D3, Feature) {
    let [a, b, c] = t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (add(a, mul(ab, v)), Feature::Edge(0));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (add(a, mul(ac, w)), Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, mul(sub(c, b), w)), Feature::Edge(1));
    }
    let den = va + vb + vc;
    let (v, w) = (vb / den, vc / den);
    (add(a, add(mul(ab, v), mul(ac, w))), Feature::Face)
}

/// A nearest point on one triangle.
#[derive(Debug, Clone, Copy)]
struct Hit {
    tri: usize,
    point: D3,
    feature: Feature,
    dist: f64,
}

/// One end cap: its triangles and a ball holding them (to skip it cheaply).
#[derive(Debug, Clone)]
struct Cap {
    tris: std::ops::Range<usize>,
    centre: D3,
    radius: f64,
}

const NONE: u32 = u32::MAX;

/// The dense reference of one tube: its wall finely tessellated, for exact distances.
///
/// Built once per tube shape with [`Reference::new`]; [`Reference::query`] and
/// [`Reference::inside`] take points in the scene's coordinates.
pub struct Reference {
    /// The tube's first control point: the local frame's origin.
    origin: D3,
    /// Merged vertices, local.
    verts: Vec<D3>,
    /// Wall triangles (`..nw`), then cap triangles; all outward, none of zero area.
    tris: Vec<[u32; 3]>,
    nw: usize,
    /// Unit normal of each triangle.
    tri_n: Vec<D3>,
    /// Triangle across each edge (0: corners 0-1, 1: 1-2, 2: 2-0) of the closed surface, or
    /// `NONE`.
    nbr: Vec<[u32; 3]>,
    /// Angle-weighted vertex pseudo-normals (unit, or zero) of the wall alone and of the
    /// closed surface (they differ on the two end rings only).
    vpn_wall: Vec<D3>,
    vpn_closed: Vec<D3>,
    caps: Vec<Cap>,
    /// parry3d BVH over the wall triangles (leaf `t` is `tris[t]`), boxes rounded outward to
    /// `f32`, local.
    bvh: Bvh,
    bound: f64,
}

impl std::fmt::Debug for Reference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reference")
            .field("origin", &self.origin)
            .field("vertices", &self.verts.len())
            .field("wall_triangles", &self.nw)
            .field("cap_triangles", &(self.tris.len() - self.nw))
            .field("bound", &self.bound)
            .finish_non_exhaustive()
    }
}

/// Vertex and triangle accumulation with exact-duplicate merging.
#[derive(Default)]
struct Builder {
    verts: Vec<D3>,
    index: HashMap<[u64; 3], u32>,
    tris: Vec<[u32; 3]>,
}

impl Builder {
    fn vertex(&mut self, p: D3) -> u32 {
        // `+ 0.0` turns -0.0 into 0.0 so both merge.
        let key = p.map(|x| (x + 0.0).to_bits());
        let n = self.verts.len() as u32;
        let id = *self.index.entry(key).or_insert(n);
        if id == n {
            self.verts.push(p);
        }
        id
    }

    /// Adds triangle `t` unless it is degenerate (repeated or non-finite vertices, or an area
    /// that is zero to working precision: `|ab x ac| <= 1e-12 * longest edge^2`).
    fn triangle(&mut self, t: [u32; 3]) {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return;
        }
        let [a, b, c] = t.map(|i| self.verts[i as usize]);
        if !a.iter().chain(&b).chain(&c).all(|x| x.is_finite()) {
            return;
        }
        let (ab, ac, bc) = (sub(b, a), sub(c, a), sub(c, b));
        let longest = dot(ab, ab).max(dot(ac, ac)).max(dot(bc, bc));
        if norm(cross(ab, ac)) <= 1e-12 * longest {
            return;
        }
        self.tris.push(t);
    }
}

impl Reference {
    /// Tessellates tube `t` with Catmull-Rom parameter `alpha`, `steps` axial subdivisions per
    /// segment (`u = m / steps`; 0 counts as 1) and every spoke exact (straight edges between
    /// consecutive tips at fixed `u`).
    ///
    /// The rings themselves are vertices of the tessellation (`u = 0` of each segment, and the
    /// last ring). Triangles are oriented outward whichever way the spokes run. Missing radial
    /// vectors (a `radial` shorter than `rings * spokes`) read as zero; nothing here panics on
    /// degenerate geometry.
    pub fn new(t: &Tube, alpha: f32, steps: usize) -> Reference {
        let steps = steps.max(1);
        let rings = t.points.len();
        let nb = t.spokes;
        let origin = t.points.first().map_or([0.0; 3], |p| to64(*p));
        // Local control points as `lumen-detect` forms them: `f32`, correctly rounded.
        let local32 = |j: usize| {
            let p = sub(to64(t.points[j]), origin);
            V3::new(p[0] as f32, p[1] as f32, p[2] as f32)
        };
        let spoke = |i: usize, k: usize| t.radial.get(i * nb + k).map_or([0.0; 3], |v| to64(*v));

        let mut b = Builder::default();
        let stations = if rings >= 2 { (rings - 1) * steps + 1 } else { rings };
        let mut grid: Vec<u32> = Vec::with_capacity(stations * nb);
        let mut centre: Vec<D3> = Vec::with_capacity(stations);
        let mut bound = 0.0f64;
        let h = 1.0 / steps as f64;
        for i in 0..rings.saturating_sub(1) {
            let c = Cubic64::of(&Cubic::of_chain(local32, rings, i, alpha));
            let m2 = c.max_second();
            for k in 0..nb {
                let k1 = (k + 1) % nb;
                let twist = sub(sub(spoke(i + 1, k1), spoke(i, k1)), sub(spoke(i + 1, k), spoke(i, k)));
                bound = bound.max((h * h * m2 + 2.0 * h * norm(twist)) / 8.0);
            }
            for m in 0..steps {
                let u = m as f64 * h;
                let cu = c.at(u);
                centre.push(cu);
                for k in 0..nb {
                    let v = add(mul(spoke(i, k), 1.0 - u), mul(spoke(i + 1, k), u));
                    grid.push(b.vertex(add(cu, v)));
                }
            }
        }
        if rings >= 1 {
            let cl = v64(local32(rings - 1));
            centre.push(cl);
            for k in 0..nb {
                grid.push(b.vertex(add(cl, spoke(rings - 1, k))));
            }
        }
        let g = |s: usize, k: usize| grid[s * nb + k];

        // Wall: quad (s, k) (s, k+1) (s+1, k+1) (s+1, k), split along (s, k)-(s+1, k+1). The
        // order is outward for spokes counter-clockwise about the midline; `score` measures
        // which way it actually is.
        let mut score = 0.0f64;
        for s in 0..stations.saturating_sub(1) {
            let mid = mul(add(centre[s], centre[s + 1]), 0.5);
            for k in 0..nb {
                let k1 = (k + 1) % nb;
                for tri in [[g(s, k), g(s, k1), g(s + 1, k1)], [g(s, k), g(s + 1, k1), g(s + 1, k)]] {
                    let before = b.tris.len();
                    b.triangle(tri);
                    if b.tris.len() > before {
                        let [p0, p1, p2] = tri.map(|i| b.verts[i as usize]);
                        let n = cross(sub(p1, p0), sub(p2, p0));
                        let centroid = mul(add(add(p0, p1), p2), 1.0 / 3.0);
                        score += dot(n, sub(centroid, mid)).signum() * norm(n);
                    }
                }
            }
        }
        let nw = b.tris.len();

        // Caps: fans from the first and last control point, ordered to match the wall.
        let mut caps = Vec::new();
        if rings >= 2 && nb >= 3 {
            for (s, first) in [(0, true), (stations - 1, false)] {
                let c = centre[s];
                let ci = b.vertex(c);
                let start = b.tris.len();
                let mut radius = 0.0f64;
                for k in 0..nb {
                    let k1 = (k + 1) % nb;
                    radius = radius.max(norm(sub(b.verts[g(s, k) as usize], c)));
                    b.triangle(if first { [ci, g(s, k1), g(s, k)] } else { [ci, g(s, k), g(s, k1)] });
                }
                if b.tris.len() > start {
                    caps.push(Cap { tris: start..b.tris.len(), centre: c, radius });
                }
            }
        }

        let Builder { verts, mut tris, .. } = b;
        if score < 0.0 {
            for t in &mut tris {
                t.swap(1, 2);
            }
        }

        // Normals (the builder guarantees a non-zero area).
        let corner = |t: &[u32; 3], j: usize| verts[t[j] as usize];
        let tri_n: Vec<D3> = tris.iter().map(|t| unit_or(cross(sub(corner(t, 1), corner(t, 0)), sub(corner(t, 2), corner(t, 0))), [0.0; 3])).collect();

        // Neighbours across edges: sort the edges by their vertex pair and pair equal keys.
        let mut edges: Vec<(u64, u32)> = Vec::with_capacity(tris.len() * 3);
        for (ti, t) in tris.iter().enumerate() {
            for e in 0..3 {
                let (a, c) = (t[e], t[(e + 1) % 3]);
                let key = ((a.min(c) as u64) << 32) | a.max(c) as u64;
                edges.push((key, (ti * 3 + e) as u32));
            }
        }
        edges.sort_unstable();
        let mut nbr = vec![[NONE; 3]; tris.len()];
        for w in edges.chunk_by(|x, y| x.0 == y.0) {
            // Manifold edges have two triangles; of a non-manifold one, the first two pair.
            if let [x, y, ..] = w {
                let (tx, ex) = (x.1 as usize / 3, x.1 as usize % 3);
                let (ty, ey) = (y.1 as usize / 3, y.1 as usize % 3);
                nbr[tx][ex] = ty as u32;
                nbr[ty][ey] = tx as u32;
            }
        }

        // Angle-weighted vertex pseudo-normals.
        let mut vpn_wall = vec![[0.0; 3]; verts.len()];
        let mut vpn_closed = vec![[0.0; 3]; verts.len()];
        for (ti, t) in tris.iter().enumerate() {
            for j in 0..3 {
                let p = corner(t, j);
                let e1 = sub(corner(t, (j + 1) % 3), p);
                let e2 = sub(corner(t, (j + 2) % 3), p);
                let angle = norm(cross(e1, e2)).atan2(dot(e1, e2));
                let w = mul(tri_n[ti], angle);
                let v = t[j] as usize;
                vpn_closed[v] = add(vpn_closed[v], w);
                if ti < nw {
                    vpn_wall[v] = add(vpn_wall[v], w);
                }
            }
        }
        for n in vpn_wall.iter_mut().chain(vpn_closed.iter_mut()) {
            *n = unit_or(*n, [0.0; 3]);
        }

        let leaves = tris[..nw].iter().enumerate().map(|(ti, t)| {
            let [a, b, c] = t.map(|i| verts[i as usize]);
            let lo = |j: usize| down(a[j].min(b[j]).min(c[j]));
            let hi = |j: usize| up(a[j].max(b[j]).max(c[j]));
            (ti, Aabb::new(Vector::new(lo(0), lo(1), lo(2)), Vector::new(hi(0), hi(1), hi(2))))
        });
        let bvh = Bvh::from_iter(BvhBuildStrategy::Binned, leaves);

        Reference { origin, verts, tris, nw, tri_n, nbr, vpn_wall, vpn_closed, caps, bvh, bound }
    }

    /// Upper bound on the distance between the tessellation and the continuous surface
    /// (Hausdorff, scene unit): every distance from [`Reference::query`] is within this of the
    /// distance to the continuous wall, up to rounding. See the crate documentation for the
    /// formula; it shrinks as `1 / steps^2` (midline curvature) plus `1 / steps` (wall twist).
    pub fn bound(&self) -> f32 {
        self.bound as f32
    }

    /// Number of wall triangles (zero-area ones dropped).
    pub fn wall_triangles(&self) -> usize {
        self.nw
    }

    fn corners(&self, tri: usize) -> [D3; 3] {
        self.tris[tri].map(|i| self.verts[i as usize])
    }

    fn hit(&self, p: D3, tri: usize) -> Hit {
        let (point, feature) = closest_on_triangle(p, self.corners(tri));
        Hit { tri, point, feature, dist: norm(sub(p, point)) }
    }

    /// The outward (pseudo-)normal at a hit's feature: of the wall alone, or of the closed
    /// surface (the wall and its caps).
    fn feature_normal(&self, h: &Hit, closed: bool) -> D3 {
        let n = self.tri_n[h.tri];
        match h.feature {
            Feature::Face => n,
            Feature::Edge(e) => {
                let o = self.nbr[h.tri][e];
                if o != NONE && (closed || (o as usize) < self.nw) {
                    unit_or(add(n, self.tri_n[o as usize]), n)
                } else {
                    n
                }
            }
            Feature::Vertex(j) => {
                let v = self.tris[h.tri][j] as usize;
                let pn = if closed { self.vpn_closed[v] } else { self.vpn_wall[v] };
                if pn == [0.0; 3] {
                    n
                } else {
                    pn
                }
            }
        }
    }

    /// Nearest wall hit, and whether `p` is inside the closed tube (local coordinates).
    fn solve(&self, p: D3) -> Option<(Hit, bool)> {
        if self.nw == 0 || !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        // Nearest wall triangle: parry's BVH prunes with box distances (rounded down, so
        // conservative); leaves compare in f64. A leaf nearer in f64 gets a cost strictly below
        // the best so far even when both round to the same f32, so the argmin is the f64 one.
        let best = std::cell::Cell::new(f64::INFINITY);
        let (_, (_, wall)) = self.bvh.find_best(
            f32::MAX,
            |node: &BvhNode, _| box_distance(node, p),
            |leaf, best_cost| {
                let h = self.hit(p, leaf as usize);
                (h.dist < best.get()).then(|| {
                    best.set(h.dist);
                    (down(h.dist).min(best_cost.next_down()), h)
                })
            },
        )?;
        // The closed surface's nearest feature: the wall's, unless a cap is strictly nearer.
        let mut near = wall;
        for cap in &self.caps {
            if norm(sub(p, cap.centre)) - cap.radius < near.dist {
                for t in cap.tris.clone() {
                    let h = self.hit(p, t);
                    if h.dist < near.dist {
                        near = h;
                    }
                }
            }
        }
        let inside = dot(sub(p, near.point), self.feature_normal(&near, true)) < 0.0;
        Some((wall, inside))
    }

    /// The nearest wall point, the signed distance (negative inside the lumen, i.e. inside the
    /// tube closed by its end caps) and the wall's outward unit normal there (the triangle's
    /// normal, or the angle-weighted pseudo-normal of the wall at an edge or vertex). Computed in
    /// `f64` in local coordinates; `p` and the result are in the scene's coordinates.
    ///
    /// A wall with no area (everything collapsed) answers its nearest vertex, with a positive
    /// distance and the direction towards `p` as normal.
    pub fn query(&self, p: [f32; 3]) -> RefQuery {
        let pl = sub(to64(p), self.origin);
        let (point, sd, normal) = match self.solve(pl) {
            Some((h, inside)) => (h.point, if inside { -h.dist } else { h.dist }, self.feature_normal(&h, false)),
            None => {
                let q = self.verts.iter().copied().min_by(|a, b| dot(sub(pl, *a), sub(pl, *a)).total_cmp(&dot(sub(pl, *b), sub(pl, *b)))).unwrap_or(pl);
                let d = sub(pl, q);
                (q, norm(d), unit_or(d, [1.0, 0.0, 0.0]))
            }
        };
        RefQuery { sd: sd as f32, point: to32(add(point, self.origin)), normal: to32(normal) }
    }

    /// Whether `p` lies inside the closed (capped) tube: the sign of [`Reference::query`].
    pub fn inside(&self, p: [f32; 3]) -> bool {
        self.solve(sub(to64(p), self.origin)).is_some_and(|(_, inside)| inside)
    }
}

/// Dense samples of a rod's midline: the Catmull-Rom of `lumen-detect` (`Cubic::of_chain` over
/// the rod's control points, its `f32` coefficients evaluated in `f64`), `n` samples per segment
/// at `u = s / n` (0 counts as 1) plus the last control point, each with its radius
/// interpolated linearly between control points. A rod of `A` points gives `(A - 1) n + 1`
/// samples (none for an empty rod), in the scene's coordinates.
pub fn dense_rod(rod: &Rod, alpha: f32, n: usize) -> Vec<([f32; 3], f32)> {
    let n = n.max(1);
    let count = rod.points.len();
    let Some(first) = rod.points.first() else {
        return Vec::new();
    };
    let origin = to64(*first);
    let local32 = |j: usize| {
        let p = sub(to64(rod.points[j]), origin);
        V3::new(p[0] as f32, p[1] as f32, p[2] as f32)
    };
    let radius = |i: usize| {
        let r = if rod.radius.len() == 1 { rod.radius.first() } else { rod.radius.get(i).or(rod.radius.last()) };
        r.copied().unwrap_or(0.0) as f64
    };
    let mut out = Vec::with_capacity((count - 1) * n + 1);
    for j in 0..count - 1 {
        let c = Cubic64::of(&Cubic::of_chain(local32, count, j, alpha));
        let (r0, r1) = (radius(j), radius(j + 1));
        for s in 0..n {
            let u = s as f64 / n as f64;
            out.push((to32(add(c.at(u), origin)), (r0 + (r1 - r0) * u) as f32));
        }
    }
    out.push((rod.points[count - 1], radius(count - 1) as f32));
    out
}

#[cfg(test)]
mod tests;
