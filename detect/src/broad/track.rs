//! Where each rod sample is along a tube, with temporal coherence.
//!
//! A rod's first sample remembers the tube segment it was in last frame and walks the ring
//! planes from there; every other sample walks from the sample before it (a plane or two, with
//! rings about as dense as the samples), so the rod is walked along the tube once a frame, and
//! the answer is the one a session without history gives ([`Walk::locate`]). Each sample also
//! remembers its sector, where its sector walk starts. Only when a walk fails, the first
//! sample's walk reads it outside the wall, or a walk reads it farther outside than its section
//! is wide (walked onto another loop), does a sample re-acquire through the tube's BVH. A
//! sample outside the wall otherwise keeps its segment: it is a contact with positive depth
//! however far out it is, and its normal is the wall's.

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
/// ended.
#[derive(Debug, Clone, Copy)]
pub struct Walk {
    /// Segment of the sample before (this frame), where the next sample's walk starts.
    neighbour: Option<usize>,
    /// Axial re-projections of a section reading ([`TubeCache::gap`]).
    refine: u32,
}

impl Walk {
    /// A walk along a tube, before the rod's first sample.
    #[inline]
    pub fn new(refine: u32) -> Self {
        Self { neighbour: None, refine }
    }

    /// Locates sample `p` (radius `r`) and reads it there: walks the ring planes from the
    /// sample before's segment (the first sample: from its own `track`, last frame's), reads
    /// it with `read` (segment, `u`, sector guess), re-acquires through the BVH where the walk
    /// fails or lands far from the midline, and takes a second look across folded planes where
    /// the reading puts it outside. Updates `track`. `None`: beyond the tube's ends, or lost.
    ///
    /// **History never changes the answer.** Only the first sample walks from last frame: every
    /// other starts from the sample before it, as in a session without history. And the first
    /// sample's walk is trusted only where its section holds it: a reading outside the wall, or
    /// past an end of the tube, may come from planes that bracket it far from where it is (the
    /// scope moved anywhere, or a frame of nonsense came before), so such a sample is located
    /// afresh through the BVH, as a session without history locates it. The
    /// track's sector only starts the sector walk, which ends in the same sector from any start
    /// where the section is star-shaped.
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
        let from_history = self.neighbour.is_none();
        let guess = self.neighbour.or(tr.valid.then_some(tr.seg as usize));
        let mut axial = match guess {
            Some(g) => tube.cache.axial(&t, p, g.min(t.segments() - 1), WINDOW),
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
            let outside = matches!(read, Reading::Gap(g) if g.sd > 0.0);
            // Farther outside than its section is wide: walked onto another loop (from the
            // scope's samples outside the body, beside which a loop of the colon passes, into
            // an anal canal narrower than the scope: read 64 to 90 mm outside that loop instead
            // of 2 outside the canal), more likely than that far through the wall: re-acquire.
            let far_outside = matches!(read, Reading::Gap(g) if g.sd > g.size);
            if rho2 > reach * reach || (from_history && outside) || far_outside {
                axial = Axial::Lost;
            } else {
                reading = Some(read);
            }
        }
        // Past an end, read by a walk from last frame's place: not trusted (see above).
        if from_history && matches!(axial, Axial::BeforeStart | Axial::AfterEnd) {
            axial = Axial::Lost;
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
        // The track keeps the section's own place: where the first sample's walk starts next
        // frame, and every sample's sector walk.
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
