//! Every wall of a sample's own section within reach, all around it.
//!
//! A section reading ([`TubeCache::gap`]) reads the wall in the sector the sample's offset from
//! the midline points to. Where the lumen is narrower than the scope (a collapsed or spastic
//! segment, the rectum's start), the wall presses on the sample from every side, and a reading
//! of one sector holds it against one wall only: it is pushed through the opposite one, and the
//! sector it reads flips from frame to frame.
//!
//! So the whole section is scanned, strip by strip, for the point of each wall edge nearest the
//! sample, and those within reach are sorted into three quadrants about the first wall's
//! direction `m` (in the section's plane, `m2 = n x m`):
//!
//! ```text
//! e = F - d   (F: a strip's nearest point, d: the sample's offset from the midline point)
//!   e . m  >=  |e| cos 45   the first wall's own quadrant (its reading stands)
//!   e . (-m), e . m2, e . (-m2)  >  |e| cos 45   opposite, left, right
//! ```
//!
//! The first wall is the section's nearest (the least distance over every strip) where that
//! is nearer than the sector's reading. Only strips that face the sample count as other walls:
//! their nearest point to it lies inside the strip, so the wall's normal there points at the
//! sample (the end of a strip that turns away is nearest without being a wall of its own).
//! Each quadrant gives one: the deepest strip nearer than both its neighbours (a wall of its
//! own, such as a fold pressing in), else the strip nearest the quadrant's centre direction (on
//! a wall that curves evenly round the sample, as a collapsed lumen's does, the four walls then
//! sit a quarter turn apart and hold it from every side, not all from the side it leans to).
//! Each is its wall point itself, at its distance, with the direction to it as its normal (a
//! tangent plane there would pass nearer than the wall where it slopes along the tube, and
//! push on a wall that is not there), kept if it lies more than [`OTHER_ANGLE_DEG`] from the
//! first and from each other: up to three other walls.
//!
//! **When.** Only where some wall of the section may touch the sample on its far side: a wall
//! point `E` with `E . d <= 0` lies at least `|E|` from the sample (as
//! `|E - d|^2 = |E|^2 + |d|^2 - 2 E . d`), and `|E|` is bounded below per segment
//! ([`TubeCache::inner_bound`]). Where that
//! bound is not below the rod's radius, the lumen is nowhere narrower than the rod there, and
//! the sample's own side is the first reading's (and, with the scene's `nearest`, the
//! descents' [`crate::nearest::Near::others`]). On a colon wider than the scope this is a
//! comparison per sample; the scan costs `O(B)` where the lumen is narrow. (Scanning wherever a
//! wall may come within the contact margin instead, 2 mm in the colonoscopy, adds side contacts
//! along every fold of the real colon that touch nothing, and its scope's tip then went 0.17 mm
//! deeper: docs/measurements.md.)

use crate::nearest::{MAX_OTHERS, OTHER_ANGLE_DEG};
use crate::section::{any_perpendicular, next, prev, Gap, TubeCache};
use crate::view::TubeView;
use crate::V3;
use lumen_proto::limits::MAX_SPOKES;

/// The walls of `p`'s own section within `within` of it (scene's unit) besides its first
/// reading, where a wall of the section may lie within `touch` (the rod's radius) on its far
/// side: `first` becomes the section's nearest wall where a strip outside its sector is nearer
/// (a continuous choice: the least distance over every strip), and the others are returned, at
/// most one a quadrant about it, each more than [`OTHER_ANGLE_DEG`] from the first's normal and
/// from each other's, nearest first. Nothing for a point outside the wall.
pub fn walls_around(t: &TubeView, cache: &mut TubeCache, p: &V3, first: &mut Gap, touch: f32, within: f32) -> [Option<Gap>; MAX_OTHERS] {
    let mut out = [None; MAX_OTHERS];
    if first.outside || first.sd > 0.0 || cache.inner_bound(t, first.seg, first.u) >= touch {
        return out;
    }
    let (seg, u) = (first.seg, first.u);
    let c = cache.cubic(t, seg).at(u);
    let n = (cache.ring(t, seg).n * (1.0 - u) + cache.ring(t, seg + 1).n * u).try_normalize(0.0).unwrap_or(cache.ring(t, seg).n);
    let d = p - c;
    let b = t.spokes;
    let spoke = |k: usize| t.spoke(seg, k) * (1.0 - u) + t.spoke(seg + 1, k) * u;
    // Each strip's nearest point to the sample, as the direction to it, its squared distance,
    // and whether it lies inside the strip (a foot facing the sample, not one of its ends).
    let mut near = [(V3::zeros(), f32::INFINITY, false, 0.0f32); MAX_SPOKES];
    let mut nearest = (f32::INFINITY, usize::MAX);
    let mut va = spoke(0);
    for (k, slot) in near.iter_mut().enumerate().take(b) {
        let vb = spoke(next(k, b));
        let w = vb - va;
        let ww = w.norm_squared();
        let l = if ww > 0.0 { (d - va).dot(&w) / ww } else { 0.0 };
        let e = va + w * l.clamp(0.0, 1.0) - d;
        *slot = (e, e.norm_squared(), l > 0.0 && l < 1.0, l.clamp(0.0, 1.0));
        if slot.1 < nearest.0 {
            nearest = (slot.1, k);
        }
        va = vb;
    }
    if nearest.1 != usize::MAX && nearest.1 != first.k {
        let g = cache.gap_in_strip(t, p, seg, u, nearest.1);
        if g.sd > first.sd && g.sd < 0.0 {
            *first = Gap { not_star: first.not_star | g.not_star, ..g };
        }
    }
    // The first wall's direction in the section: its normal, else the sample's offset.
    let in_plane = |v: V3| (v - n * v.dot(&n)).try_normalize(1e-12);
    let Some(m) = in_plane(first.normal).or_else(|| in_plane(d)).or_else(|| Some(any_perpendicular(n))) else { return out };
    let m2 = n.cross(&m);
    // Each quadrant's centre direction, and the bound of its cone (cos 45 degrees).
    let centres = [-m, m2, -m2];
    let cone = std::f32::consts::FRAC_1_SQRT_2;
    // Per quadrant, among the strips within reach that face the sample (the foot inside the
    // strip: the wall's normal there points at it, where an end's direction would not) and
    // whose direction lies in its cone: a wall nearer than both neighbours (a wall of its own:
    // the deepest), else the one nearest the cone's centre (on a wall curving evenly round the
    // sample, a quarter turn from the first).
    let within2 = within * within;
    let mut pick = [(2u8, f32::INFINITY, usize::MAX); 3];
    for k in 0..b {
        let (e, e2, facing, _) = near[k];
        if !facing || e2 >= within2 || e2 <= 0.0 {
            continue;
        }
        let len = e2.sqrt();
        let Some(q) = (0..3).find(|&q| e.dot(&centres[q]) > cone * len) else { continue };
        // Nearer than both neighbours by more than rounding (a regular polygon about its centre
        // has no wall of its own, only ties).
        let (e_prev, e_next) = (near[prev(k, b)].1, near[next(k, b)].1);
        let lonely = e2 <= e_prev && e2 <= e_next && e2 < (1.0 - 1e-4) * e_prev.min(e_next);
        let key = if lonely { (0u8, e2) } else { (1u8, -e.dot(&centres[q]) / len) };
        if (key.0, key.1) < (pick[q].0, pick[q].1) {
            pick[q] = (key.0, key.1, k);
        }
    }
    let mut found = [None; MAX_OTHERS];
    for (slot, &(_, _, k)) in found.iter_mut().zip(&pick) {
        if k != usize::MAX {
            // The wall point itself: a tangent plane there would pass nearer than the wall
            // where it slopes along the tube, and push on a wall that is not there.
            let (e, e2, _, l) = near[k];
            let len = e2.sqrt();
            *slot = Some(Gap { sd: -len, normal: e / len, wall: p + e, seg, u, k, l, not_star: first.not_star, rho2: d.norm_squared(), size: first.size, outside: false });
        }
    }
    // Nearest first, each kept where it stands apart from the first and those kept before it.
    found.sort_unstable_by(|a, b| a.map_or(f32::INFINITY, |g| -g.sd).total_cmp(&b.map_or(f32::INFINITY, |g| -g.sd)));
    merge(first.normal, &mut out, &found);
    out
}

/// `others` with the walls of `more` added where a slot is free and each is more than
/// [`OTHER_ANGLE_DEG`] from the first's `normal` and from every wall already there.
pub fn merge(normal: V3, others: &mut [Option<Gap>; MAX_OTHERS], more: &[Option<Gap>]) {
    let cos = OTHER_ANGLE_DEG.to_radians().cos();
    for g in more.iter().flatten() {
        let apart = g.normal.dot(&normal) < cos && others.iter().flatten().all(|o| g.normal.dot(&o.normal) < cos);
        if let (true, Some(slot)) = (apart, others.iter_mut().find(|o| o.is_none())) {
            *slot = Some(*g);
        }
    }
}
