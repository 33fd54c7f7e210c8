//! Read-only views of one body inside the flat frame state, in local coordinates.
//!
//! Every position is read relative to a per-frame origin (a control point of the scene), so a
//! scene far from the world origin loses no precision inside the pipeline: subtracting two
//! nearby `f32` values is exact, and all further arithmetic is on small numbers.

use crate::broad::aabb::Aabb;
use crate::V3;

/// A tube: `rings` control points, each followed by `spokes` radial vectors.
#[derive(Debug, Clone, Copy)]
pub struct TubeView<'a> {
    /// The floats as triples: one bounds check a vector, where a slice of three takes two.
    data: &'a [[f32; 3]],
    pub rings: usize,
    pub spokes: usize,
    /// Triples per ring: the control point and its spokes.
    stride: usize,
    origin: V3,
}

impl<'a> TubeView<'a> {
    /// `data` must hold `rings * (spokes + 1) * 3` floats.
    pub fn new(data: &'a [f32], rings: usize, spokes: usize, origin: V3) -> Self {
        debug_assert_eq!(data.len(), rings * (spokes + 1) * 3);
        let (data, _) = data.as_chunks::<3>();
        Self { data, rings, spokes, stride: spokes + 1, origin }
    }

    /// Control point `i`, local.
    #[inline]
    pub fn point(&self, i: usize) -> V3 {
        let [x, y, z] = self.data[i * self.stride];
        V3::new(x - self.origin.x, y - self.origin.y, z - self.origin.z)
    }

    /// Radial vector `k` of ring `i` (relative to its control point).
    #[inline]
    pub fn spoke(&self, i: usize, k: usize) -> V3 {
        V3::from(self.data[i * self.stride + 1 + k])
    }

    /// Ring `i`'s radial vectors, in order (relative to its control point).
    #[inline]
    pub fn spokes_of(&self, i: usize) -> &'a [[f32; 3]] {
        let o = i * self.stride + 1;
        &self.data[o..o + self.spokes]
    }

    /// Ring `i` as sent: its control point (world, not local) then its radial vectors.
    #[inline]
    pub fn ring_of(&self, i: usize) -> &'a [[f32; 3]] {
        let o = i * self.stride;
        &self.data[o..o + self.stride]
    }

    /// The box of ring `i`'s radial vectors (relative to its control point), read in one pass
    /// over the ring's floats.
    pub fn spoke_box(&self, i: usize) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &v in self.spokes_of(i) {
            b.add(V3::from(v));
        }
        b
    }

    /// Segments (ring pairs).
    pub fn segments(&self) -> usize {
        self.rings - 1
    }
}

/// A rod: control points only (radii live in the scene spec).
#[derive(Debug, Clone, Copy)]
pub struct RodView<'a> {
    data: &'a [f32],
    pub points: usize,
    origin: V3,
}

impl<'a> RodView<'a> {
    pub fn new(data: &'a [f32], points: usize, origin: V3) -> Self {
        debug_assert_eq!(data.len(), points * 3);
        Self { data, points, origin }
    }

    /// Control point `i`, local.
    #[inline]
    pub fn point(&self, i: usize) -> V3 {
        let d = &self.data[i * 3..i * 3 + 3];
        V3::new(d[0] - self.origin.x, d[1] - self.origin.y, d[2] - self.origin.z)
    }
}
