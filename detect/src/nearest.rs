//! The nearest point of the continuous wall, found from a section reading.
//!
//! A section reading ([`TubeCache::gap`]) finds the wall in the point's own cross-section: the
//! foot `W0 = S(i, u, k, l)` of the point on the nearest wall strip of that section, and the
//! distance to the wall's tangent plane there. Where the wall slopes along the tube (the flank
//! of a haustral fold, the outer wall of a flexure, a ring plane tilted against the lumen), the
//! nearest wall point lies in another section, and the tangent plane at `W0` is not the wall:
//! on the real colon the two differ by millimetres and their normals by tens of degrees, and
//! the distance jumps where a point crosses from one segment to the next.
//!
//! This descends on the surface itself, from `W0` or, where that is nearer, from the same
//! strip position in the section through the tangent plane's foot (which lies, to first order,
//! as far along the tube as the nearest point); from a valley floor or a fold crest, where the
//! foot's own slope does not tell which way the nearest flank lies, both ways along the tube,
//! unless the distance is convex at the foot (the point nearer than the wall curves away: the
//! foot lies in one minimum's basin):
//!
//! ```text
//! minimise f(u, l) = |S(u, l) - P|^2 / 2,   r = P - S,
//! S_u = C'(u) + (1 - l) dV_k + l dV_{k+1},   S_l = V_{k+1}(u) - V_k(u),
//! S_uu = C''(u),   S_ul = dV_{k+1} - dV_k,   S_ll = 0   (dV_k = V_{i+1,k} - V_{i,k}),
//! grad f = -(r.S_u, r.S_l),
//! H = [[S_u.S_u - r.S_uu, S_u.S_l - r.S_ul], [S_u.S_l - r.S_ul, S_l.S_l]],
//! ```
//!
//! with Newton's step where `H` is positive definite and Gauss-Newton's (the `r` terms dropped)
//! where it is not, each step capped at half a patch and halved (twice at most) until it brings
//! `S` nearer. A step that leaves the patch stops on its edge, then goes on in the neighbouring
//! strip (`k +- 1`) or segment (`i +- 1`) in that one's own coordinates. The wall is only `C0`
//! across those edges (a spoke's tip line is a crease of the polygonal section; a ring is one
//! where the spokes change pace): a point whose nearest wall point lies on a crease is pushed
//! back across it by the next patch's step, so the coordinate that would cross is pinned there
//! and the descent goes on along the crease.
//!
//! **Seeds.** The distance to a curved wall has several local minima where the point sits in a
//! pocket (walls on several sides) or faces a fold ahead of its own section (the end of the
//! scope against a fold's flank: the flank is within the scope's radius along the tube but in
//! no section the sample's centre lies in). So a second descent starts from the nearest seed on
//! a wall facing the point that is nearer than the first descent's end. Between the rod's ends
//! the seeds are wall points on the rings within the rod's radius along the tube (the foot's
//! strip and three either side, at the middle of each, and their spokes' tips, where a fold's
//! crest running across the strips comes nearest; [`Probe::ring_descent`]): a ring's wall
//! points are its control point and spokes, a few operations each. At the rod's two ends, which
//! also seek other walls, they are the foot's strip and its neighbours in the point's own
//! section and in the sections half the rod's radius and the whole radius ahead and behind
//! along the tube ([`SEEDS`]). The nearer end wins.
//!
//! **Never a contact without a wall.** Every accepted step brings `S` nearer, so the result is
//! never farther than `W0`; and the distance returned is always that of a point on the wall
//! (`W0` at worst), never the tangent plane's: where a fold's flank is extrapolated past its
//! crest, the tangent plane passes millimetres nearer than any wall point, and a contact read
//! from it pushes the scope away from a wall that is not there (into the one that is).
//!
//! **Side.** Inside or outside is the section's sector test ([`Gap::outside`]): which side of
//! its sector's wall edge the point lies in its own section. A point's side does not depend on
//! which wall point is nearest; the tangent plane's sign does, and flips on a steep flank. The
//! normal is the direction between the point and its nearest wall point (the gradient of the
//! distance, continuous as the point moves), oriented outward. A descent that ends where the
//! wall faces the other way (a fold of the surface) is not taken: the foot `W0` stands, at its
//! own distance.

use crate::section::{next, prev, Axial, Gap, TubeCache};
use crate::view::TubeView;
use crate::V3;

/// Most descent steps per point.
pub const ITERATIONS: usize = 6;

/// A foot whose wall runs within this cosine of a right angle to the point, along the tube,
/// is on a floor or a crest: the descent is started both ways (see [`nearest`]).
pub const FLOOR_COS: f32 = 0.2;

/// The first step of a descent started both ways, in segments along the tube.
pub const FLOOR_STEP: f32 = 0.25;

/// Where on the wall: segment `seg`, strip `k` (spokes `k`, `k + 1`), and `(u, l)` in it.
#[derive(Debug, Clone, Copy)]
struct Patch {
    seg: usize,
    k: usize,
    u: f32,
    l: f32,
}

impl Patch {
    /// Where a section reading or a wall found lies, its coordinates clamped to the patch.
    fn of(g: &Gap) -> Self {
        Self { seg: g.seg, k: g.k, u: g.u.clamp(0.0, 1.0), l: g.l.clamp(0.0, 1.0) }
    }

    /// The same wall point in the segment beyond edge `e` of this one (-1: `u = 0`, +1:
    /// `u = 1`), if the tube goes on there (`last`: its last segment).
    fn across_u(self, e: i8, last: usize) -> Option<Self> {
        let seg = if e < 0 { self.seg.checked_sub(1) } else { (self.seg < last).then_some(self.seg + 1) };
        seg.map(|seg| Self { seg, u: if e < 0 { 1.0 } else { 0.0 }, ..self })
    }

    /// The same wall point in the strip beyond edge `e` of this one (-1: `l = 0`, +1: `l = 1`),
    /// of `b` spokes.
    fn across_l(self, e: i8, b: usize) -> Self {
        if e < 0 {
            Self { k: prev(self.k, b), l: 1.0, ..self }
        } else {
            Self { k: next(self.k, b), l: 0.0, ..self }
        }
    }
}

/// Rings within `dist` along the tube of segment `seg` (at most [`MAX_CROSSINGS`]): where they
/// are denser than a descent's steps cover, its budget grows by them (a step stops at each ring
/// it crosses).
fn rings_within(t: &TubeView, seg: usize, dist: f32) -> usize {
    let spacing = (t.point(seg + 1) - t.point(seg)).norm();
    if spacing > 0.0 {
        (dist / spacing).ceil().min(MAX_CROSSINGS as f32) as usize
    } else {
        MAX_CROSSINGS
    }
}

/// The wall at a patch point and its derivatives there (see the module's formulas).
#[derive(Clone, Copy)]
struct Local {
    s: V3,
    su: V3,
    sl: V3,
    suu: V3,
    sul: V3,
}

fn local(t: &TubeView, cache: &mut TubeCache, at: Patch) -> Local {
    let mid = Midline::at(t, cache, at.seg, at.u);
    mid.local(mid.spoke(t, at.k), mid.spoke(t, next(at.k, t.spokes)), at.l)
}

/// The midline of segment `seg` at `u` and its derivatives: what every strip of that section
/// shares ([`Probe::consider`] reads three strips of one section).
#[derive(Clone, Copy)]
struct Midline {
    seg: usize,
    u: f32,
    c: V3,
    cu: V3,
    cuu: V3,
}

impl Midline {
    #[inline]
    fn at(t: &TubeView, cache: &mut TubeCache, seg: usize, u: f32) -> Self {
        let cubic = cache.cubic(t, seg);
        let c = &cubic.c;
        Self { seg, u, c: cubic.at(u), cu: cubic.tangent(u), cuu: c[2] * 2.0 + c[3] * (6.0 * u) }
    }

    /// Spoke `k` across the segment at `u`, and its change along it (`V_k(u)`, `dV_k`).
    #[inline]
    fn spoke(&self, t: &TubeView, k: usize) -> (V3, V3) {
        let (a0, a1) = (t.spoke(self.seg, k), t.spoke(self.seg + 1, k));
        (a0 + (a1 - a0) * self.u, a1 - a0)
    }

    /// The wall at `l` across the strip between spokes `a` and `b` ([`Midline::spoke`]s).
    #[inline]
    fn local(&self, (va, da): (V3, V3), (vb, db): (V3, V3), l: f32) -> Local {
        Local { s: self.c + va * (1.0 - l) + vb * l, su: self.cu + da * (1.0 - l) + db * l, sl: vb - va, suu: self.cuu, sul: db - da }
    }
}

impl Local {
    /// Whether the squared distance to the wall from the point at `r` from here (`r = P - S`)
    /// is convex here: its Hessian (see the module's formulas) positive definite.
    #[inline]
    fn convex_toward(&self, r: &V3) -> bool {
        let (uu, ul, ll) = (self.su.norm_squared(), self.su.dot(&self.sl), self.sl.norm_squared());
        let (nuu, nul) = (uu - r.dot(&self.suu), ul - r.dot(&self.sul));
        nuu > 0.0 && nuu * ll - nul * nul > 0.0
    }

    /// The wall's outward normal here, unnormalised (`o`: the ring's spoke orientation, see
    /// [`crate::section::Ring::o`]).
    #[inline]
    fn outward(&self, o: f32) -> V3 {
        self.sl.cross(&self.su) * o
    }

    /// Whether the wall here faces `p` from the side `side` (-1 inside, +1 outside): not the
    /// back of a fold's crest, which is nearer than its front from some places, and from which
    /// a descent ends on the crest.
    #[inline]
    fn faces(&self, p: &V3, o: f32, side: f32) -> bool {
        (p - self.s).dot(&self.outward(o)) * side > 0.0
    }
}

/// Where a descent ended: its patch coordinates, the wall there and the squared distance.
#[derive(Clone, Copy)]
struct End {
    at: Patch,
    here: Local,
    d2: f32,
    /// Whether it stopped at a minimum (no step brings `S` nearer, or the last was below
    /// tolerance), not for want of steps.
    settled: bool,
}

/// What [`nearest`] found for one point.
#[derive(Debug, Clone, Copy)]
pub struct Near {
    /// The nearest wall point (or the section's own reading, see [`nearest`]).
    pub first: Gap,
    /// Other walls within the `within` distance [`nearest`] was given, nearest first, each
    /// facing the point from a direction more than [`OTHER_ANGLE_DEG`] from the first's and from
    /// each other's: the point wedged in a corner (the scope's end between the side wall and a
    /// fold ahead of it) or a pocket. Inside points only.
    pub others: [Option<Gap>; MAX_OTHERS],
}

/// Walls besides the nearest that [`nearest`] reports at most: a pocket of the real colon
/// holds the scope's end between three or four (the side wall, a fold's front, the valley
/// between them).
pub const MAX_OTHERS: usize = lumen_proto::limits::MAX_OTHER_WALLS;

/// Two local minima of the distance to the wall count as two walls when their normals differ
/// by more than this, degrees: the side wall and a fold's front meet at about a right angle; a
/// descent that slides back to the first wall ends within a few degrees of it.
pub const OTHER_ANGLE_DEG: f32 = 30.0;

/// The nearest wall point to `p` from the section reading `from`: `from` with `sd`, `normal`,
/// `wall` and the patch coordinates (`seg`, `u`, `k`, `l`) of that point, `sd` signed by the
/// section's side ([`Gap::outside`]); where the descent ends on a wall facing the other way,
/// `from` with `sd` the distance to its foot on the wall.
///
/// Where the foot lies on the floor of a fold's valley or the crest of a fold (the wall runs
/// nearly at right angles to the point there, within [`FLOOR_COS`]), which way along the tube
/// the nearest flank lies is not told by the foot's own slope: both ways are tried, unless the
/// squared distance is convex at the foot (one descent then reaches its minimum).
///
/// `reach`: how far along the tube the seeds of the second descent go (the rod's radius, in the
/// scene's unit; 0: no seeds). `within`: for a point inside the wall, the distance (scene's
/// unit) within which other walls are sought and reported ([`Near::others`]; 0: none): the
/// losing ends of the descents where they are other walls. [`Search::Ends`], for the rod's ends: also
/// descend from the pockets of the wall around the point ([`scan_pockets`], which says why the
/// ends), and, where no other wall is found yet, from the nearest seeds facing the point from
/// another direction. Elsewhere along the rod a wall ahead of a sample lies in the next
/// sample's section; searching there too found nothing more in the colonoscopy, at a cost
/// (docs/decisions/detect.md). Between the ends, [`Search::Across`].
pub fn nearest(t: &TubeView, cache: &mut TubeCache, p: &V3, from: Gap, reach: f32, within: f32, search: Search) -> Near {
    let scan = matches!(search, Search::Ends);
    let side = if from.outside { 1.0 } else { -1.0 };
    let rings = rings_within(t, from.seg, reach + within);
    let mut probe = Probe { t, cache, p, tol: 1e-4 * from.size.max(1e-6), side, rings };
    let start = Patch::of(&from);
    let s0 = probe.local(start);
    // The ends of descents that lost to `end`: candidates for other walls.
    let mut spare: [Option<End>; 4 + SCAN_SEEDS] = [None; 4 + SCAN_SEEDS];
    let mut end = probe.first_descent(&from, start, s0, &mut spare[0]);
    // A wall within this of the point is a contact (the rod's radius and the margin).
    let touch = within;
    let within = if from.outside { 0.0 } else { within };
    // Seeds facing the point (see the module's "Seeds"), nearer than the first descent ended
    // or, where other walls are sought, near enough to descend to one.
    let mut seeds = Seeds { at: [None; SEED_SLOTS], n: 0 };
    let mut n_own = 0;
    if reach > 0.0 && scan {
        let keep2 = if within > 0.0 { end.d2.max((within + reach) * (within + reach)) } else { end.d2 };
        n_own = probe.gather_seeds(&mut seeds, &from, start, reach, keep2);
        spare[1] = probe.second_descent(&mut seeds, &mut end);
        // The ring seeds and the patches find the nearest wall where the seeds above miss it;
        // the walls they end on otherwise are kept out of the other walls (on a polygonal
        // section every strip holds a minimum, and those would crowd out the walls the pockets
        // find), all but the wall they displace.
        let d2 = end.d2;
        spare[2] = probe.ring_descent(&from, start, reach, &mut end).filter(|_| end.d2 < d2);
        probe.pocket_descents(&from, start.k, reach + within, &mut end, &mut spare[4..]);
        spare[3] = probe.box_descents(&from, reach, touch, &mut end);
    } else if reach > 0.0 {
        spare[1] = probe.ring_descent(&from, start, reach, &mut end);
        if let Search::Across { own, nearby } = search {
            spare[3] = probe.across_descents(own, &mut end);
            spare[4] = probe.across_descents(nearby, &mut end);
        }
    }
    let Some((normal, dist)) = judge(&mut probe, &end) else {
        // Not a wall facing the way the side says (a fold seen from behind): the section's own
        // reading stands, at the distance of its foot on the wall; or, where the descent's end
        // lies within the contact margin (`within - reach`) or [`AT_WALL`] of the rod's radius,
        // at that end's distance if nearer: the point is at the wall, on a wall that passes over
        // itself (0.03 mm against the foot's 0.14 on the GCA colon inflated four times), and any
        // wall point bounds the distance to the wall. (Farther, a wall seen from behind says
        // little: taking its distance wherever nearer, walls 7 mm away in a generated colon's
        // hairpin, the colonoscopy there went 1.01 mm deep instead of 0.64.)
        let foot = (p - s0.s).norm();
        let at_wall = (within - reach).max(AT_WALL * reach);
        let dist = if end.d2 < at_wall * at_wall { foot.min(end.d2.sqrt()) } else { foot };
        return Near { first: Gap { sd: side * dist, ..from }, others: [None; MAX_OTHERS] };
    };
    let first = gap_at(&from, &end, normal, side * dist);
    if within <= 0.0 {
        return Near { first, others: [None; MAX_OTHERS] };
    }
    let cos = OTHER_ANGLE_DEG.to_radians().cos();
    let mut found = Walls { at: [None; CANDIDATES], n: 0 };
    for e in spare.into_iter().flatten() {
        if let Some(w) = probe.wall_of(e, within) {
            found.push(w);
        }
    }
    if scan {
        probe.other_way_descents(&mut seeds, n_own, start.k, normal, within, &mut found);
    }
    Near { first, others: pick_others(&from, &mut found.at[..found.n], normal, cos) }
}

/// `near` (a point's nearest wall as [`nearest`] found it) moved to where a descent from `seed`
/// ends, where that is a wall facing `p` nearer than `near`: `seed` is a wall point nearer `p`
/// than `near`, the nearest wall a neighbouring sample found. The nearest wall point moves
/// continuously with the point except across the medial axis, so where a point's own descents
/// ended in a local minimum of the distance that its neighbours' did not, a neighbour's answer
/// starts a descent in the basin of the nearer one. `reach`: the distance along the tube the
/// descent may go (scene's unit).
pub fn nearer_from(t: &TubeView, cache: &mut TubeCache, p: &V3, near: &Gap, seed: &Gap, reach: f32) -> Option<Gap> {
    let side = if near.outside { 1.0 } else { -1.0 };
    let rings = rings_within(t, seed.seg, reach);
    let mut probe = Probe { t, cache, p, tol: 1e-4 * near.size.max(1e-6), side, rings };
    let at = Patch::of(seed);
    let here = probe.local(at);
    if !here.faces(p, probe.cache.ring(t, at.seg).o, side) {
        return None;
    }
    let e = descend(&mut probe, at, here, None, ITERATIONS);
    if e.d2 >= near.sd * near.sd {
        return None;
    }
    let (normal, dist) = judge(&mut probe, &e)?;
    Some(gap_at(near, &e, normal, side * dist))
}

/// What [`nearest`] searches beyond its seeds.
#[derive(Debug, Clone, Copy)]
pub enum Search<'a> {
    /// The rod's ends: the pockets of the wall around the point, the patches nearer than the
    /// wall found, and seeds facing it from another direction.
    Ends,
    /// Between the ends: a descent from each wall the point's section sees across the lumen
    /// (`own`, from [`crate::around::walls_around`]) and from each wall the sections of the
    /// rod's samples about it read other than its own first (`nearby`), whatever their
    /// distance ([`Probe::across_descents`]).
    Across { own: &'a [Option<Gap>], nearby: &'a [Option<Gap>] },
}

/// The wall being searched and the point searched from: what every descent reads.
struct Probe<'a> {
    t: &'a TubeView<'a>,
    cache: &'a mut TubeCache,
    p: &'a V3,
    /// A step shorter than this ends a descent (scene's unit; relative to the section's size).
    tol: f32,
    /// -1: the point is inside the wall (its section says), +1: outside.
    side: f32,
    /// Rings within the search's distance along the tube (at most [`MAX_CROSSINGS`]).
    rings: usize,
}

/// Walls found at the ends of descents (end, normal, distance), the first `n` slots filled.
struct Walls {
    at: [Option<(End, V3, f32)>; CANDIDATES],
    n: usize,
}

impl Walls {
    /// Adds a wall.
    fn push(&mut self, w: (End, V3, f32)) {
        self.at[self.n] = Some(w);
        self.n += 1;
    }
}

/// Which coordinates of a descent are pinned on a crease: -1 / +1 its lower / upper edge, 0 free.
#[derive(Clone, Copy, Default)]
struct Pins {
    u: i8,
    l: i8,
}

impl Probe<'_> {
    /// The wall at patch point `at`.
    #[inline]
    fn local(&mut self, at: Patch) -> Local {
        local(self.t, self.cache, at)
    }

    /// The first descent: both ways along the tube from a floor or a crest (the foot's slope
    /// does not tell which way the nearest flank lies; the losing end goes to `lost`), else
    /// from the nearer of the foot `start` (the wall there `s0`) and the tangent plane's foot.
    fn first_descent(&mut self, from: &Gap, start: Patch, s0: Local, lost: &mut Option<End>) -> End {
        let r0 = self.p - s0.s;
        let floor = r0.dot(&s0.su).abs() <= FLOOR_COS * r0.norm() * s0.su.norm();
        if floor && s0.convex_toward(&r0) {
            // A floor or crest the point is nearer than the wall curves away: the foot lies in
            // the basin of a minimum, which one descent reaches.
            descend(self, start, s0, None, ITERATIONS)
        } else if floor {
            let up = descend(self, start, s0, Some(FLOOR_STEP), ITERATIONS);
            let down = descend(self, start, s0, Some(-FLOOR_STEP), ITERATIONS);
            let (win, lose) = if down.d2 < up.d2 { (down, up) } else { (up, down) };
            *lost = Some(lose);
            win
        } else {
            // The foot on the wall's tangent plane lies, to first order, as far along the tube as
            // the nearest point: start there where that is nearer (fewer steps across rings).
            let (start, s0) = match self.cache.axial(self.t, &from.wall, from.seg, 4) {
                Axial::In { seg, u } if seg != start.seg || (u - start.u).abs() > 0.05 => {
                    let alt = Patch { seg, u, ..start };
                    let sa = self.local(alt);
                    if (self.p - sa.s).norm_squared() < r0.norm_squared() {
                        (alt, sa)
                    } else {
                        (start, s0)
                    }
                }
                _ => (start, s0),
            };
            descend(self, start, s0, None, ITERATIONS)
        }
    }

    /// Fills `seeds` with wall points facing the point within `keep2` (squared): the strips
    /// about `start`'s in its own section, then in the sections [`SEEDS`] `reach`es along the
    /// tube; returns how many lie in its own section.
    fn gather_seeds(&mut self, seeds: &mut Seeds, from: &Gap, start: Patch, reach: f32, keep2: f32) -> usize {
        let (t, p) = (self.t, self.p);
        let axis = (self.cache.ring(t, from.seg).n * (1.0 - start.u) + self.cache.ring(t, from.seg + 1).n * start.u).try_normalize(0.0);
        self.consider(seeds, start, start.seg, start.u, keep2);
        let n_own = seeds.n;
        if let Some(axis) = axis {
            for f in SEEDS {
                if let Axial::In { seg, u } = self.cache.axial(t, &(p + axis * (reach * f)), from.seg, SEED_WINDOW.max(self.rings + 2)) {
                    self.consider(seeds, start, seg, u, keep2);
                }
            }
        }
        n_own
    }

    /// Adds to `seeds` the three strips about `start`'s at `(seg, u)` that face the point
    /// within `keep2` (squared).
    fn consider(&mut self, seeds: &mut Seeds, start: Patch, seg: usize, u: f32, keep2: f32) {
        let (t, b) = (self.t, self.t.spokes);
        // The section's midline and its four spokes, read once for the three strips.
        let mid = Midline::at(t, self.cache, seg, u);
        let o = self.cache.ring(t, seg).o;
        let (k0, k1, k2) = (prev(start.k, b), start.k, next(start.k, b));
        let v = [mid.spoke(t, k0), mid.spoke(t, k1), mid.spoke(t, k2), mid.spoke(t, next(k2, b))];
        for (j, (k, l)) in [(k0, 0.5), (k1, start.l), (k2, 0.5)].into_iter().enumerate() {
            let at = Patch { seg, u, k, l };
            let here = mid.local(v[j], v[j + 1], l);
            let d2 = (self.p - here.s).norm_squared();
            if here.faces(self.p, o, self.side) && d2 < keep2 && seeds.n < SEED_SLOTS {
                seeds.at[seeds.n] = Some((at, here, d2));
                seeds.n += 1;
            }
        }
    }

    /// Between the rod's ends, the second descent: from the nearest of the wall points on the
    /// rings within `reach` along the tube (every ring, or every so many where more than
    /// [`RING_SEED_RINGS`] lie within it either side), on the foot's strip at its `l`, the strips
    /// either side at their middles and the spokes' tips, that is nearer than `end` and faces
    /// the point. The nearer
    /// of the two ends becomes `end`; returns the other. A ring's wall points are its control
    /// point and spokes themselves, a few operations each, where a seed in a section between
    /// rings costs a walk to that section and the midline's cubic there; and a ring every
    /// ring spacing samples the wall along the tube more densely than [`SEEDS`]' four sections.
    fn ring_descent(&mut self, from: &Gap, start: Patch, reach: f32, end: &mut End) -> Option<End> {
        let (t, p) = (self.t, self.p);
        let (b, last) = (t.spokes, t.segments() - 1);
        let spacing = (t.point(from.seg + 1) - t.point(from.seg)).norm().max(1e-6);
        let full = ((reach / spacing).ceil() as usize).min(MAX_CROSSINGS);
        let stride = full.div_ceil(RING_SEED_RINGS).max(1);
        let reach_rings = full.div_ceil(stride) * stride;
        let lo = from.seg.saturating_sub(reach_rings);
        let hi = (from.seg + 1 + reach_rings).min(t.rings - 1);
        // The strips about the foot's, each the one after the one before.
        let mut ks = [(start.k + b - (RING_STRIPS / 2) % b) % b; RING_STRIPS + 1];
        for j in 1..=RING_STRIPS {
            ks[j] = next(ks[j - 1], b);
        }
        let ls: [f32; RING_STRIPS] = std::array::from_fn(|j| if ks[j] == start.k { start.l } else { 0.5 });
        // The nearest few nearer than `end`, nearest first: the nearest may face away.
        let mut best = [(end.d2, usize::MAX, 0usize, 0.0f32); RING_TRIES];
        // Each strip's weights, one per float of its spokes: the loop reads a ring's spokes as
        // one flat run of floats and weighs them float by float, then sums each point's three
        // squares in order (the same sums as a point at a time, in fewer instructions and less
        // time: docs/decisions/detect.md).
        let (ms, lf) = strip_weights(&ls);
        // And the spokes' own tips: a fold's crest running across the strips has its nearest
        // point near a tip as often as near a strip's middle.
        let (ms0, lf0) = strip_weights(&[0.0; RING_STRIPS]);
        for i in (lo..=hi).step_by(stride) {
            let q = p - t.point(i);
            // A ring whose plane, less its spokes' offset from it, lies farther than the seeds
            // kept holds no nearer one (most rings away from the point's own): the seeds are not
            // read. The offset is read only where the plane alone is that far; the slack keeps
            // rounding from dropping a tie.
            let worst = best[RING_TRIES - 1].0;
            let along = q.dot(&self.cache.ring(t, i).n).abs();
            if along * along >= worst {
                let off = self.cache.plane_offset(t, i);
                let above = along - off - PLANE_SLACK * (q.x.abs() + q.y.abs() + q.z.abs() + off);
                if above > 0.0 && above * above >= worst {
                    continue;
                }
            }
            let qs: [f32; STRIP_FLOATS] = std::array::from_fn(|f| q[f % 3]);
            let s = t.spokes_of(i);
            // The ring's spokes about the foot's, read as one block where they do not wrap.
            let w: [[f32; 3]; RING_STRIPS + 1] = match s.get(ks[0]..ks[0] + RING_STRIPS + 1).and_then(|run| run.try_into().ok()) {
                Some(run) => run,
                None => std::array::from_fn(|j| s[ks[j]]),
            };
            for (tips, d2) in [(false, ring_seed_d2(&qs, &w, &ms, &lf)), (true, ring_seed_d2(&qs, &w, &ms0, &lf0))] {
                // Most rings hold no seed nearer than those kept: one test of all seven first.
                if d2.iter().any(|&d| d < best[RING_TRIES - 1].0) {
                    for (j, &d2) in d2.iter().enumerate() {
                        keep_nearest(&mut best, (d2, i, j, if tips { 0.0 } else { ls[j] }), |c| c.0);
                    }
                }
            }
        }
        for &(_, i, j, l) in best.iter().take_while(|c| c.1 != usize::MAX) {
            // A tip is the corner of two strips: the seed is on whichever of them faces the point
            // (where a fold's crest runs across the strips, one side of the tip is the crest's
            // back, the other its front).
            let (seg, u) = if i > last { (last, 1.0) } else { (i, 0.0) };
            let (at, here) = if l == 0.0 {
                facing_corner(t, self.cache, p, self.side, seg, u, ks[j])
            } else {
                let at = Patch { seg, u, k: ks[j], l };
                (at, self.local(at))
            };
            if here.faces(p, self.cache.ring(t, at.seg).o, self.side) && (p - here.s).norm_squared() < end.d2 {
                let other = descend(self, at, here, None, OTHER_ITERATIONS);
                return Some(if other.d2 < end.d2 { std::mem::replace(end, other) } else { other });
            }
        }
        None
    }

    /// The second descent, from the nearest seed, where that is nearer than `end`: the nearer
    /// of the two ends becomes `end`; returns the other.
    fn second_descent(&mut self, seeds: &mut Seeds, end: &mut End) -> Option<End> {
        let nearest_seed = (0..seeds.n).filter_map(|i| seeds.at[i].map(|s| (i, s))).filter(|(_, s)| s.2 < end.d2).min_by(|a, b| a.1 .2.total_cmp(&b.1 .2));
        let (i, (at, here, _)) = nearest_seed?;
        seeds.at[i] = None;
        let other = descend(self, at, here, None, ITERATIONS);
        Some(if other.d2 < end.d2 { std::mem::replace(end, other) } else { other })
    }

    /// For the rod's ends: a descent from the middle of each wall patch (ring segment by strip,
    /// every strip, the segments within `reach` along the tube and beyond while ring planes
    /// pass within `touch` of the point, up to [`BOX_FAN_RINGS`]) whose box, grown for the
    /// spline's swing past its rings, lies nearer the point than `end`, nearest box first, at
    /// most [`BOX_TRIES`]. Where the lumen is wide its patches are too (12 mm strips on a
    /// lumen of 60 mm radius at 32 spokes): the nearest wall point can lie in a patch's middle,
    /// millimetres nearer than any of its corners and farther from any seed than the first
    /// descent's end, in a basin of its own. The nearer end becomes `end`; returns the end it
    /// displaced last, if any.
    fn box_descents(&mut self, from: &Gap, reach: f32, touch: f32, end: &mut End) -> Option<End> {
        let (t, p) = (self.t, self.p);
        let (b, last) = (t.spokes, t.segments() - 1);
        let spacing = (t.point(from.seg + 1) - t.point(from.seg)).norm().max(1e-6);
        let full = ((reach / spacing).ceil() as usize).min(BOX_RINGS);
        let (mut lo, mut hi) = (from.seg.saturating_sub(full), (from.seg + full).min(last));
        // Where ring planes fan about a bend's inner side, rings far along the tube hold wall
        // within reach: the window goes on while the next ring's plane (less its spokes'
        // offset from it and a segment's swing) passes nearer the point than `end` and than
        // `touch` (a wall any farther is no contact).
        let limit = end.d2.sqrt().min(touch) + spacing;
        while hi < last && hi - from.seg < BOX_FAN_RINGS {
            let j = hi + 1;
            if -self.cache.plane(t, j, p) > limit + self.cache.plane_offset(t, j) {
                break;
            }
            hi = j;
        }
        while lo > 0 && from.seg - lo < BOX_FAN_RINGS {
            if self.cache.plane(t, lo, p) > limit + self.cache.plane_offset(t, lo) {
                break;
            }
            lo -= 1;
        }
        // Ring `j` clamped to the tube: the spline's end segments repeat their end rings.
        let tip = |j: isize, k: usize| {
            let j = j.clamp(0, last as isize + 1) as usize;
            t.point(j) + t.spoke(j, k)
        };
        let mut best = [(f32::INFINITY, 0usize, 0usize, f32::INFINITY); BOX_TRIES];
        for k in 0..b {
            let k1 = next(k, b);
            // The two spokes' tips on rings i - 1 to i + 2, rolled along the window.
            let i0 = lo as isize;
            let mut a: [V3; 4] = std::array::from_fn(|j| tip(i0 - 1 + j as isize, k));
            let mut e: [V3; 4] = std::array::from_fn(|j| tip(i0 - 1 + j as isize, k1));
            for i in lo..=hi {
                if i > lo {
                    a = [a[1], a[2], a[3], tip(i as isize + 2, k)];
                    e = [e[1], e[2], e[3], tip(i as isize + 2, k1)];
                }
                // How far the spline may swing past the chord between the rings: a quarter of
                // the largest step of the two spokes over this and the neighbouring segments.
                let step = (0..3).map(|j| (a[j + 1] - a[j]).norm_squared().max((e[j + 1] - e[j]).norm_squared())).fold(0.0f32, f32::max);
                let grow = 0.25 * step.sqrt();
                let mut d2 = 0.0;
                for d in 0..3 {
                    let mn = a[1][d].min(a[2][d]).min(e[1][d]).min(e[2][d]) - grow;
                    let mx = a[1][d].max(a[2][d]).max(e[1][d]).max(e[2][d]) + grow;
                    let out = (mn - p[d]).max(p[d] - mx).max(0.0);
                    d2 += out * out;
                }
                if d2 >= end.d2 {
                    continue;
                }
                // The ball about the corners' mean that holds them (grown the same): a second
                // bound, and the order among patches whose boxes hold the point.
                let c = (a[1] + a[2] + e[1] + e[2]) * 0.25;
                let rad = [a[1], a[2], e[1], e[2]].iter().map(|q| (q - c).norm_squared()).fold(0.0f32, f32::max).sqrt() + grow;
                let to_c = (p - c).norm();
                let lb = (to_c - rad).max(0.0);
                let bound = d2.max(lb * lb);
                if bound < end.d2 {
                    keep_nearest(&mut best, (bound, i, k, to_c), |c| (c.0, c.3));
                }
            }
        }
        let mut displaced = None;
        for &(d2, i, k, _) in best.iter().take_while(|c| c.0.is_finite()) {
            if d2 >= end.d2 {
                break;
            }
            displaced = self.descent_from(Patch { seg: i, u: 0.5, k, l: 0.5 }, end).or(displaced);
        }
        displaced
    }

    /// A descent from each wall in `across` that faces the point, however far its reading:
    /// the walls the point's section sees across the lumen ([`crate::around::walls_around`]),
    /// or those the sections of the rod's samples about it read. Where the lumen is pressed
    /// into a slit narrower than the scope, the nearest point of the far wall can lie in a
    /// patch's middle, nearer than the wall found first while every ring seed there is farther
    /// (on the GCA colon inflated four times, 5.35 mm against 6.52, no seed within 6.52); where
    /// the slit's ceiling runs down along the tube just ahead of a sample, its own section reads
    /// the ceiling's flat part (a minimum of its own) or nothing, and the ramp's nearest point
    /// lies between the points its neighbours' sections read on it
    /// (`hard_slits_with_a_ramp_at_any_angle_ahead_of_or_behind_the_samples`: 0.84 mm nearer
    /// than the floor). The nearer end becomes `end`; returns the end it displaced last, if any.
    fn across_descents(&mut self, across: &[Option<Gap>], end: &mut End) -> Option<End> {
        let mut displaced = None;
        for g in across.iter().flatten() {
            let at = Patch::of(g);
            displaced = self.descent_from(at, end).or(displaced);
        }
        displaced
    }

    /// A descent from `at` where the wall there faces the point; where it ends nearer than
    /// `end`, it becomes `end` and the end it displaced is returned.
    fn descent_from(&mut self, at: Patch, end: &mut End) -> Option<End> {
        let here = self.local(at);
        if !here.faces(self.p, self.cache.ring(self.t, at.seg).o, self.side) {
            return None;
        }
        let e = descend(self, at, here, None, OTHER_ITERATIONS);
        (e.d2 < end.d2).then(|| std::mem::replace(end, e))
    }

    /// For the rod's ends: a descent from each pocket of the wall within `dist` around the point
    /// (see [`scan_pockets`]); the nearest end becomes `end`, the others fill `spare`.
    fn pocket_descents(&mut self, from: &Gap, k0: usize, dist: f32, end: &mut End, spare: &mut [Option<End>]) {
        let found = scan_pockets(self, from, k0, dist);
        for (slot, (at, here)) in spare.iter_mut().zip(found.into_iter().flatten()) {
            let other = descend(self, at, here, None, OTHER_ITERATIONS);
            *slot = Some(if other.d2 < end.d2 { std::mem::replace(end, other) } else { other });
        }
    }

    /// A wall within `within` at the end of a descent: only a minimum (a descent cut short ends
    /// on a slope, at no wall the point faces), facing the point; with its normal and distance.
    fn wall_of(&mut self, e: End, within: f32) -> Option<(End, V3, f32)> {
        if !e.settled {
            return None;
        }
        let (n, d) = judge(self, &e)?;
        (d < within).then_some((e, n, d))
    }

    /// At the rod's ends, where the descents so far found no other wall: descents from the seeds
    /// along the tube, on the foot's own strip (`k0`), on a wall turned from the first (`normal`)
    /// and facing the point from another direction, nearest first, one per section (the
    /// neighbouring strips' seeds lie on the first wall's sides, and a seed on a wall running on
    /// as the first's does, a smooth tube's, is the first wall: descents from them slide back
    /// to it). The walls they end on within `within` are added to `found`.
    fn other_way_descents(&mut self, seeds: &mut Seeds, n_own: usize, k0: usize, normal: V3, within: f32, found: &mut Walls) {
        let cos = OTHER_ANGLE_DEG.to_radians().cos();
        let (t, p, side) = (self.t, self.p, self.side);
        for _ in 0..OTHER_TRIES {
            if found.at[..found.n].iter().flatten().any(|w| w.1.dot(&normal) < cos) {
                break;
            }
            let cache = &mut *self.cache;
            let other_way = seeds.at[n_own..seeds.n]
                .iter()
                .flatten()
                .filter(|s| s.0.k == k0 && (p - s.1.s).dot(&normal) * side < cos * s.2.sqrt() && turned(&s.1.outward(cache.ring(t, s.0.seg).o), &normal, cos))
                .min_by(|a, b| a.2.total_cmp(&b.2));
            let Some(&(at, here, _)) = other_way else { break };
            for s in seeds.at[n_own..seeds.n].iter_mut() {
                if s.is_some_and(|s| s.0.seg == at.seg && s.0.u == at.u) {
                    *s = None;
                }
            }
            let e = descend(self, at, here, None, OTHER_ITERATIONS);
            if let Some(w) = self.wall_of(e, within) {
                found.push(w);
            }
        }
    }
}

/// The other walls of [`Near::others`] from the walls `found`: nearest first, each facing the
/// point from a direction more than the angle whose cosine is `cos` from the first's (`normal`)
/// and every other's taken (two descents that end on one wall end within degrees).
fn pick_others(from: &Gap, found: &mut [Option<(End, V3, f32)>], normal: V3, cos: f32) -> [Option<Gap>; MAX_OTHERS] {
    found.sort_unstable_by(|a, b| a.map_or(f32::INFINITY, |w| w.2).total_cmp(&b.map_or(f32::INFINITY, |w| w.2)));
    let side = if from.outside { 1.0 } else { -1.0 };
    let mut taken = [normal; 1 + MAX_OTHERS];
    let mut others = [None; MAX_OTHERS];
    let mut n_taken = 1;
    for (e, n, d) in found.iter().flatten() {
        if n_taken <= MAX_OTHERS && taken[..n_taken].iter().all(|m| n.dot(m) < cos) {
            others[n_taken - 1] = Some(gap_at(from, e, *n, side * d));
            taken[n_taken] = *n;
            n_taken += 1;
        }
    }
    others
}

/// Whether the wall's outward normal `out` (unnormalised) is turned from the unit `normal` by
/// more than the angle whose cosine is `cos`.
#[inline]
fn turned(out: &V3, normal: &V3, cos: f32) -> bool {
    out.dot(normal) < cos * out.norm()
}

/// The contact normal at the end of a descent and the distance to it: the direction between
/// the point and the wall point, outward (from the wall to an outside point, from an inside
/// point to the wall), or the wall's own normal where the point is on it; `None` where the wall
/// there faces the other way (a fold of the surface seen from behind), and on a crease (a
/// ring's section, a spoke's line) where no patch that meets there faces the point.
fn judge(pr: &mut Probe, e: &End) -> Option<(V3, f32)> {
    let (t, p, side, tol) = (pr.t, pr.p, pr.side, pr.tol);
    let dist = e.d2.sqrt();
    let wall_out = e.here.outward(pr.cache.ring(t, e.at.seg).o);
    let normal = if dist > tol { (p - e.here.s) * (side / dist) } else { wall_out.try_normalize(0.0)? };
    if normal.dot(&wall_out) > 0.0 {
        return Some((normal, dist));
    }
    // On a crease, the patches that meet there: on a fold thinner than the ring spacing the
    // nearest point is the crest on a ring's section, and the patch beyond the ring faces away
    // from a point in front of the fold while the patch before it faces the point.
    let edge = |x: f32| {
        if x <= EDGE {
            -1
        } else if x >= 1.0 - EDGE {
            1
        } else {
            0
        }
    };
    let (at, eu, el) = (e.at, edge(e.at.u), edge(e.at.l));
    let across = [(eu != 0).then(|| at.across_u(eu, t.segments() - 1)).flatten(), (el != 0).then(|| at.across_l(el, t.spokes))];
    across.into_iter().flatten().any(|q| normal.dot(&pr.local(q).outward(pr.cache.ring(t, q.seg).o)) > 0.0).then_some((normal, dist))
}

/// `from` moved to the end of a descent.
fn gap_at(from: &Gap, e: &End, normal: V3, sd: f32) -> Gap {
    Gap { sd, normal, wall: e.here.s, seg: e.at.seg, u: e.at.u, k: e.at.k, l: e.at.l, ..*from }
}

/// Within this fraction of the rod's radius of a wall seen from behind, a point counts as at
/// the wall (its side cannot change its depth by more than twice that), and [`nearest`] takes
/// that wall's distance where it is nearer than the section's foot.
const AT_WALL: f32 = 0.1;

/// Rings either side of the point's own that [`scan_pockets`] reads at most (every so many
/// where more lie within its distance).
pub const SCAN_RINGS: usize = 24;

/// Rings within a search's reach that its descents cross without more steps.
pub const FREE_CROSSINGS: usize = 16;

/// Most rings within a search's reach that count (for the steps of a descent and the walk to
/// a seed's section).
pub const MAX_CROSSINGS: usize = 512;

/// Patches [`Probe::box_descents`] descends from at most.
const BOX_TRIES: usize = 6;

/// Rings either side of the point's own whose patches [`Probe::box_descents`] reads at most.
const BOX_RINGS: usize = 16;

/// Rings either side of the point's own whose patches [`Probe::box_descents`] reads at most
/// where ring planes fan about a bend (the import's fold check looks as far).
const BOX_FAN_RINGS: usize = 64;

/// Pockets [`scan_pockets`] returns at most.
pub const SCAN_SEEDS: usize = 4;

/// The wall's pockets around `p`, for the rod's ends: the nearest wall corner (ring `i`, spoke
/// `k`: `C_i + V_ik`) on each ring within `dist` of `p`'s own along the tube (and within a
/// quarter turn of its strip `k0`), and of those, the rings nearer than both neighbours: up to
/// [`SCAN_SEEDS`], nearest first, each on a wall facing the probe's point from its side.
///
/// Why the ends: the wall ahead of the scope's end (a fold's front within its radius along the
/// tube) lies in no section a sample reads, and the distance to it has several local minima
/// there (the side wall, a fold's valley, the fold's front a few rings further), more than the
/// seeds of [`nearest`] tell apart: their descents can end on the side wall and in the valley
/// while the end stands in the fold's front (docs/decisions/detect.md). Two samples per rod, a
/// few hundred corners each: cheap.
fn scan_pockets(pr: &mut Probe, from: &Gap, k0: usize, dist: f32) -> [Option<(Patch, Local)>; SCAN_SEEDS] {
    let (t, cache, p, side) = (pr.t, &mut *pr.cache, pr.p, pr.side);
    let (b, last) = (t.spokes, t.segments() - 1);
    let spacing = (t.point(from.seg + 1) - t.point(from.seg)).norm().max(1e-6);
    let full = ((dist / spacing).ceil() as usize).min(MAX_CROSSINGS);
    // Every `stride`-th ring where more than SCAN_RINGS lie within the distance either side.
    let stride = full.div_ceil(SCAN_RINGS).max(1);
    let reach = (full / stride).min(SCAN_RINGS) * stride;
    let lo = from.seg.saturating_sub(reach);
    let hi = (from.seg + 1 + reach).min(t.rings - 1);
    let w = (b / 4).max(1);
    // Per ring read: the squared distance to its nearest corner in the window, and that corner.
    let mut ring = [(f32::INFINITY, 0usize); 2 * SCAN_RINGS + 2];
    let n = (hi - lo) / stride + 1;
    for (j, slot) in ring.iter_mut().enumerate().take(n) {
        let i = lo + j * stride;
        let c = t.point(i);
        for jj in 0..=2 * w {
            let k = (k0 + b + jj - w) % b;
            let d2 = (p - (c + t.spoke(i, k))).norm_squared();
            if d2 < slot.0 {
                *slot = (d2, k);
            }
        }
    }
    let mut out: [Option<(Patch, Local)>; SCAN_SEEDS] = [None; SCAN_SEEDS];
    let mut kept = [f32::INFINITY; SCAN_SEEDS];
    for j in 0..n {
        let d2 = ring[j].0;
        let pocket = (j == 0 || d2 <= ring[j - 1].0) && (j + 1 == n || d2 <= ring[j + 1].0);
        if !pocket || d2 > dist * dist {
            continue;
        }
        let Some(slot) = (0..SCAN_SEEDS).max_by(|&x, &y| kept[x].total_cmp(&kept[y])).filter(|&x| d2 < kept[x]) else { continue };
        let i = lo + j * stride;
        let (seg, u) = if i > last { (last, 1.0) } else { (i, 0.0) };
        let (at, here) = facing_corner(t, cache, p, side, seg, u, ring[j].1);
        if here.faces(p, cache.ring(t, at.seg).o, side) {
            out[slot] = Some((at, here));
            kept[slot] = d2;
        }
    }
    out
}

/// Spoke `k`'s tip at `u` of segment `seg` (a ring), as a point of whichever of the two strips
/// it bounds faces `p` from `side`: strip `k` at `l = 0`, or else strip `k - 1` at `l = 1`.
/// Where a fold's crest runs across the strips one of them is the crest's back, and a descent
/// from there ends on the crest, not on the front the point faces.
fn facing_corner(t: &TubeView, cache: &mut TubeCache, p: &V3, side: f32, seg: usize, u: f32, k: usize) -> (Patch, Local) {
    let at = Patch { seg, u, k, l: 0.0 };
    let here = local(t, cache, at);
    if here.faces(p, cache.ring(t, seg).o, side) {
        return (at, here);
    }
    let at = Patch { seg, u, k: prev(k, t.spokes), l: 1.0 };
    (at, local(t, cache, at))
}

/// Inserts `item` into `best`, kept in ascending `key` order, where it is below the last: the
/// last falls out, and an equal key goes after those already kept.
#[inline]
pub(crate) fn keep_nearest<T: Copy, K: PartialOrd>(best: &mut [T], item: T, key: impl Fn(&T) -> K) {
    let Some(last) = best.len().checked_sub(1) else { return };
    let k = key(&item);
    if k.partial_cmp(&key(&best[last])) != Some(std::cmp::Ordering::Less) {
        return;
    }
    let mut at = last;
    while at > 0 && k < key(&best[at - 1]) {
        best[at] = best[at - 1];
        at -= 1;
    }
    best[at] = item;
}

/// Where the second descent of [`nearest`] may start, in units of its `reach` along the tube.
pub const SEEDS: [f32; 4] = [-1.0, -0.5, 0.5, 1.0];

/// Ring planes the walk to a seed's section may cross.
const SEED_WINDOW: usize = 16;

/// Where the second and later descents may start: wall points facing the point (patch, wall, squared
/// distance), the first `n` slots filled in order, a slot emptied once descended from.
struct Seeds {
    at: [Option<(Patch, Local, f32)>; SEED_SLOTS],
    n: usize,
}

/// A step that leaves its patch within this fraction of its length starts on the edge (to
/// rounding): it crosses over first.
const EDGE: f32 = 1e-4;

/// The descents' ends [`nearest`] may judge as other walls: two spares, the pockets, the tries.
const CANDIDATES: usize = 2 + SCAN_SEEDS + OTHER_TRIES;

/// Most steps of a descent from a seed in search of another wall: it starts up to the rod's
/// radius along the tube from the wall it ends on, several half-patch steps with rings 1 mm
/// apart.
pub const OTHER_ITERATIONS: usize = 16;

/// Descents at most from seeds along the tube in search of another wall.
const OTHER_TRIES: usize = 2;

/// Ring seeds [`Probe::ring_descent`] checks at most for one facing the point, nearest first.
const RING_TRIES: usize = 3;

/// Rings either side of the point's own that [`Probe::ring_descent`] reads at most (every so
/// many where more lie within its reach).
const RING_SEED_RINGS: usize = 8;

/// Relative slack of [`Probe::ring_descent`]'s plane bound, well above `f32` rounding of the
/// distances it is compared with.
const PLANE_SLACK: f32 = 1e-5;

/// Strips of each ring [`Probe::ring_descent`] seeds on: the foot's and three either side.
const RING_STRIPS: usize = 7;

/// The floats of [`RING_STRIPS`] wall points.
const STRIP_FLOATS: usize = 3 * RING_STRIPS;

/// The weights `1 - l` and `l` of each strip's two spokes, repeated for each of its floats.
#[inline]
fn strip_weights(ls: &[f32; RING_STRIPS]) -> ([f32; STRIP_FLOATS], [f32; STRIP_FLOATS]) {
    (std::array::from_fn(|f| 1.0 - ls[f / 3]), std::array::from_fn(|f| ls[f / 3]))
}

/// The squared distances from `q` (repeated per point: `qs`) to the ring's seed points: point
/// `j` lies at `m_j w_j + l_j w_{j+1}` of the spokes `w` (`ms`, `ls`: the weights, repeated per
/// float).
#[inline]
fn ring_seed_d2(qs: &[f32; STRIP_FLOATS], w: &[[f32; 3]; RING_STRIPS + 1], ms: &[f32; STRIP_FLOATS], ls: &[f32; STRIP_FLOATS]) -> [f32; RING_STRIPS] {
    let w = w.as_flattened();
    let (a, e) = (&w[..STRIP_FLOATS], &w[3..3 + STRIP_FLOATS]);
    let sq: [f32; STRIP_FLOATS] = std::array::from_fn(|f| {
        let d = qs[f] - (a[f] * ms[f] + e[f] * ls[f]);
        d * d
    });
    std::array::from_fn(|j| sq[3 * j] + sq[3 * j + 1] + sq[3 * j + 2])
}

/// Seeds at most: three strips in the point's own section and in each of [`SEEDS`]'.
const SEED_SLOTS: usize = 3 * (1 + SEEDS.len());

/// Descends from `at` (where the wall is `here`) as the module says; `first_du`, if given,
/// replaces the first step (along the tube only). `iterations` steps, and as many more as the
/// rings within the search's reach exceed [`FREE_CROSSINGS`]: a step ends at each ring it
/// crosses, so rings far denser than the search's distance would otherwise hold the descent
/// short of the wall.
fn descend(pr: &mut Probe, mut at: Patch, mut here: Local, first_du: Option<f32>, iterations: usize) -> End {
    let (p, tol) = (pr.p, pr.tol);
    let iterations = iterations + pr.rings.saturating_sub(FREE_CROSSINGS);
    let mut d2 = (p - here.s).norm_squared();
    let mut pin = Pins::default();
    let mut settled = false;
    // The edges the last step crossed without moving (-1 lower, +1 upper, 0 none), u and l.
    let mut crossed = (0i8, 0i8);
    for it in 0..iterations {
        let r = p - here.s;
        let (gu, gl) = (r.dot(&here.su), r.dot(&here.sl));
        let (uu, ul, ll) = (here.su.norm_squared(), here.su.dot(&here.sl), here.sl.norm_squared());
        let (nuu, nul) = (uu - r.dot(&here.suu), ul - r.dot(&here.sul));
        // Newton where H is positive definite, Gauss-Newton where not.
        let (huu, hul) = if nuu > 0.0 && nuu * ll - nul * nul > 0.0 { (nuu, nul) } else { (uu, ul) };
        let (mut du, mut dl) = match (pin.u != 0, pin.l != 0) {
            (true, true) => {
                settled = true;
                break;
            }
            (true, false) => (0.0, if ll > 0.0 { gl / ll } else { 0.0 }),
            (false, true) => (if huu > 0.0 { gu / huu } else { 0.0 }, 0.0),
            (false, false) => {
                let det = huu * ll - hul * hul;
                if det <= 0.0 {
                    settled = true;
                    break;
                }
                ((gu * ll - gl * hul) / det, (gl * huu - gu * hul) / det)
            }
        };
        if let (0, Some(f)) = (it, first_du) {
            (du, dl) = (f, 0.0);
        }
        // Half a patch at most per step.
        let m = du.abs().max(dl.abs());
        if m > 0.5 {
            du *= 0.5 / m;
            dl *= 0.5 / m;
        }
        // Stop on the patch's edge where the step leaves it.
        let (fu, fl) = (edge_fraction(at.u, du), edge_fraction(at.l, dl));
        let f = fu.min(fl);
        // Which edges the full step ends on (-1 lower, +1 upper).
        let edge = |d: f32| if d > 0.0 { 1 } else { -1 };
        let mut eu = if fu < 1.0 && fu <= fl { edge(du) } else { 0 };
        let mut el = if fl < 1.0 && fl <= fu { edge(dl) } else { 0 };
        if f <= EDGE {
            // Already on the edge the step leaves by (a descent started on a ring or a spoke's
            // tip line): over it without moving, or pin it. Straight back over the edge just
            // crossed in place is a crease too: each patch's Newton step, turned by the other
            // coordinate, leaves it for the other (on a fold thinner than the ring spacing),
            // and crossing again would spend the descent's steps without moving.
            let (bu, bl) = (eu != 0 && eu == -crossed.0, el != 0 && el == -crossed.1);
            if bu {
                (pin.u, eu) = (eu, 0);
            }
            if bl {
                (pin.l, el) = (el, 0);
            }
            let before = (at.seg, at.k);
            (at, here) = across_edges(pr, at, here, eu, el, &mut pin);
            crossed = (if at.seg != before.0 { eu } else { 0 }, if at.k != before.1 { el } else { 0 });
            continue;
        }
        crossed = (0, 0);
        let (mut du, mut dl) = (du * f, dl * f);
        let mut moved = None;
        for _ in 0..3 {
            let on = |x: f32, d: f32, e: i8| match e {
                -1 => 0.0,
                1 => 1.0,
                _ => (x + d).clamp(0.0, 1.0),
            };
            let cand = Patch { u: on(at.u, du, eu), l: on(at.l, dl, el), ..at };
            let next = pr.local(cand);
            let nd2 = (p - next.s).norm_squared();
            if nd2 < d2 {
                moved = Some((cand, next, nd2));
                break;
            }
            // A shorter step ends inside the patch.
            du *= 0.5;
            dl *= 0.5;
            eu = 0;
            el = 0;
        }
        let Some((cand, next, nd2)) = moved else {
            settled = true;
            break;
        };
        let step2 = (next.s - here.s).norm_squared();
        at = cand;
        here = next;
        d2 = nd2;
        (at, here) = across_edges(pr, at, here, eu, el, &mut pin);
        if step2 <= tol * tol {
            settled = true;
            break;
        }
    }
    End { at, here, d2, settled }
}

/// On the edges a step wanted to cross (`eu`, `el`: -1 lower, +1 upper, 0 none): goes on in the
/// neighbouring patch if the descent goes on into it; if it would come straight back, the edge
/// is a crease: pins it.
fn across_edges(pr: &mut Probe, mut at: Patch, mut here: Local, eu: i8, el: i8, pin: &mut Pins) -> (Patch, Local) {
    if el != 0 {
        let across = at.across_l(el, pr.t.spokes);
        match goes_on(pr, across, el, |w| w.sl) {
            Some(there) => (at, here) = (across, there),
            None => pin.l = el,
        }
    }
    if eu != 0 {
        let across = at.across_u(eu, pr.t.segments() - 1);
        match across.and_then(|a| goes_on(pr, a, eu, |w| w.su).map(|there| (a, there))) {
            Some((a, there)) => (at, here) = (a, there),
            None => pin.u = eu,
        }
    }
    (at, here)
}

/// The wall at `across`, the patch beyond an edge the descent reached on side `e` (-1 lower,
/// +1 upper), if the descent goes on into it: if `p`'s gradient along the crossed coordinate
/// (`along`: `S_u` or `S_l`) points further in.
fn goes_on(pr: &mut Probe, across: Patch, e: i8, along: fn(&Local) -> V3) -> Option<Local> {
    let there = pr.local(across);
    let g = (pr.p - there.s).dot(&along(&there));
    ((e < 0 && g < 0.0) || (e > 0 && g > 0.0)).then_some(there)
}

/// The largest fraction of step `d` that keeps `x + d` in [0, 1].
#[inline]
fn edge_fraction(x: f32, d: f32) -> f32 {
    if x + d > 1.0 && d > 0.0 {
        ((1.0 - x) / d).max(0.0)
    } else if x + d < 0.0 && d < 0.0 {
        (x / -d).max(0.0)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane-wise distances are each point's own `|q - (m a + l e)|^2`, bit for bit, summed
    /// `(x^2 + y^2) + z^2` as a point at a time would: the scan picks the same seeds either way.
    #[test]
    fn ring_seed_distances_equal_a_point_at_a_time() {
        let w: [[f32; 3]; RING_STRIPS + 1] = std::array::from_fn(|j| {
            let a = j as f32 * 0.7;
            [10.0 * a.cos() + 0.013 * j as f32, 9.0 * a.sin(), 0.37 * (j as f32 - 4.0)]
        });
        let ls: [f32; RING_STRIPS] = std::array::from_fn(|j| if j == 3 { 0.8125 } else { 0.5 });
        let q = V3::new(1.25, -3.5, 0.3);
        let qs: [f32; STRIP_FLOATS] = std::array::from_fn(|f| q[f % 3]);
        let (ms, lf) = strip_weights(&ls);
        let d2 = ring_seed_d2(&qs, &w, &ms, &lf);
        for j in 0..RING_STRIPS {
            let (a, e, l) = (w[j], w[j + 1], ls[j]);
            let m = 1.0 - l;
            let (dx, dy, dz) = (q.x - (a[0] * m + e[0] * l), q.y - (a[1] * m + e[1] * l), q.z - (a[2] * m + e[2] * l));
            assert_eq!(d2[j].to_bits(), (dx * dx + dy * dy + dz * dz).to_bits(), "strip {j}");
        }
    }
}
