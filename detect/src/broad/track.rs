//! Where each rod sample is along a tube, with temporal coherence.
//!
//! Each rod sample remembers the tube segment and sector it was in last frame and walks from
//! there (a few ring planes at most per frame); the first sample of a rod seeds the next, so even
//! a fresh frame walks the tube once along the rod. Only when a walk fails does the sample
//! re-acquire through the tube's BVH. A sample outside the wall keeps its segment: it is a
//! contact with positive depth however far out it is, and its normal is the wall's.

use super::aabb::Aabb;
use super::{Counters, TubeFrame};
use crate::section::{Axial, Gap, Reading, TubeCache};
use crate::view::TubeView;
use crate::V3;

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

/// One rod's walk along a tube in one frame, sample after sample: where the sample before
/// ended and how far it moved along the tube since last frame.
#[derive(Debug, Clone, Copy)]
pub struct Walk {
    /// Segment of the sample before, the start of a sample without history.
    neighbour: Option<usize>,
    /// Segments the sample before moved along the tube since last frame: the scope slides as
    /// one, so each sample's walk starts that far from where it was (with rings denser than the
    /// scope moves per frame, the walk then crosses no plane instead of several).
    shift: isize,
    /// The tube's last segment.
    last: isize,
    /// Axial re-projections of a section reading ([`TubeCache::gap`]).
    refine: u32,
}

impl Walk {
    /// A walk along `t`, before the rod's first sample.
    #[inline]
    pub fn new(t: &TubeView, refine: u32) -> Self {
        Self { neighbour: None, shift: 0, last: t.segments() as isize - 1, refine }
    }

    /// Locates sample `p` (radius `r`) from its `track` and reads it there: walks the ring
    /// planes from last frame's segment (or the sample before's), reads it with `read`
    /// (segment, `u`, sector guess), re-acquires through the BVH where the walk fails or lands
    /// far from the midline, and takes a second look across folded planes where the reading
    /// puts it outside. Updates `track`. `None`: beyond the tube's ends, or lost.
    #[inline]
    pub fn locate(
        &mut self,
        tube: &mut TubeFrame,
        p: &V3,
        r: f32,
        track: &mut Track,
        counters: &mut Counters,
        read: impl FnOnce(&mut TubeCache, &TubeView, usize, f32, Option<usize>) -> Reading,
    ) -> Option<Reading> {
        let t = tube.view;
        let tr = *track;
        let guess = if tr.valid { Some((tr.seg as isize + self.shift).clamp(0, self.last) as usize) } else { self.neighbour };
        let mut axial = match guess {
            Some(g) => tube.cache.axial(&t, p, g, WINDOW),
            None => Axial::Lost,
        };
        let mut reading = None;
        if let Axial::In { seg, u } = axial {
            let k_guess = tr.valid.then_some(tr.sector as usize);
            let read = read(tube.cache, &t, seg, u, k_guess);
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
            axial = reacquire(tube, p, self.refine, counters);
        }
        let (seg, u) = match axial {
            Axial::In { seg, u } => (seg, u),
            Axial::BeforeStart => {
                *track = Track { seg: 0, sector: 0, valid: true };
                self.neighbour = Some(0);
                return None;
            }
            Axial::AfterEnd => {
                let last = t.segments() - 1;
                *track = Track { seg: last as u32, sector: 0, valid: true };
                self.neighbour = Some(last);
                return None;
            }
            Axial::Lost => {
                *track = Track::default();
                return None;
            }
        };
        // A sample that re-acquired has no sector to start from.
        let read = match reading.unwrap_or_else(|| Reading::Gap(tube.cache.gap(&t, p, seg, u, None, self.refine))) {
            Reading::Gap(g) if g.sd > 0.0 => Reading::Gap(second_opinion(&t, tube.cache, p, g, self.refine)),
            read => read,
        };
        let (at, k) = read.place();
        // The track keeps the section's own place: it is where next frame's walk starts.
        // A sample that had to re-acquire (it jumped, or its loop touches another) says
        // nothing about how the next one moved.
        self.shift = if tr.valid && walked { at as isize - tr.seg as isize } else { 0 };
        *track = Track { seg: at as u32, sector: k as u16, valid: true };
        self.neighbour = Some(at);
        Some(read)
    }
}

/// Squared distance from `p` to the chord of segment `i`, and the chord's parameter there.
fn chord_distance2(t: &TubeView, i: usize, p: &V3) -> (f32, f32) {
    let (a, b) = (t.point(i), t.point(i + 1));
    let ab = b - a;
    let len2 = ab.norm_squared();
    let u = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    ((a + ab * u - p).norm_squared(), u)
}

/// Locates `p` without history: the most-inside segment whose box holds it, else the nearest
/// midline chord. Returns the axial position (`BeforeStart` / `AfterEnd` beyond the ends).
pub fn reacquire(tube: &mut TubeFrame, p: &V3, refine: u32, counters: &mut Counters) -> Axial {
    let TubeFrame { view: t, cache, bvh } = tube;
    let (t, cache): (&TubeView, &mut TubeCache) = (t, cache);
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
/// are not taken: they call escaped samples inside (the benchmark's pushed-through samples
/// went undetected). A sample truly through the wall is outside every bracketing section and
/// stays a contact with positive depth. Only samples found outside pay for this.
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
