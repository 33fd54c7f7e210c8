//! The faces beside a contact of the scope's ends at a concave crease of the wall, as contacts
//! of their own.
//!
//! **Units**: millimetres.
//!
//! The detector reports, for each sample, its nearest wall point and the other walls that are
//! nearest points of their own (local minima of the distance). Where the scope's end lies on one
//! face `A` of the wall just before a crease where another face `B` rises towards the lumen (the
//! front of a fold, the floor of a valley), `B`'s nearest point to the sample is the crease
//! itself, which lies on `A` too and is farther than `A`'s own: `B` is no minimum, so no
//! contact holds the sample off it, and a frame that slides the end along `A` carries it into
//! `B` before the next detection sees `B` (measured: `docs/decisions/sim.md`).
//!
//! So each contact of a sample of the rod's end segments with the wall (patch of rings `i`, `i + 1` and spokes
//! `k`, `k + 1`, wall point `W`, unit normal `n` from the sample towards the wall, sample centre
//! `P = W - (r - depth) n`) is joined by a contact with each of the eight patches around it that
//! - lies on the lumen side of the contact's tangent plane: `n . (C - W) < 0`, with `C` the
//!   mean of the patch's four tips (a concave crease: beyond the crease `B`'s plane runs behind
//!   `A`, outside the lumen, so its constraint holds nothing off a wall that is not there);
//! - faces the sample and its plane is within the rod's radius and the margin:
//!   `0 <= d = m . (C - P) <= r + margin`, with `m` the patch's unit normal
//!   `(T11 - T00) x (T10 - T01)`, turned outward (along its spokes);
//! - is itself within reach: `|C - P| <= r + margin + max_j |T_j - C|`;
//! - and is not already one of the sample's contacts.
//!
//! The added contact is the patch's plane: normal `m`, depth `r - d`, wall point `P + d m`, the
//! four tips weighted `1/4` each, flagged [`FLAG_OTHER_WALL`]; it is rebuilt every frame from
//! the wall as it is.
//!
//! **Only the end segments.** Between its ends the scope lies along the wall, and a sample's
//! neighbours along the rod hold it where a face rises; the ends meet folds head on (the
//! detector seeks other walls only at the end samples for the same reason). The whole end
//! segment, not its end sample alone: on an imported colon the sample half a segment behind the
//! tip met a fold the same way. Applied to every sample, the GCA run's scope left the colon
//! (`docs/decisions/sim.md`).

use crate::v3;
use crate::wall::Wall;
use lumen_detect::V3d;
use lumen_proto::contact::FLAG_OTHER_WALL;
use lumen_proto::{Contact, ContactKind};
use std::ops::RangeInclusive;

fn f3(v: V3d) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The rod whose ends get crease faces.
#[derive(Debug, Clone, PartialEq)]
pub struct Ends {
    /// The rod's body index in the scene.
    pub body: u16,
    /// The samples of its end segments (both ends).
    pub samples: [RangeInclusive<u32>; 2],
    /// Its radius, mm.
    pub radius_mm: f64,
}

/// Appends to `out` the crease faces (see the module's rules) of every interior contact in
/// `contacts` between the samples of `ends` and tube `tube_body`, whose wall is `wall`, within
/// the detection margin `margin_mm`. Returns how many it appended.
pub fn add_faces(contacts: &[Contact], ends: &Ends, tube_body: u16, wall: &Wall, margin_mm: f64, out: &mut Vec<Contact>) -> usize {
    let (rings, spokes) = (wall.rings(), wall.spokes());
    let radius_mm = ends.radius_mm;
    let reach = radius_mm + margin_mm;
    let start = out.len();
    for c in contacts {
        if c.kind != ContactKind::Interior as u8 || c.body_a != ends.body || c.body_b != tube_body || !ends.samples.iter().any(|e| e.contains(&c.sample)) {
            continue;
        }
        if c.index_b as usize + 1 >= rings || c.spoke_b as usize >= spokes {
            continue;
        }
        let n = v3(c.normal);
        let nn = n.norm();
        if nn.is_nan() || nn <= 0.5 {
            continue;
        }
        let w = v3(c.point_b);
        let p = w - n * (radius_mm - c.depth as f64);
        for di in -1i64..=1 {
            for dk in -1i64..=1 {
                if di == 0 && dk == 0 {
                    continue;
                }
                let i = c.index_b as i64 + di;
                if i < 0 || i as usize + 1 >= rings {
                    continue;
                }
                let (i, k) = (i as usize, (c.spoke_b as i64 + dk).rem_euclid(spokes as i64) as usize);
                let held = |e: &Contact| e.sample == c.sample && e.body_b == tube_body && e.kind == c.kind && e.index_b as usize == i && e.spoke_b as usize == k;
                if contacts.iter().any(held) || out[start..].iter().any(held) {
                    continue;
                }
                if let Some(face) = face(wall, i, k, p, w, n, reach) {
                    let mut e = *c;
                    e.index_b = i as u32;
                    e.spoke_b = k as u32;
                    e.weights_b = [0.25; 4];
                    e.normal = f3(face.normal);
                    e.depth = (radius_mm - face.distance) as f32;
                    e.point_b = f3(p + face.normal * face.distance);
                    e.flags |= FLAG_OTHER_WALL;
                    out.push(e);
                }
            }
        }
    }
    out.len() - start
}

/// A crease face: its outward unit normal and the distance of its plane from the sample, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Face {
    pub normal: V3d,
    pub distance: f64,
}

/// Patch (rings `i`, `i + 1`, spokes `k`, `k + 1`) as a crease face for the sample at `p`
/// whose contact has wall point `w` and normal `n`, if it passes the module's rules within
/// `reach` (the rod's radius and the margin, mm).
pub fn face(wall: &Wall, i: usize, k: usize, p: V3d, w: V3d, n: V3d, reach: f64) -> Option<Face> {
    let spokes = wall.spokes();
    let k1 = (k + 1) % spokes;
    let ids = [i * spokes + k, i * spokes + k1, (i + 1) * spokes + k, (i + 1) * spokes + k1].map(|t| t as u32);
    let t = ids.map(|id| wall.tip(id));
    let centre = (t[0] + t[1] + t[2] + t[3]) * 0.25;
    if n.dot(&(centre - w)) >= 0.0 {
        return None;
    }
    let mut m = (t[3] - t[0]).cross(&(t[2] - t[1]));
    let len = m.norm();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    m /= len;
    let outward: V3d = ids.iter().map(|&id| wall.tip_dir(id)).sum();
    if m.dot(&outward) < 0.0 {
        m = -m;
    }
    let d = m.dot(&(centre - p));
    if !(0.0..=reach).contains(&d) {
        return None;
    }
    let half = t.iter().map(|x| (x - centre).norm()).fold(0.0, f64::max);
    if (centre - p).norm() > reach + half {
        return None;
    }
    Some(Face { normal: m, distance: d })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wall::WallParams;
    use lumen_detect::Tube;

    const B: usize = 16;

    /// A straight tube along +z, a ring every millimetre (ring `i` at `z = i`), 16 spokes of
    /// radius `before` up to ring 5 and `after` from ring 6: a face across the tube between
    /// rings 5 and 6.
    fn stepped(before: f32, after: f32) -> Wall {
        let rings = 12;
        let radial = (0..rings)
            .flat_map(|i| {
                let r = if i <= 5 { before } else { after };
                (0..B).map(move |k| {
                    let a = k as f32 * std::f32::consts::TAU / B as f32;
                    [r * a.cos(), r * a.sin(), 0.0]
                })
            })
            .collect();
        let tube = Tube::new((0..rings).map(|i| [0.0, 0.0, i as f32]).collect(), radial, B).unwrap();
        Wall::new(&tube, WallParams::default())
    }

    /// The middle direction of strip 0 (between spokes 0 and 1), and the cosine of half a strip.
    fn mid() -> (V3d, f64) {
        let h = std::f64::consts::PI / B as f64;
        (V3d::new(h.cos(), h.sin(), 0.0), h.cos())
    }

    /// A contact of the sample `gap` mm inside strip 0 of the wall of radius `radius` at
    /// `z = 4.5` (between rings 4 and 5): its wall point, normal and the sample's centre.
    fn on_strip0(radius: f64, gap: f64) -> (V3d, V3d, V3d) {
        let (n, c) = mid();
        let w = n * (radius * c) + V3d::z() * 4.5;
        (w, n, w - n * gap)
    }

    fn contact(sample: u32, w: V3d, n: V3d, depth: f64) -> Contact {
        Contact {
            kind: ContactKind::Interior as u8,
            body_a: 1,
            body_b: 0,
            sample,
            index_b: 4,
            spoke_b: 0,
            weights_b: [0.25; 4],
            point_b: f3(w),
            normal: f3(n),
            depth: depth as f32,
            ..Contact::default()
        }
    }

    #[test]
    fn a_fold_rising_ahead_of_the_end_is_a_face_with_its_own_plane() {
        // Radius 10 narrowing to 7: the face from ring 5 to ring 6 rises towards the lumen.
        let wall = stepped(10.0, 7.0);
        let (r, gap) = (1.5, 1.6);
        let (w, n, p) = on_strip0(10.0, gap);
        let f = face(&wall, 5, 0, p, w, n, r + 2.0).expect("the fold's face");
        // In the plane of the tube's axis and strip 0's middle, the face runs from (10 c, 5) to
        // (7 c, 6) (distance from the axis along the middle, z): normal (1, 3 c) / |.|.
        let (m, c) = mid();
        let len = (1.0 + 9.0 * c * c).sqrt();
        let normal = (m + V3d::z() * (3.0 * c)) / len;
        let distance = ((10.0 * c - (10.0 * c - gap)) + 0.5 * 3.0 * c) / len;
        assert!((f.normal - normal).norm() < 1e-5, "{:?} against {normal:?}", f.normal);
        assert!((f.distance - distance).abs() < 1e-5, "{} against {distance}", f.distance);
    }

    #[test]
    fn a_wall_turning_away_or_out_of_reach_is_no_face() {
        // Radius 7 widening to 10: the face from ring 5 to ring 6 turns away from the lumen.
        let wall = stepped(7.0, 10.0);
        let (w, n, p) = on_strip0(7.0, 1.6);
        assert_eq!(face(&wall, 5, 0, p, w, n, 3.5), None);
        // The fold of the narrowing tube, from a sample too far behind it for the reach.
        let wall = stepped(10.0, 7.0);
        let (w, n, p) = on_strip0(10.0, 1.6);
        let d = face(&wall, 5, 0, p, w, n, 3.5).unwrap().distance;
        assert_eq!(face(&wall, 5, 0, p, w, n, d - 1e-3), None);
        // The same cylinder behind the contact is no crease at all.
        let behind = face(&wall, 3, 0, p, w, n, 3.5);
        assert!(behind.is_none_or(|f| (f.distance - 1.6).abs() < 1e-4), "{behind:?}");
    }

    #[test]
    fn only_the_ends_get_faces_and_none_twice() {
        let wall = stepped(10.0, 7.0);
        let (r, gap) = (1.5, 1.6);
        let (w, n, _) = on_strip0(10.0, gap);
        let end = contact(636, w, n, r - gap);
        let middle = contact(300, w, n, r - gap);
        let mut out = vec![end, middle];
        let ends = Ends { body: 1, samples: [0..=4, 632..=636], radius_mm: r };
        let added = add_faces(&[end, middle], &ends, 0, &wall, 2.0, &mut out);
        assert!(added >= 3, "the fold's three strips at least: {added}");
        let faces = &out[2..];
        assert!(faces.iter().all(|f| f.sample == 636 && f.flags & FLAG_OTHER_WALL != 0 && f.weights_b == [0.25; 4]));
        let fold = faces.iter().find(|f| (f.index_b, f.spoke_b) == (5, 0)).expect("the fold ahead");
        let want = face(&wall, 5, 0, w - n * gap, w, n, r + 2.0).unwrap();
        assert!(((r - fold.depth as f64) - want.distance).abs() < 1e-5, "{fold:?} against {want:?}");
        assert!((v3(fold.normal) - want.normal).norm() < 1e-6);
        let mut keys: Vec<(u32, u32)> = faces.iter().map(|f| (f.index_b, f.spoke_b)).collect();
        keys.sort();
        keys.dedup();
        assert_eq!(keys.len(), faces.len(), "a patch added twice: {keys:?}");
        // A patch the detector already reported for the sample is not added again.
        let mut reported = contact(636, w, n, r - gap);
        reported.index_b = 5;
        let mut again = vec![end, reported];
        add_faces(&[end, reported], &ends, 0, &wall, 2.0, &mut again);
        assert!(again[2..].iter().all(|f| (f.index_b, f.spoke_b) != (5, 0)));
        // A contact with another body, or a self contact, gets none.
        let mut other = end;
        other.body_b = 2;
        let mut none = Vec::new();
        assert_eq!(add_faces(&[other], &ends, 0, &wall, 2.0, &mut none), 0);
    }
}
