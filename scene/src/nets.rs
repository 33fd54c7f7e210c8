//! Surface nets: a closed triangle mesh of the zero level set of a function sampled on a grid.
//!
//! One vertex per cell whose corners change sign, at the mean of the points where its edges
//! cross zero (linear interpolation along each edge); one quad (two triangles) per grid edge
//! whose ends change sign, joining the four cells around it, wound so that its normal points
//! from the negative side (inside) to the positive one. The level set of a function is a
//! surface that never passes through itself, whatever the shape it bounds: that is why the
//! generated surfaces are meshed this way rather than swept. Written here rather than taken from
//! a crate: `fast-surface-nets` works on padded chunks of its own `ndshape` layout and would be
//! one more dependency for about 100 lines over a plain grid.

use lumen_import::Mesh;

/// A scalar field sampled on a regular grid: `values[(z * ny + y) * nx + x]` at
/// `origin + spacing * (x, y, z)`, negative inside.
#[derive(Debug, Clone)]
pub struct Grid {
    pub dims: [usize; 3],
    pub origin: [f64; 3],
    /// Distance between neighbouring samples, the same on every axis.
    pub spacing: f64,
    pub values: Vec<f32>,
}

impl Grid {
    /// A grid of `dims` samples, all `fill`.
    pub fn new(dims: [usize; 3], origin: [f64; 3], spacing: f64, fill: f32) -> Self {
        Self { dims, origin, spacing, values: vec![fill; dims[0] * dims[1] * dims[2]] }
    }

    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    /// Position of sample `(x, y, z)`.
    #[inline]
    pub fn position(&self, x: usize, y: usize, z: usize) -> [f64; 3] {
        [self.origin[0] + self.spacing * x as f64, self.origin[1] + self.spacing * y as f64, self.origin[2] + self.spacing * z as f64]
    }
}

/// The mesh of the zero level set of `grid` (see the module doc). Samples on the grid's
/// boundary should be positive, so that the surface is closed.
pub fn mesh(grid: &Grid) -> Mesh {
    let [nx, ny, nz] = grid.dims;
    if nx < 2 || ny < 2 || nz < 2 {
        return Mesh { vertices: Vec::new(), triangles: Vec::new() };
    }
    let (cx, cy) = (nx - 1, ny - 1);
    let cell = |x: usize, y: usize, z: usize| (z * cy + y) * cx + x;
    let mut vertex_of = vec![u32::MAX; cx * cy * (nz - 1)];
    let mut vertices = Vec::new();
    const CORNERS: [[usize; 3]; 8] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]];
    const EDGES: [[usize; 2]; 12] = [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];
    for z in 0..nz - 1 {
        for y in 0..cy {
            for x in 0..cx {
                let v: [f32; 8] = CORNERS.map(|c| grid.values[grid.index(x + c[0], y + c[1], z + c[2])]);
                let inside = v.iter().filter(|&&a| a < 0.0).count();
                if inside == 0 || inside == 8 {
                    continue;
                }
                let (mut sum, mut n) = ([0.0f64; 3], 0.0);
                for [a, b] in EDGES {
                    if (v[a] < 0.0) != (v[b] < 0.0) {
                        let t = (v[a] / (v[a] - v[b])) as f64;
                        for d in 0..3 {
                            sum[d] += CORNERS[a][d] as f64 + t * (CORNERS[b][d] as f64 - CORNERS[a][d] as f64);
                        }
                        n += 1.0;
                    }
                }
                let p = grid.position(x, y, z);
                vertex_of[cell(x, y, z)] = vertices.len() as u32;
                vertices.push([0, 1, 2].map(|d| (p[d] + grid.spacing * sum[d] / n) as f32));
            }
        }
    }
    let mut triangles = Vec::new();
    // Each edge from sample (x, y, z) along axis `a` is shared by the four cells whose indices
    // on the two other axes are one less or equal; the quad joins them.
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let here = grid.values[grid.index(x, y, z)] < 0.0;
                for axis in 0..3 {
                    let mut q = [x, y, z];
                    q[axis] += 1;
                    if q[axis] >= grid.dims[axis] {
                        continue;
                    }
                    let there = grid.values[grid.index(q[0], q[1], q[2])] < 0.0;
                    if here == there {
                        continue;
                    }
                    let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
                    let s = [x, y, z];
                    if s[u] == 0 || s[w] == 0 {
                        continue;
                    }
                    let at = |du: usize, dw: usize| {
                        let mut c = s;
                        c[u] -= du;
                        c[w] -= dw;
                        if c[0] >= cx || c[1] >= cy || c[2] >= nz - 1 {
                            return u32::MAX;
                        }
                        vertex_of[cell(c[0], c[1], c[2])]
                    };
                    let quad = [at(1, 1), at(0, 1), at(0, 0), at(1, 0)];
                    if quad.contains(&u32::MAX) {
                        continue;
                    }
                    // Counter-clockwise about `axis` seen from its positive end: the normal
                    // points along +axis; flip when the inside is at the far end.
                    let [a, b, c, d] = if here { quad } else { [quad[3], quad[2], quad[1], quad[0]] };
                    triangles.push([a, b, c]);
                    triangles.push([a, c, d]);
                }
            }
        }
    }
    Mesh { vertices, triangles }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of radius 10 on a 1-unit grid: every vertex within half a cell of the sphere,
    /// every edge shared by exactly two triangles (closed), normals outwards.
    #[test]
    fn sphere_is_closed_and_round() {
        let n = 26;
        let mut g = Grid::new([n; 3], [-12.5; 3], 1.0, 1.0);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = g.position(x, y, z);
                    let i = g.index(x, y, z);
                    g.values[i] = ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 10.0) as f32;
                }
            }
        }
        let m = mesh(&g);
        assert!(m.triangles.len() > 1000, "{} triangles", m.triangles.len());
        for v in &m.vertices {
            let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!((r - 10.0).abs() < 0.5, "vertex at radius {r}");
        }
        let mut edges = std::collections::HashMap::new();
        let mut outward = 0;
        for t in &m.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
            let [a, b, c] = t.map(|i| m.vertices[i as usize].map(f64::from));
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let nrm = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            if nrm[0] * a[0] + nrm[1] * a[1] + nrm[2] * a[2] > 0.0 {
                outward += 1;
            }
        }
        assert!(edges.values().all(|&k| k == 2), "open or non-manifold edges: {}", edges.values().filter(|&&k| k != 2).count());
        assert_eq!(outward, m.triangles.len(), "every triangle faces out");
    }
}
