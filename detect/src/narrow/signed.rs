//! Signed containment with temporal coherence (the default method).
//!
//! Each rod sample remembers the tube segment and sector it was in last frame and walks from
//! there (a few ring planes at most per frame); the first sample of a rod seeds the next, so even
//! a fresh frame walks the tube once along the rod. Only when a walk fails does the sample
//! re-acquire through the tube's BVH. A sample outside the wall keeps its segment: it is a
//! contact with positive depth however far out it is, and its normal is the wall's.

use super::Emit;
use crate::aabb::Aabb;
use crate::bvh::ChainBvh;
use crate::nearest::{nearest, MAX_OTHERS};
use crate::samples::RodSamples;
use crate::section::{Axial, Gap, Reading, TubeCache};
use crate::view::TubeView;
use crate::V3;
use lumen_proto::contact::{FLAG_NOT_STAR, FLAG_OUTSIDE, FLAG_OTHER_WALL};
use lumen_proto::Contact;

/// Ring planes a sample may walk per frame before it re-acquires through the BVH.
pub const WINDOW: usize = 32;

/// Segments along the tube within which a sample's second opinion looks for a section holding
/// it: folded planes at a tight bend lie within a few centimetres of arc (1 mm rings), a
/// neighbouring loop much further.
pub const FOLD_REACH: usize = 2 * WINDOW;

/// What a sample remembers between frames.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Track {
    pub seg: u32,
    pub sector: u16,
    pub valid: bool,
}

/// Counters of one frame, for benchmarks and diagnostics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Samples located by walking from last frame or from their neighbour.
    pub walked: u32,
    /// Samples that re-acquired through the BVH.
    pub reacquired: u32,
    /// Candidate leaf pairs from BVH traversals.
    pub candidates: u32,
    /// Ring planes the walks crossed, from each sample's starting guess to its segment.
    pub planes: u32,
}

/// The tube's BVH with conservative leaves (spline bulge + every spoke of both rings), refit at
/// most once per frame and only when something needs it.
#[derive(Debug, Clone, Default)]
pub struct TubeBvh {
    pub bvh: ChainBvh,
    /// The box of each ring's radial vectors this frame ([`TubeView::spoke_box`]).
    rings: Vec<Aabb>,
    fresh: bool,
}

impl TubeBvh {
    /// Marks the boxes stale for a new frame.
    pub fn begin(&mut self) {
        self.fresh = false;
    }

    /// Refits if stale. Leaf `i` holds segment `i`'s whole wall: the Minkowski sum of the
    /// midline's Bezier hull and the box of both rings' radial vectors. A refit reads the whole
    /// tube, so each ring's spokes are read once (a ring bounds the segments on both its sides).
    pub fn ensure(&mut self, t: &TubeView, cache: &mut TubeCache) -> &ChainBvh {
        if !self.fresh {
            self.rings.clear();
            self.rings.extend((0..t.rings).map(|i| t.spoke_box(i)));
            let rings = &self.rings;
            self.bvh.build(t.segments(), |i| cache.cubic(t, i).bounds().minkowski(&rings[i].merge(&rings[i + 1])));
            self.fresh = true;
        }
        &self.bvh
    }
}

/// Squared distance from `p` to the chord of segment `i`.
fn chord_distance2(t: &TubeView, i: usize, p: &V3) -> (f32, f32) {
    let (a, b) = (t.point(i), t.point(i + 1));
    let ab = b - a;
    let len2 = ab.norm_squared();
    let u = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    ((a + ab * u - p).norm_squared(), u)
}

/// Locates `p` without history: the most-inside segment whose box holds it, else the nearest
/// midline chord. Returns the axial position (`BeforeStart` / `AfterEnd` beyond the ends).
pub fn reacquire(t: &TubeView, cache: &mut TubeCache, bvh: &mut TubeBvh, p: &V3, refine: u32, counters: &mut Counters) -> Axial {
    counters.reacquired += 1;
    let tree = bvh.ensure(t, cache);
    let mut best: Option<(f32, usize, f32)> = None;
    let q = Aabb { min: *p, max: *p };
    let mut hits = [0usize; 16];
    let mut nh = 0;
    tree.query(&q, |i| {
        if nh < hits.len() {
            hits[nh] = i;
            nh += 1;
        }
    });
    counters.candidates += nh as u32;
    for &i in &hits[..nh] {
        if let Axial::In { seg, u } = cache.axial(t, p, i, 0) {
            let g = cache.gap(t, p, seg, u, None, refine);
            if best.is_none_or(|(sd, _, _)| g.sd < sd) {
                best = Some((g.sd, seg, u));
            }
        }
    }
    if let Some((_, seg, u)) = best {
        return Axial::In { seg, u };
    }
    let tree = bvh.ensure(t, cache);
    let Some((i, _)) = tree.nearest(*p, |i| chord_distance2(t, i, p).0) else { return Axial::Lost };
    match cache.axial(t, p, i, WINDOW) {
        Axial::Lost => {
            // Planes fold here (a kink sharper than the tube is wide): use the chord's foot.
            let (_, u) = chord_distance2(t, i, p);
            Axial::In { seg: i, u }
        }
        a => a,
    }
}

/// The most-inside reading of a sample that its first section puts outside the wall.
///
/// Where the midline bends tighter than the lumen is wide, neighbouring ring planes cross inside
/// the lumen, and the walk can stop at a segment whose planes bracket the point while another
/// segment's planes bracket it too, one whose section holds it. The lumen is the union of its
/// sections there, so every segment within [`FOLD_REACH`] whose planes bracket the point is
/// read, and the most inside wins. Readings at a segment whose planes do not bracket the point
/// are not taken: they call escaped samples inside (measured: the benchmark's pushed-through
/// samples went undetected). A sample truly through the wall is outside every bracketing section and stays a
/// contact with positive depth. Only samples found outside pay for this.
fn second_opinion(t: &TubeView, cache: &mut TubeCache, p: &V3, first: Gap, refine: u32) -> Gap {
    // A scan of the planes near the first reading, not a BVH query: the BVH would be refit for
    // the whole tube on every frame with an escaped sample.
    let mut best = first;
    cache.brackets(t, p, first.seg, FOLD_REACH, |cache, seg, u| {
        if seg != first.seg {
            let g = cache.gap(t, p, seg, u, None, refine);
            if g.sd < best.sd {
                best = g;
            }
        }
    });
    best
}

/// Tunables of the signed narrow phase.
#[derive(Debug, Clone, Copy)]
pub struct SignedParams {
    /// Axial re-projections of every section reading ([`TubeCache::gap`]).
    pub refine: u32,
    /// Whether contacts are moved to the nearest point of the continuous wall.
    pub nearest: bool,
}

/// How much nearer than the margin the section reading of a sample must put it before its
/// nearest wall point is sought, in units of the margin: the section's foot is a wall point,
/// so the true distance is never larger than its distance, but the tangent-plane distance
/// the section reports can be (where the wall curves away along the tube).
pub const NEAREST_REACH: f32 = 2.0;

/// Interior contacts of one rod inside one tube.
#[allow(clippy::too_many_arguments)]
pub fn interior(
    t: &TubeView,
    cache: &mut TubeCache,
    bvh: &mut TubeBvh,
    rod: &RodSamples,
    tracks: &mut [Track],
    params: SignedParams,
    emit: &Emit,
    out: &mut Vec<Contact>,
    counters: &mut Counters,
) {
    let mut neighbour: Option<usize> = None;
    // Segments the sample before moved along the tube since last frame: the scope slides as
    // one, so each sample's walk starts that far from where it was (with rings denser than the
    // scope moves per frame, the walk then crosses no plane instead of several).
    let mut shift: isize = 0;
    let last = t.segments() as isize - 1;
    // How far inside, beyond the rod's radius, a sample is clear: no contact, and no search
    // for the nearest wall (which starts within NEAREST_REACH margins).
    let clear = emit.margin * if params.nearest { NEAREST_REACH } else { 1.0 };
    // By index: a sample reads its position, radius and track, and writes its track.
    #[allow(clippy::needless_range_loop)]
    for s in 0..rod.len() {
        let p = rod.pos[s];
        let tr = tracks[s];
        let guess = if tr.valid { Some((tr.seg as isize + shift).clamp(0, last) as usize) } else { neighbour };
        let mut axial = match guess {
            Some(g) => cache.axial(t, &p, g, WINDOW),
            None => Axial::Lost,
        };
        let mut k_guess = tr.valid.then_some(tr.sector as usize);
        let r = rod.radius[s];
        // The rod's ends are read whatever their section says, and scanned for pockets of the
        // wall around them: the wall ahead of an end (a fold's flank within the rod's radius
        // along the tube) lies in no section a sample reads, where along the rod the next
        // sample's own section holds it.
        let end = s == 0 || s + 1 == rod.len();
        let mut reading = None;
        if let Axial::In { seg, u } = axial {
            // Most samples lie well inside: those only need their sector for next frame.
            let read = if params.refine == 0 && !(params.nearest && end) {
                cache.gap_or_clear(t, &p, seg, u, k_guess, r + clear)
            } else {
                Reading::Gap(cache.gap(t, &p, seg, u, k_guess, params.refine))
            };
            let (rho2, size) = read.spread();
            // A walk that lands far from the midline has followed folded planes: re-acquire.
            let chord2 = (t.point(seg + 1) - t.point(seg)).norm_squared();
            let reach = 8.0 * size.max(chord2.sqrt()) + 2.0 * r;
            if rho2 > reach * reach {
                axial = Axial::Lost;
            } else {
                reading = Some(read);
            }
        }
        let walked = axial != Axial::Lost;
        if walked {
            counters.walked += 1;
            if let (Axial::In { seg, .. }, Some(g)) = (axial, guess) {
                counters.planes += seg.abs_diff(g) as u32;
            }
        } else {
            axial = reacquire(t, cache, bvh, &p, params.refine, counters);
            k_guess = None;
        }
        let (seg, u) = match axial {
            Axial::In { seg, u } => (seg, u),
            Axial::BeforeStart => {
                tracks[s] = Track { seg: 0, sector: 0, valid: true };
                neighbour = Some(0);
                continue;
            }
            Axial::AfterEnd => {
                let last = t.segments() - 1;
                tracks[s] = Track { seg: last as u32, sector: 0, valid: true };
                neighbour = Some(last);
                continue;
            }
            Axial::Lost => {
                tracks[s] = Track::default();
                continue;
            }
        };
        // A clear sample keeps only its place, as a gap deeper than the margin would: no contact.
        let read = match reading.unwrap_or_else(|| Reading::Gap(cache.gap(t, &p, seg, u, k_guess, params.refine))) {
            Reading::Gap(g) if g.sd > 0.0 => Reading::Gap(second_opinion(t, cache, &p, g, params.refine)),
            read => read,
        };
        let (at, k) = read.place();
        // The track keeps the section's own place: it is where next frame's walk starts.
        // A sample that had to re-acquire (it jumped, or its loop touches another) says
        // nothing about how the next one moved.
        shift = if tr.valid && walked { at as isize - tr.seg as isize } else { 0 };
        tracks[s] = Track { seg: at as u32, sector: k as u16, valid: true };
        neighbour = Some(at);
        let Reading::Gap(mut g) = read else { continue };
        let mut others = [None; MAX_OTHERS];
        if params.nearest && (g.sd + r > -NEAREST_REACH * emit.margin || end) {
            let near = nearest(t, cache, &p, g, r, r + emit.margin, end);
            (g, others) = (near.first, near.others);
        }
        let depth = g.sd + r;
        if depth > -emit.margin {
            out.push(tube_contact(rod, s, &g, r, depth, g.normal, emit, t.spokes));
        }
        // Other walls within the margin (a corner, a pocket): a contact each, so the sample is
        // held by all of them.
        for g2 in others.iter().flatten() {
            let mut c = tube_contact(rod, s, g2, r, g2.sd + r, g2.normal, emit, t.spokes);
            c.flags |= FLAG_OTHER_WALL;
            out.push(c);
        }
    }
}

/// Builds a contact against a tube wall; `normal` points from the rod towards the wall.
#[allow(clippy::too_many_arguments)]
fn tube_contact(rod: &RodSamples, s: usize, g: &Gap, r: f32, depth: f32, normal: V3, emit: &Emit, spokes: usize) -> Contact {
    let (ja, ua) = rod.segment_of(s);
    let p = rod.pos[s];
    let mut c = emit.contact(s, ja, ua, p + normal * r, g.wall, normal, depth);
    c.index_b = g.seg as u32;
    c.spoke_b = g.k as u32;
    c.param_b = g.u;
    c.weights_b = g.weights();
    debug_assert!(g.k < spokes);
    c.flags = if g.not_star { FLAG_NOT_STAR } else { 0 } | if g.sd > 0.0 && emit.kind == 0 { FLAG_OUTSIDE } else { 0 };
    c
}

/// Contacts of a rod against the outside of a tube (the tube as a solid). Candidates come from
/// the dual traversal of both BVHs; per sample the deepest candidate wins.
#[allow(clippy::too_many_arguments)]
pub fn exterior(
    t: &TubeView,
    cache: &mut TubeCache,
    bvh: &mut TubeBvh,
    rod: &RodSamples,
    rod_bvh: &ChainBvh,
    best: &mut Vec<(f32, Gap)>,
    params: SignedParams,
    emit: &Emit,
    out: &mut Vec<Contact>,
    counters: &mut Counters,
) {
    best.clear();
    best.resize(rod.len(), (f32::NEG_INFINITY, Gap::default()));
    let tree = bvh.ensure(t, cache);
    rod_bvh.pairs(tree, |j, i| {
        counters.candidates += 1;
        for s in rod.of_segment(j) {
            let p = rod.pos[s];
            let d0 = (p - t.point(i)).dot(&cache.ring(t, i).n);
            let d1 = (p - t.point(i + 1)).dot(&cache.ring(t, i + 1).n);
            if d0 < 0.0 || d1 > 0.0 {
                continue;
            }
            let u = if d0 - d1 > 0.0 { d0 / (d0 - d1) } else { 0.0 };
            let g = cache.gap(t, &p, i, u, None, params.refine);
            let depth = rod.radius[s] - g.sd;
            if depth > best[s].0 {
                best[s] = (depth, g);
            }
        }
    });
    for (s, &(depth, g)) in best.iter().enumerate() {
        let r = rod.radius[s];
        let (depth, g) = if params.nearest && depth > -NEAREST_REACH * emit.margin {
            let g = nearest(t, cache, &rod.pos[s], g, 0.0, 0.0, false).first;
            (r - g.sd, g)
        } else {
            (depth, g)
        };
        if depth > -emit.margin {
            out.push(tube_contact(rod, s, &g, r, depth, -g.normal, emit, t.spokes));
        }
    }
}
