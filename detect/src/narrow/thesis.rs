//! The published method (thesis chapter 2), as a fair baseline.
//!
//! Every frame: leaf boxes around both rings of tips of every tube segment and around every rod
//! segment, both BVHs rebuilt bottom-up, a dual traversal for candidate segment pairs, `x`
//! interpolated samples on each candidate, a proximity list pairing each rod sample with the
//! nearest tube sample, and the unsigned sector test at that section: the nearest point on the
//! polygon of wall tips, a contact when it is closer than the rod radius. The collision vector
//! runs from the rod sample to the wall, so it flips when the sample crosses the wall, and a
//! sample outside every leaf box is never tested: the failure this project fixes.
//!
//! What is *not* copied are the plain bugs of the published code: knots are the real
//! centripetal ones, samples are counted with integers, the end segments have leaves, and the
//! nearest-sample search looks only at candidate segments. Nor is it made slower than it need
//! be: each ring's box is computed once, candidates are grouped by a linear counting sort, and
//! buffers are reused, so nothing allocates per frame once warm.

use super::Emit;
use crate::broad::aabb::Aabb;
use crate::broad::bvh::ChainBvh;
use crate::samples::RodSamples;
use crate::section::TubeCache;
use crate::view::TubeView;
use crate::V3;
use lumen_proto::Contact;

/// The job of one interior pair by the published method: the rod's slot, the tube's slot, and
/// the method's reused buffers.
#[derive(Debug, Clone, Default)]
pub struct Thesis {
    pub rod: usize,
    pub tube: usize,
    tube_bvh: ChainBvh,
    rod_bvh: ChainBvh,
    pairs: Vec<(u32, u32)>,
    found: Vec<(u32, u32)>,
    start: Vec<u32>,
    fill: Vec<u32>,
    ring_boxes: Vec<Aabb>,
    /// Interpolated midline samples, `x + 1` per tube segment, valid where `stamp` matches.
    centres: Vec<V3>,
    stamp: Vec<u32>,
    frame: u32,
}

/// Closest point to `p` on segment `a..b`: returns (squared distance, parameter).
#[inline]
fn on_edge(p: &V3, a: &V3, b: &V3) -> (f32, f32) {
    let w = b - a;
    let ww = w.norm_squared();
    let l = if ww > 0.0 { ((p - a).dot(&w) / ww).clamp(0.0, 1.0) } else { 0.0 };
    ((a + w * l - p).norm_squared(), l)
}

impl Thesis {
    /// The job for rod slot `rod` inside tube slot `tube`.
    pub fn new(rod: usize, tube: usize) -> Self {
        Self { rod, tube, ..Self::default() }
    }

    /// This frame's interior contacts of `rod` in tube `t`, appended to `out`; returns the
    /// candidate leaf pairs.
    pub fn run(&mut self, t: &TubeView, cache: &mut TubeCache, rod: &RodSamples, emit: &Emit, out: &mut Vec<Contact>) -> u32 {
        let x = rod.x;
        let segs = t.segments();
        // Published leaves: the tips of both rings, rebuilt from scratch every frame. Each
        // ring's box is computed once and shared by its two segments.
        self.ring_boxes.clear();
        // The tips' box is the spokes' box moved to the ring's point (rounding is monotonic, so
        // the very same floats as the box of the tips themselves).
        self.ring_boxes.extend((0..t.rings).map(|r| {
            let c = t.point(r);
            Aabb { min: c, max: c }.minkowski(&t.spoke_box(r))
        }));
        let ring_boxes = &self.ring_boxes;
        self.tube_bvh.build(segs, |i| ring_boxes[i].merge(&ring_boxes[i + 1]));
        let rod_segs = rod.cubic.len();
        self.rod_bvh.build(rod_segs, |j| rod.leaf(j, 0.0));
        // Candidate pairs grouped by rod segment with a counting sort (linear, no comparison
        // sort): each rod sample then searches only its own segment's candidates.
        self.found.clear();
        let found = &mut self.found;
        self.rod_bvh.pairs(&self.tube_bvh, |j, i| found.push((j as u32, i as u32)));
        self.start.clear();
        self.start.resize(rod_segs + 1, 0);
        for &(j, _) in &self.found {
            self.start[j as usize + 1] += 1;
        }
        for j in 0..rod_segs {
            self.start[j + 1] += self.start[j];
        }
        self.pairs.clear();
        self.pairs.resize(self.found.len(), (0, 0));
        self.fill.clear();
        self.fill.extend_from_slice(&self.start[..rod_segs]);
        for &(j, i) in &self.found {
            let slot = &mut self.fill[j as usize];
            self.pairs[*slot as usize] = (j, i);
            *slot += 1;
        }
        let candidates = self.pairs.len() as u32;

        self.frame = self.frame.wrapping_add(1).max(1);
        if self.stamp.len() != segs || self.centres.len() != segs * (x + 1) {
            self.stamp.clear();
            self.stamp.resize(segs, 0);
            self.centres.clear();
            self.centres.resize(segs * (x + 1), V3::zeros());
        }

        let mut p0 = 0;
        while p0 < self.pairs.len() {
            let j = self.pairs[p0].0 as usize;
            let mut p1 = p0;
            while p1 < self.pairs.len() && self.pairs[p1].0 as usize == j {
                let i = self.pairs[p1].1 as usize;
                if self.stamp[i] != self.frame {
                    let c = cache.cubic(t, i);
                    for m in 0..=x {
                        self.centres[i * (x + 1) + m] = c.at(m as f32 / x as f32);
                    }
                    self.stamp[i] = self.frame;
                }
                p1 += 1;
            }
            // The segment's own samples (its end belongs to the next segment, but for the last).
            let last = j + 1 == rod.cubic.len();
            let range = j * x..j * x + x + usize::from(last);
            for s in range {
                let p = rod.pos[s];
                // Proximity list: the nearest interpolated tube sample among the candidates.
                let mut near = (f32::INFINITY, 0usize, 0usize);
                for &(_, i) in &self.pairs[p0..p1] {
                    let i = i as usize;
                    for m in 0..=x {
                        let d = (self.centres[i * (x + 1) + m] - p).norm_squared();
                        if d < near.0 {
                            near = (d, i, m);
                        }
                    }
                }
                let (_, i, m) = near;
                let u = m as f32 / x as f32;
                let c = self.centres[i * (x + 1) + m];
                let tip = |k: usize| c + t.spoke(i, k) * (1.0 - u) + t.spoke(i + 1, k) * u;
                // Unsigned sector test over every edge of the section.
                let mut best = (f32::INFINITY, 0usize, 0f32);
                let first = tip(0);
                let mut a = first;
                for k in 0..t.spokes {
                    let b = if k + 1 == t.spokes { first } else { tip(k + 1) };
                    let (d2, l) = on_edge(&p, &a, &b);
                    if d2 < best.0 {
                        best = (d2, k, l);
                    }
                    a = b;
                }
                let r = rod.radius[s];
                let (d2, k, l) = best;
                let dist = d2.sqrt();
                if dist < r + emit.margin {
                    let k1 = (k + 1) % t.spokes;
                    let wall = tip(k) * (1.0 - l) + tip(k1) * l;
                    let v = wall - p;
                    let radial = wall - c;
                    let normal = if dist > 0.0 {
                        v / dist
                    } else if radial.norm_squared() > 0.0 {
                        radial.normalize()
                    } else {
                        crate::section::any_perpendicular(cache.cubic(t, i).tangent(u).try_normalize(0.0).unwrap_or(V3::x()))
                    };
                    let mut ct = emit.contact(rod, s, p + normal * r, wall, normal, r - dist);
                    ct.index_b = i as u32;
                    ct.spoke_b = k as u32;
                    ct.param_b = u;
                    ct.weights_b = [(1.0 - u) * (1.0 - l), (1.0 - u) * l, u * (1.0 - l), u * l];
                    out.push(ct);
                }
            }
            p0 = p1;
        }
        candidates
    }
}
