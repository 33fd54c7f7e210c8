//! A rod inside a tube, by the signed method (the default): each sample located by its walk
//! ([`crate::broad::track`]), then read in its own cross-section ([`TubeCache::gap`]), or moved
//! to the nearest point of the continuous wall with the scene's `nearest` ([`crate::nearest`]).
//! A sample outside the wall is a contact with positive depth however far out it is, and its
//! normal is the wall's. Every sample's section is read first, then each sample's nearest wall
//! is sought, also from the walls its neighbours' sections read: a wall ahead of a sample along
//! the tube (a slit's ceiling running down) is often read by the next samples' sections only.
//! Last, a sample whose descents all ended in a local minimum of the distance (the wall beyond
//! a fold's flank) descends again from the nearest wall point a neighbour found, where that may
//! lie in another basin ([`mend`]).

use super::{Emit, SignedParams, NEAREST_REACH};
use crate::around::{merge, walls_around};
use crate::broad::track::{Track, Walk};
use crate::broad::{Counters, TubeFrame};
use crate::nearest::{keep_nearest, nearer_from, nearest, Search, MAX_OTHERS, OTHER_ANGLE_DEG};
use crate::samples::RodSamples;
use crate::section::{Gap, Reading, TubeCache};
use crate::view::TubeView;
use crate::V3;
use lumen_proto::contact::FLAG_OTHER_WALL;
use lumen_proto::Contact;

/// The job of one interior pair: the rod's slot, the tube's slot, and each sample's track.
#[derive(Debug, Clone, Default)]
pub struct RodInTube {
    pub rod: usize,
    pub tube: usize,
    /// One per rod sample: where its walk starts next frame.
    tracks: Vec<Track>,
    /// One per rod sample, this frame: its section's walls, where it is not clear.
    read: Vec<Option<Walls>>,
    /// One per rod sample, this frame: its nearest wall and the other walls about it.
    found: Vec<Option<Found>>,
    /// One per rod sample, this frame: what [`mend`] reads of its nearest wall.
    feet: Vec<Foot>,
}

/// A sample's nearest wall this frame and the other walls about it.
#[derive(Debug, Clone, Copy)]
struct Found {
    first: Gap,
    others: [Option<Gap>; MAX_OTHERS],
}

/// What [`mend`] reads of a sample's nearest wall, laid out for its loop over neighbours: the
/// wall point, the outward normal, the distance and side, whether it was sought on the
/// continuous wall and whether [`mend`] moved it.
#[derive(Debug, Clone, Copy, Default)]
struct Foot {
    wall: V3,
    normal: V3,
    dist: f32,
    outside: bool,
    sought: bool,
    mended: bool,
}

impl Foot {
    /// A sought sample's nearest wall `g`.
    fn of(g: &Gap) -> Self {
        Self { wall: g.wall, normal: g.normal, dist: g.sd.abs(), outside: g.outside, sought: true, mended: false }
    }
}

/// A sample's section walls: its first reading and the walls it sees across the lumen.
type Walls = (Gap, [Option<Gap>; MAX_OTHERS]);

/// A neighbour's wall point farther from a sample's own than this many times the step between
/// the two samples may lie in another basin of the distance ([`mend`]): along one smooth wall
/// the nearest point moves by less than the point where the wall is convex towards it, a
/// little more where it is concave (by `R / (R - d)` at distance `d` inside a tube of radius
/// `R`).
const MEND_RATIO: f32 = 1.0;

/// Wall points of the neighbouring samples' sections a sample descends from at most.
const NEARBY: usize = 2;

impl RodInTube {
    /// The job for rod slot `rod` inside tube slot `tube`, without history.
    pub fn new(rod: usize, tube: usize) -> Self {
        Self { rod, tube, tracks: Vec::new(), read: Vec::new(), found: Vec::new(), feet: Vec::new() }
    }

    /// Forgets every sample's track: the next frame locates each through the BVH.
    pub fn reset(&mut self) {
        self.tracks.iter_mut().for_each(|t| *t = Track::default());
    }

    /// This frame's contacts of `rod` inside `tube`, appended to `out`.
    #[inline]
    pub fn run(&mut self, tube: TubeFrame, rod: &RodSamples, params: SignedParams, emit: &Emit, out: &mut Vec<Contact>, counters: &mut Counters) {
        if self.tracks.len() != rod.len() {
            self.tracks.clear();
            self.tracks.resize(rod.len(), Track::default());
        }
        self.read.clear();
        self.read.resize(rod.len(), None);
        self.found.clear();
        self.found.resize(rod.len(), None);
        self.feet.clear();
        self.feet.resize(rod.len(), Foot::default());
        interior(tube, rod, &mut self.tracks, &mut self.read, &mut self.found, &mut self.feet, params, emit, out, counters);
    }
}

/// Interior contacts of one rod inside one tube, in three passes: every sample's section read
/// (into `read`, one slot a sample); each moved to its nearest wall (into `found` and `feet`),
/// which may start from the walls its neighbours' sections read; and each moved on where a
/// descent from a neighbour's nearest wall ends nearer ([`mend`]).
#[allow(clippy::too_many_arguments)]
fn interior(
    mut tube: TubeFrame,
    rod: &RodSamples,
    tracks: &mut [Track],
    read: &mut [Option<Walls>],
    found: &mut [Option<Found>],
    feet: &mut [Foot],
    params: SignedParams,
    emit: &Emit,
    out: &mut Vec<Contact>,
    counters: &mut Counters,
) {
    let mut walk = Walk::new(params.refine);
    // How far inside, beyond the rod's radius, a sample is clear: no contact, and no search
    // for the nearest wall (which starts within NEAREST_REACH margins).
    let clear = emit.margin * if params.nearest { NEAREST_REACH } else { 1.0 };
    // By index: a sample reads its position, radius and track, and writes its track.
    #[allow(clippy::needless_range_loop)]
    for s in 0..rod.len() {
        let p = rod.pos[s];
        let r = rod.radius[s];
        // The rod's ends are read whatever their section says, and scanned for pockets of the
        // wall around them: the wall ahead of an end (a fold's flank within the rod's radius
        // along the tube) lies in no section a sample reads, where along the rod the next
        // sample's own section holds it.
        let end = s == 0 || s + 1 == rod.len();
        // Most samples lie well inside: those only need their sector for next frame.
        // A sample clear of its own sector's wall is clear of the section's only where no wall on
        // its far side can touch it either ([`crate::around`]).
        let reading = |cache: &mut TubeCache, t: &TubeView, seg: usize, u: f32, k_guess: Option<usize>| {
            if params.refine == 0 && !(params.nearest && end) {
                // With `nearest`, a wall along the tube may be nearer than the section's by its slope.
                let reach = if params.nearest { (r + clear) * (1.0 + cache.slope_near(t, seg, r + clear).powi(2)).sqrt() } else { r + clear };
                match cache.gap_or_clear(t, &p, seg, u, k_guess, reach) {
                    Reading::Clear { k, .. } if cache.inner_bound(t, seg, u) < r => Reading::Gap(cache.gap(t, &p, seg, u, Some(k), 0)),
                    read => read,
                }
            } else {
                Reading::Gap(cache.gap(t, &p, seg, u, k_guess, params.refine))
            }
        };
        // A clear sample keeps only its place, as a gap deeper than the margin would: no contact.
        let Some(Reading::Gap(mut g)) = walk.locate(&mut tube, &p, r, &mut tracks[s], counters, reading) else { continue };
        let around = walls_around(&tube.view, tube.cache, &p, &mut g, r, r + emit.margin);
        read[s] = Some((g, around));
    }
    #[allow(clippy::needless_range_loop)]
    for s in 0..rod.len() {
        let Some((mut g, around)) = read[s] else { continue };
        let p = rod.pos[s];
        let r = rod.radius[s];
        let end = s == 0 || s + 1 == rod.len();
        let mut others = [None; MAX_OTHERS];
        // The nearest wall is sought where it may lie within reach: the section's wall itself,
        // or a wall along the tube as near as the wall's slope there allows.
        // (With `nearest`, `r + clear` is that reach; the slope is read only where the section
        // alone does not decide.)
        let seek = |cache: &mut TubeCache, g: &Gap| {
            let reach = r + clear;
            g.sd > -reach || -g.sd < reach * (1.0 + cache.slope_near(&tube.view, g.seg, reach).powi(2)).sqrt()
        };
        let sought = params.nearest && (end || seek(tube.cache, &g));
        if sought {
            let search = if end { Search::Ends } else { Search::Across { own: &around, nearby: &nearby(rod, read, s, g.normal, r + emit.margin) } };
            let near = nearest(&tube.view, tube.cache, &p, g, r, r + emit.margin, search);
            (g, others) = (near.first, near.others);
        }
        found[s] = Some(Found { first: g, others });
        feet[s] = if sought { Foot::of(&g) } else { Foot::default() };
    }
    if params.nearest {
        // Forth, then back: a neighbour's mended wall seeds the next sample's.
        for s in 0..rod.len() {
            mend(&mut tube, rod, found, feet, s, emit.margin, false);
        }
        for s in (0..rod.len()).rev() {
            mend(&mut tube, rod, found, feet, s, emit.margin, true);
        }
    }
    #[allow(clippy::needless_range_loop)]
    for s in 0..rod.len() {
        let (Some((_, around)), Some(Found { first: g, mut others })) = (read[s], found[s]) else { continue };
        let r = rod.radius[s];
        merge(g.normal, &mut others, &around);
        let depth = g.sd + r;
        if depth > -emit.margin {
            out.push(emit.on_tube(rod, s, &g, depth, g.normal, tube.view.spokes));
        }
        // Other walls within the margin (a corner, a pocket, a lumen narrower than the rod): a
        // contact each, so the sample is held by all of them.
        for g2 in others.iter().flatten().filter(|o| o.sd + r > -emit.margin) {
            let mut c = emit.on_tube(rod, s, g2, g2.sd + r, g2.normal, tube.view.spokes);
            c.flags |= FLAG_OTHER_WALL;
            out.push(c);
        }
    }
}

/// Sample `s`'s nearest wall moved to a nearer one found by a descent from a neighbouring
/// sample's nearest wall point ([`nearer_from`]): where its own descents ended in a local
/// minimum of the distance its neighbours' did not. The neighbours are the samples within the
/// rod's radius plus `margin` of it along the rod (only those mended already where
/// `only_mended`); of their wall points, the one tried is that whose tangent plane passes
/// nearest the sample, where that is nearer than the sample's own wall and than the rod's radius
/// plus `margin` (near enough for a contact) and the wall point lies farther from the sample's
/// own than [`MEND_RATIO`] times the step between the two samples. The wall it leaves stays an
/// other wall where it stands apart from the new one.
fn mend(tube: &mut TubeFrame, rod: &RodSamples, found: &mut [Option<Found>], feet: &mut [Foot], s: usize, margin: f32, only_mended: bool) {
    let mine = feet[s];
    if !mine.sought {
        return;
    }
    let p = rod.pos[s];
    let within = rod.radius[s] + margin;
    let within2 = within * within;
    let side = if mine.outside { 1.0 } else { -1.0 };
    let mut best = (mine.dist.min(within), usize::MAX);
    about(rod, s, within2, |j, step2| {
        let f = &feet[j];
        if f.sought && (f.mended || !only_mended) {
            let plane = (p - f.wall).dot(&f.normal) * side;
            if plane < best.0 && (f.wall - mine.wall).norm_squared() > MEND_RATIO * MEND_RATIO * step2 {
                best = (plane, j);
            }
        }
    });
    let (Some(Some(seed)), Some(mine)) = (found.get(best.1), found[s]) else { return };
    let Some(first) = nearer_from(&tube.view, tube.cache, &p, &mine.first, &seed.first, within) else { return };
    let left: [Option<Gap>; 1 + MAX_OTHERS] = std::array::from_fn(|i| if i == 0 { Some(mine.first) } else { mine.others[i - 1] });
    let mut others = [None; MAX_OTHERS];
    merge(first.normal, &mut others, &left);
    found[s] = Some(Found { first, others });
    feet[s] = Foot { mended: true, ..Foot::of(&first) };
}

/// The [`NEARBY`] wall points nearest sample `s` within `within` of it (scene's unit) among the
/// walls read by the sections of the samples about it along the rod (both ways, up to the
/// first sample farther than `within`), nearest first: only walls other than the one its own
/// section reads first (normals more than [`OTHER_ANGLE_DEG`] from `normal`), which its own
/// descents start from already.
fn nearby(rod: &RodSamples, read: &[Option<Walls>], s: usize, normal: V3, within: f32) -> [Option<Gap>; NEARBY] {
    let p = rod.pos[s];
    let within2 = within * within;
    let cos = OTHER_ANGLE_DEG.to_radians().cos();
    let mut best = [(f32::INFINITY, None); NEARBY];
    let mut keep = |g: &Gap| {
        let d2 = (g.wall - p).norm_squared();
        if d2 < within2 && g.normal.dot(&normal) < cos {
            keep_nearest(&mut best, (d2, Some(*g)), |c| c.0);
        }
    };
    about(rod, s, within2, |j, _| {
        if let Some((g, around)) = &read[j] {
            keep(g);
            around.iter().flatten().for_each(&mut keep);
        }
    });
    best.map(|(_, g)| g)
}

/// Calls `visit(j, step2)` for the samples about sample `s` along the rod, each way out to the
/// first farther than `sqrt(within2)` from it (`step2`: the squared distance between the two).
#[inline]
fn about(rod: &RodSamples, s: usize, within2: f32, mut visit: impl FnMut(usize, f32)) {
    let p = rod.pos[s];
    let mut near = |j: usize| {
        let step2 = (rod.pos[j] - p).norm_squared();
        (step2 < within2).then(|| visit(j, step2)).is_some()
    };
    for j in (0..s).rev() {
        if !near(j) {
            break;
        }
    }
    for j in s + 1..rod.len() {
        if !near(j) {
            break;
        }
    }
}
