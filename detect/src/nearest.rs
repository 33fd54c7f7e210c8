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
//! foot's own slope does not tell which way the nearest flank lies, both ways along the tube:
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
//! no section the sample's centre lies in). So a second descent starts from the nearest of a
//! few seeds on a wall facing the point: the strips beside the foot's in the point's own
//! section, and the foot's strip and its neighbours in the sections half the rod's radius and
//! the whole radius ahead and behind along the tube ([`SEEDS`]). The nearer end wins.
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

use crate::section::{Axial, Gap, TubeCache};
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
    let b = t.spokes;
    let k1 = (at.k + 1) % b;
    let cubic = cache.cubic(t, at.seg);
    let (a0, a1) = (t.spoke(at.seg, at.k), t.spoke(at.seg + 1, at.k));
    let (b0, b1) = (t.spoke(at.seg, k1), t.spoke(at.seg + 1, k1));
    let (u, l) = (at.u, at.l);
    let (va, vb) = (a0 + (a1 - a0) * u, b0 + (b1 - b0) * u);
    let (da, db) = (a1 - a0, b1 - b0);
    let c = &cubic.c;
    Local {
        s: cubic.at(u) + va * (1.0 - l) + vb * l,
        su: cubic.tangent(u) + da * (1.0 - l) + db * l,
        sl: vb - va,
        suu: c[2] * 2.0 + c[3] * (6.0 * u),
        sul: db - da,
    }
}

impl Local {
    /// The wall's outward normal here, unnormalised (`o`: the ring's spoke orientation, see
    /// [`crate::section::Ring::o`]).
    #[inline]
    fn outward(&self, o: f32) -> V3 {
        self.sl.cross(&self.su) * o
    }
}

/// Where a descent ended: its patch coordinates, the wall there and the squared distance.
struct End {
    at: Patch,
    here: Local,
    d2: f32,
}

/// The nearest wall point to `p` from the section reading `from`: `from` with `sd`, `normal`,
/// `wall` and the patch coordinates (`seg`, `u`, `k`, `l`) of that point, `sd` signed by the
/// section's side ([`Gap::outside`]); where the descent ends on a wall facing the other way,
/// `from` with `sd` the distance to its foot on the wall.
///
/// Where the foot lies on the floor of a fold's valley or the crest of a fold (the wall runs
/// nearly at right angles to the point there, within [`FLOOR_COS`]), which way along the tube
/// the nearest flank lies is not told by the foot's own slope: both ways are tried.
///
/// `reach`: how far along the tube the seeds of the second descent go (the rod's radius, in the
/// scene's unit; 0: no seeds).
pub fn nearest(t: &TubeView, cache: &mut TubeCache, p: &V3, from: Gap, reach: f32) -> Gap {
    let start = Patch { seg: from.seg, k: from.k, u: from.u.clamp(0.0, 1.0), l: from.l.clamp(0.0, 1.0) };
    let s0 = local(t, cache, start);
    let r0 = p - s0.s;
    let tol = 1e-4 * from.size.max(1e-6);
    let floor = r0.dot(&s0.su).abs() <= FLOOR_COS * r0.norm() * s0.su.norm();
    let mut end = if floor {
        let up = descend(t, cache, p, start, s0, Some(FLOOR_STEP), tol);
        let down = descend(t, cache, p, start, s0, Some(-FLOOR_STEP), tol);
        if down.d2 < up.d2 { down } else { up }
    } else {
        // The foot on the wall's tangent plane lies, to first order, as far along the tube as
        // the nearest point: start there where that is nearer (fewer steps across rings).
        let (start, s0) = match cache.axial(t, &from.wall, from.seg, 4) {
            Axial::In { seg, u } if seg != start.seg || (u - start.u).abs() > 0.05 => {
                let alt = Patch { seg, u, ..start };
                let sa = local(t, cache, alt);
                if (p - sa.s).norm_squared() < r0.norm_squared() {
                    (alt, sa)
                } else {
                    (start, s0)
                }
            }
            _ => (start, s0),
        };
        descend(t, cache, p, start, s0, None, tol)
    };
    let side = if from.outside { 1.0 } else { -1.0 };
    // The second descent, from the nearest seed (see the module's "Seeds"), where that is
    // nearer than the first ended.
    if reach > 0.0 {
        let b = t.spokes;
        let axis = (cache.ring(t, from.seg).n * (1.0 - start.u) + cache.ring(t, from.seg + 1).n * start.u).try_normalize(0.0);
        let mut seed: Option<(Patch, Local, f32)> = None;
        let mut consider = |cache: &mut TubeCache, seg: usize, u: f32| {
            for (k, l) in [((start.k + b - 1) % b, 0.5), (start.k, start.l), ((start.k + 1) % b, 0.5)] {
                let at = Patch { seg, u, k, l };
                let here = local(t, cache, at);
                let r = p - here.s;
                let d2 = r.norm_squared();
                // Only a wall facing the point's side: the back of a fold's crest is nearer
                // than its front from some places, and a descent from it ends on the crest.
                let facing = r.dot(&here.outward(cache.ring(t, seg).o)) * side > 0.0;
                if facing && d2 < end.d2 && seed.as_ref().is_none_or(|s| d2 < s.2) {
                    seed = Some((at, here, d2));
                }
            }
        };
        consider(cache, start.seg, start.u);
        if let Some(axis) = axis {
            for f in SEEDS {
                if let Axial::In { seg, u } = cache.axial(t, &(p + axis * (reach * f)), from.seg, SEED_WINDOW) {
                    consider(cache, seg, u);
                }
            }
        }
        if let Some((at, here, _)) = seed {
            let other = descend(t, cache, p, at, here, None, tol);
            if other.d2 < end.d2 {
                end = other;
            }
        }
    }
    let End { at, here, d2 } = end;
    let dist = d2.sqrt();
    let wall_out = here.outward(cache.ring(t, at.seg).o);
    let normal = if dist > tol {
        // Outward: from the wall to an outside point, from an inside point to the wall.
        (p - here.s) * (side / dist)
    } else {
        match wall_out.try_normalize(0.0) {
            Some(n) => n,
            None => return from,
        }
    };
    // The wall there must face the way the side says (not a fold seen from behind); where it
    // does not, the section's own reading stands, at the distance of its foot on the wall.
    if normal.dot(&wall_out) <= 0.0 {
        return Gap { sd: side * (p - s0.s).norm(), ..from };
    }
    Gap { sd: side * dist, normal, wall: here.s, seg: at.seg, u: at.u, k: at.k, l: at.l, ..from }
}

/// Where the second descent of [`nearest`] may start, in units of its `reach` along the tube.
pub const SEEDS: [f32; 4] = [-1.0, -0.5, 0.5, 1.0];

/// Ring planes the walk to a seed's section may cross.
const SEED_WINDOW: usize = 16;

/// Descends from `at` (where the wall is `here`) as the module says; `first_du`, if given,
/// replaces the first step (along the tube only).
fn descend(t: &TubeView, cache: &mut TubeCache, p: &V3, mut at: Patch, mut here: Local, first_du: Option<f32>, tol: f32) -> End {
    let b = t.spokes;
    let last = t.segments() - 1;
    let mut d2 = (p - here.s).norm_squared();
    // A coordinate pinned on a crease: -1 / +1 its lower / upper edge, 0 free.
    let (mut pin_u, mut pin_l) = (0i8, 0i8);
    for it in 0..ITERATIONS {
        let r = p - here.s;
        let (gu, gl) = (r.dot(&here.su), r.dot(&here.sl));
        let (uu, ul, ll) = (here.su.norm_squared(), here.su.dot(&here.sl), here.sl.norm_squared());
        let (nuu, nul) = (uu - r.dot(&here.suu), ul - r.dot(&here.sul));
        // Newton where H is positive definite, Gauss-Newton where not.
        let (huu, hul) = if nuu > 0.0 && nuu * ll - nul * nul > 0.0 { (nuu, nul) } else { (uu, ul) };
        let (mut du, mut dl) = match (pin_u != 0, pin_l != 0) {
            (true, true) => break,
            (true, false) => (0.0, if ll > 0.0 { gl / ll } else { 0.0 }),
            (false, true) => (if huu > 0.0 { gu / huu } else { 0.0 }, 0.0),
            (false, false) => {
                let det = huu * ll - hul * hul;
                if det <= 0.0 {
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
        let (mut du, mut dl) = (du * f, dl * f);
        // Which edges the full step ends on (-1 lower, +1 upper).
        let mut eu = if fu < 1.0 && fu <= fl { du.signum() as i8 } else { 0 };
        let mut el = if fl < 1.0 && fl <= fu { dl.signum() as i8 } else { 0 };
        let mut moved = None;
        for _ in 0..3 {
            let on = |x: f32, d: f32, e: i8| match e {
                -1 => 0.0,
                1 => 1.0,
                _ => (x + d).clamp(0.0, 1.0),
            };
            let cand = Patch { u: on(at.u, du, eu), l: on(at.l, dl, el), ..at };
            let next = local(t, cache, cand);
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
        let Some((cand, next, nd2)) = moved else { break };
        let step2 = (next.s - here.s).norm_squared();
        at = cand;
        here = next;
        d2 = nd2;
        // On an edge the step wanted to cross: go on in the neighbouring patch if the descent
        // goes on into it; if it would come straight back, the edge is a crease: pin it.
        if el != 0 {
            let across = if el < 0 { Patch { k: (at.k + b - 1) % b, l: 1.0, ..at } } else { Patch { k: (at.k + 1) % b, l: 0.0, ..at } };
            match goes_on(t, cache, p, across, el, |w| w.sl) {
                Some(there) => (at, here) = (across, there),
                None => pin_l = el,
            }
        }
        if eu != 0 {
            let seg = if eu < 0 { at.seg.checked_sub(1) } else { (at.seg < last).then_some(at.seg + 1) };
            let across = seg.map(|seg| Patch { seg, u: if eu < 0 { 1.0 } else { 0.0 }, ..at });
            match across.and_then(|a| goes_on(t, cache, p, a, eu, |w| w.su).map(|there| (a, there))) {
                Some((a, there)) => (at, here) = (a, there),
                None => pin_u = eu,
            }
        }
        if step2 <= tol * tol {
            break;
        }
    }
    End { at, here, d2 }
}

/// The wall at `across`, the patch beyond an edge the descent reached on side `e` (-1 lower,
/// +1 upper), if the descent goes on into it: if `p`'s gradient along the crossed coordinate
/// (`along`: `S_u` or `S_l`) points further in.
fn goes_on(t: &TubeView, cache: &mut TubeCache, p: &V3, across: Patch, e: i8, along: fn(&Local) -> V3) -> Option<Local> {
    let there = local(t, cache, across);
    let g = (p - there.s).dot(&along(&there));
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
