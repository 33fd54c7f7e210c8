//! A kinematic endoscope inserted into a colon, frame by frame, in the colon's unit
//! (millimetres for the scenes of this crate).
//!
//! **The scope** is a rod of [`Insertion::length_mm`] (1.6 m) with [`Insertion::points`] (160)
//! equally spaced control points and radius [`Insertion::radius_mm`] (6.5 mm: a 13 mm adult
//! colonoscope). Control point 0 is the distal tip; the last one is at the handle.
//!
//! **Pose at a depth** (`depth` = arc length of the colon's midline at the tip). The inserted
//! part follows a path through the lumen: the midline pushed towards the *outer* wall of bends,
//! as a scope under push rests on the outer curve. The offset at ring `i` is
//! `beta * (R_out - r + press)` along the outward bend direction (opposite the midline's
//! curvature vector, Gaussian-smoothed with sigma 15 mm), where `R_out` is the wall's distance that way
//! (averaged over 8 mm, so the stiff scope presses into haustral folds rather than following
//! them), `r` the scope radius, and `beta` in [0, 1] grows with the bend (0 below a curvature of
//! 1/300 mm, 1 above 1/120 mm), fading out over the last 60 mm before the tip (the tip is
//! steered along the lumen) and the first 40 mm after the anus. The scope is stiffer than a
//! tortuous lumen is wiggly, so that path is then smoothed (Gaussian, sigma 10 mm) and pulled
//! back, ring by ring, to where the scope's surface is at most `press` past the rest wall.
//! Control points sit at equal arc length along the path from the tip; those that do not reach the anus continue straight
//! out of the first ring, backwards along its normal.
//!
//! **Wall deformation.** Where the scope reaches past the wall (bends push it `press` beyond
//! the rest wall), the wall gives: every spoke tip that lies within `r - residual` of the
//! scope's axis moves outward along its spoke until it is `r - residual` away, and the moves are
//! spread smoothly (raised-cosine falloff over 8 mm along the arc and two spokes around) so the
//! wall forms a smooth bulge. Each frame starts again from the rest wall, so the wall springs
//! back everywhere the scope has left: only tips near the scope differ from the rest colon, and
//! the scope stays pressed `residual` into the deformed wall (contacts to detect).
//!
//! **Escapes** (the published method's failure case). In [`Insertion::frames`], seeded events
//! (every 40-120 frames, 12-24 frames long) push the scope *through* the wall where it presses
//! hardest (chosen when the event starts, away from the tip and the anus, and fixed in the colon
//! while the scope slides on): over a stretch of 1 to 3 control-point spacings (30 mm ramps either side) the
//! path is drawn towards a line 2 to 5 mm outside the wall, with a strength that rises and falls
//! over the event (a half sine), so the centres cross the wall for the middle part of it. Control points stay equally spaced along the path. Every control point whose
//! centre ends outside the rest wall is listed in [`Frame::escaped`], with how far in
//! [`Frame::escaped_by_mm`]; the wall does not give around them (a puncture zone of +-0.75
//! control-point spacings along the arc and 80 degrees around the push keeps its rest shape, and
//! the segments touching them do not deform it), so they stay outside in the frame's colon.

use crate::rng::Rng;
use lumen_detect::{Rod, Tube};
use lumen_import::geom::{at_arc, at_arc_scalar, d3, f3, smooth_along, smooth_scalar, V3d};
use lumen_import::probe::Lumen;
use std::f64::consts::PI;

/// The scope and how it presses on the wall. Lengths in the colon's unit (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Insertion {
    /// Scope length (default 1600 mm).
    pub length_mm: f32,
    /// Scope radius (default 6.5 mm).
    pub radius_mm: f32,
    /// Control points, tip first (default 160).
    pub points: usize,
    /// How far past the rest wall the scope reaches at a full bend, before the wall gives
    /// (default 2 mm; in frames it varies between 50% and 100% of this, slowly).
    pub press_mm: f32,
    /// How far the scope stays pressed into the deformed wall (default 0.5 mm).
    pub residual_mm: f32,
    /// Whether [`Insertion::frames`] has escape events (default true).
    pub escapes: bool,
}

impl Default for Insertion {
    fn default() -> Self {
        Self { length_mm: 1600.0, radius_mm: 6.5, points: 160, press_mm: 2.0, residual_mm: 0.5, escapes: true }
    }
}

/// One frame: the deformed colon and the scope.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Frame number in its sequence (0 first).
    pub index: usize,
    /// Arc length of the colon's midline at the scope's tip.
    pub depth_mm: f32,
    /// The colon, deformed where the scope presses (same rings and spokes as the input).
    pub colon: Tube,
    /// The scope: control points tip first, one radius.
    pub scope: Rod,
    /// For each scope control point, the colon arc length where it is (negative: outside,
    /// that far behind the first ring).
    pub arc_mm: Vec<f32>,
    /// Control points inside the colon (past the first ring's plane): `0..inserted`.
    pub inserted: usize,
    /// Length of scope inside the colon, along its path (longer than `depth_mm` where the scope
    /// rides the outer wall of bends).
    pub inserted_mm: f32,
    /// Whether an escape event is under way (the scope is being pushed through the wall at a
    /// bend; the part behind the bulge then shifts by its extra length, a few millimetres over
    /// several frames).
    pub escaping: bool,
    /// Control points pushed through the wall (their centre outside the colon), ascending.
    pub escaped: Vec<usize>,
    /// How far outside the wall each of [`Frame::escaped`] is (centre to wall, along the push).
    pub escaped_by_mm: Vec<f32>,
    /// Spoke tips moved away from the rest wall.
    pub deformed_tips: usize,
}

/// Per-colon data the insertion needs (computed once per sequence).
struct Track {
    lumen: Lumen,
    rest: Tube,
    arc: Vec<f64>,
    centre: Vec<V3d>,
    normal: Vec<V3d>,
    /// Outward bend direction, unit, in the ring plane.
    out: Vec<V3d>,
    /// Bend factor in [0, 1].
    beta: Vec<f64>,
    /// Wall distance along `out`, averaged along the arc.
    r_out: Vec<f64>,
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

const KAPPA_LO: f64 = 1.0 / 300.0;
const KAPPA_HI: f64 = 1.0 / 120.0;
const TIP_FREE_MM: f64 = 60.0;
const ANUS_FREE_MM: f64 = 40.0;
const SPREAD_MM: f64 = 8.0;
const PATH_SMOOTHING_MM: f64 = 10.0;
const KAPPA_SMOOTHING_MM: f64 = 15.0;
const ESCAPE_RAMP_MM: f64 = 30.0;
const SPREAD_SPOKES: i64 = 2;

impl Track {
    fn new(colon: &Tube) -> Self {
        let lumen = Lumen::new(colon);
        let n = lumen.rings();
        let arc = lumen.arc().to_vec();
        let centre: Vec<V3d> = (0..n).map(|i| lumen.point(i)).collect();
        let normal: Vec<V3d> = (0..n).map(|i| lumen.normal(i)).collect();
        let kappa: Vec<V3d> = (0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let ds = arc[b] - arc[a];
                if ds > 0.0 {
                    (normal[b] - normal[a]) / ds
                } else {
                    V3d::zeros()
                }
            })
            .collect();
        let kappa = smooth_along(&kappa, &arc, KAPPA_SMOOTHING_MM);
        let mut out = Vec::with_capacity(n);
        let mut beta = Vec::with_capacity(n);
        let mut prev: Option<V3d> = None;
        for i in 0..n {
            let k = kappa[i] - normal[i] * kappa[i].dot(&normal[i]);
            let mag = k.norm();
            let dir = if mag > 1e-9 {
                -k / mag
            } else {
                prev.map(|p| p - normal[i] * p.dot(&normal[i])).and_then(|p| p.try_normalize(1e-9)).unwrap_or_else(|| lumen_import::geom::any_perpendicular(normal[i]))
            };
            prev = Some(dir);
            out.push(dir);
            beta.push(smoothstep((mag - KAPPA_LO) / (KAPPA_HI - KAPPA_LO)));
        }
        let r_raw: Vec<f64> = (0..n).map(|i| lumen.wall_radius(i, out[i])).collect();
        let r_out = smooth_scalar(&r_raw, &arc, 8.0);
        Self { lumen, rest: colon.clone(), arc, centre, normal, out, beta, r_out }
    }

    fn length(&self) -> f64 {
        self.arc[self.arc.len() - 1]
    }
}

/// An escape event, as seeded.
#[derive(Debug, Clone, Copy)]
struct Event {
    start: usize,
    len: usize,
    peak_mm: f64,
    count: usize,
}

/// Where the scope is in one frame, before deformation.
struct Pose {
    points: Vec<V3d>,
    arc: Vec<f64>,
    /// Whether each control point is inside the colon.
    inside: Vec<bool>,
    /// Scope length inside.
    inside_len: f64,
    escaped: Vec<usize>,
    escaped_by: Vec<f64>,
}

impl Insertion {
    fn spacing(&self) -> f64 {
        self.length_mm as f64 / (self.points.max(2) - 1) as f64
    }

    fn check(&self, colon: &Tube) {
        assert!(self.points >= 2, "a scope needs at least 2 control points");
        assert!(self.radius_mm > 0.0 && self.length_mm > 0.0, "scope length and radius must be > 0");
        assert!(colon.rings() >= 2, "the colon needs at least 2 rings");
    }

    /// Deepest reachable tip depth: 30 mm (or a tenth of the colon) before its last ring.
    fn max_depth(track: &Track) -> f64 {
        (track.length() - 30.0f64.min(0.1 * track.length())).max(0.0)
    }

    fn pose(&self, t: &Track, depth: f64, press: f64, escape: Option<(f64, f64, usize, f64)>) -> Pose {
        let r = self.radius_mm as f64;
        let n = t.arc.len();
        let depth = depth.clamp(0.0, Self::max_depth(t));
        let (itip, utip) = lumen_import::geom::locate_arc(&t.arc, depth);
        // Offset path through the rings up to the tip.
        let offset = |i: usize| -> f64 {
            let s = t.arc[i];
            let ramp = smoothstep((depth - s) / TIP_FREE_MM) * smoothstep(s / ANUS_FREE_MM);
            t.beta[i] * ramp * (t.r_out[i] - r + press).max(0.0)
        };
        let bent: Vec<V3d> = (0..=itip).map(|i| t.centre[i] + t.out[i] * offset(i)).collect();
        // The scope is stiffer than the lumen is wiggly: smooth the path, then keep it in the
        // lumen (the scope's surface at most `press` past the rest wall, in its ring's plane).
        let smooth = smooth_along(&bent, &t.arc[..=itip], PATH_SMOOTHING_MM);
        let mut path: Vec<V3d> = Vec::with_capacity(itip + 2);
        let mut path_s: Vec<f64> = Vec::with_capacity(itip + 2);
        let dx = self.spacing();
        for (i, q) in smooth.into_iter().enumerate() {
            let nrm = t.normal[i];
            let mut d = q - t.centre[i];
            d -= nrm * d.dot(&nrm);
            let len = d.norm();
            if len > 1e-9 {
                let room = (t.lumen.wall_radius(i, d) - r + press).max(0.0);
                if len > room {
                    d *= room / len;
                }
            }
            // An escape: over a plateau around `s_star` the path runs `peak` outside the wall
            // (towards the outer side of the bend), with raised-cosine ramps either side.
            if let Some((s_star, peak, count, strength)) = escape {
                let ds = (t.arc[i] - s_star).abs();
                let half = 0.5 * count as f64 * dx;
                let w = if ds <= half {
                    1.0
                } else if ds < half + ESCAPE_RAMP_MM {
                    0.5 * (1.0 + (PI * (ds - half) / ESCAPE_RAMP_MM).cos())
                } else {
                    0.0
                };
                if w > 0.0 {
                    let u = t.out[i];
                    let target = u * (t.lumen.wall_radius(i, u) + peak);
                    let w = w * strength;
                    d = d * (1.0 - w) + target * w;
                }
            }
            path.push(t.centre[i] + d);
            path_s.push(t.arc[i]);
        }
        if utip > 0.0 && itip + 1 < n {
            path.push(t.centre[itip].lerp(&t.centre[itip + 1], utip));
            path_s.push(depth);
        }
        let sigma = lumen_import::geom::arc_lengths(&path);
        let total = sigma[sigma.len() - 1];
        let back = -t.normal[0];
        let mut points = Vec::with_capacity(self.points);
        let mut arc = Vec::with_capacity(self.points);
        let mut inside = Vec::with_capacity(self.points);
        for j in 0..self.points {
            let sj = total - j as f64 * dx;
            if sj >= 0.0 && path.len() > 1 {
                points.push(at_arc(&path, &sigma, sj));
                arc.push(at_arc_scalar(&path_s, &sigma, sj));
                inside.push(true);
            } else {
                let behind = -sj.min(0.0);
                points.push(t.centre[0] + back * behind);
                arc.push(-behind);
                inside.push(false);
            }
        }
        // Control points whose centre ended outside the rest wall have escaped.
        let (mut escaped, mut escaped_by) = (Vec::new(), Vec::new());
        if escape.is_some() {
            let spacing = t.length() / (n - 1).max(1) as f64;
            for j in 0..self.points {
                if !inside[j] {
                    continue;
                }
                let hint = (arc[j] / spacing) as usize;
                if let Some(p) = t.lumen.locate(f3(points[j]), hint.saturating_sub(1)) {
                    if p.gap() < 0.0 {
                        escaped.push(j);
                        escaped_by.push(-p.gap());
                    }
                }
            }
        }
        Pose { points, arc, inside, inside_len: total, escaped, escaped_by }
    }

    /// The rest colon deformed around the scope of `pose`.
    fn deform(&self, t: &Track, pose: &Pose) -> (Tube, usize) {
        let r = self.radius_mm as f64;
        let keep = (r - self.residual_mm as f64).max(0.1 * r);
        let n = t.arc.len();
        let b = t.rest.spokes;
        let spacing = if n > 1 { t.length() / (n - 1) as f64 } else { 1.0 };
        let mut raw = vec![0.0f64; n * b];
        let m = pose.points.len();
        let touches_escape = |j: usize| pose.escaped.iter().any(|&e| e == j || e == j + 1);
        for j in 0..m.saturating_sub(1) {
            if !(pose.inside[j] || pose.inside[j + 1]) || touches_escape(j) {
                continue;
            }
            let (a, c) = (pose.points[j], pose.points[j + 1]);
            let axis = c - a;
            let len = axis.norm();
            if len < 1e-9 {
                continue;
            }
            let dir = axis / len;
            let (s0, s1) = (pose.arc[j].min(pose.arc[j + 1]), pose.arc[j].max(pose.arc[j + 1]));
            let lo = t.arc.partition_point(|&x| x < s0 - r - 2.0);
            let hi = t.arc.partition_point(|&x| x <= s1 + r + 2.0);
            for i in lo..hi {
                for k in 0..b {
                    let v = t.lumen.spoke(i, k);
                    let tip = t.centre[i] + v;
                    let w = tip - a;
                    let along = w.dot(&dir);
                    if along < 0.0 || along > len {
                        continue;
                    }
                    let wp = w - dir * along;
                    if wp.norm() >= keep {
                        continue;
                    }
                    let vl = v.norm();
                    if vl < 1e-9 {
                        continue;
                    }
                    let vh = v / vl;
                    let vp = vh - dir * vh.dot(&dir);
                    let (qa, qb, qc) = (vp.dot(&vp), wp.dot(&vp), wp.dot(&wp) - keep * keep);
                    if qa < 1e-9 {
                        continue;
                    }
                    let lam = (-qb + (qb * qb - qa * qc).max(0.0).sqrt()) / qa;
                    let lam = lam.clamp(0.0, 3.0 * r);
                    let slot = &mut raw[i * b + k];
                    *slot = slot.max(lam);
                }
            }
        }
        // Spread smoothly.
        let ki = (SPREAD_MM / spacing).ceil() as i64;
        let mut disp = vec![0.0f64; n * b];
        for i in 0..n {
            for k in 0..b {
                let l = raw[i * b + k];
                if l <= 0.0 {
                    continue;
                }
                for di in -ki..=ki {
                    let ii = i as i64 + di;
                    if ii < 0 || ii >= n as i64 {
                        continue;
                    }
                    let ds = (t.arc[ii as usize] - t.arc[i]).abs();
                    if ds >= SPREAD_MM {
                        continue;
                    }
                    let ws = 0.5 * (1.0 + (PI * ds / SPREAD_MM).cos());
                    for dk in -SPREAD_SPOKES..=SPREAD_SPOKES {
                        let kk = (k as i64 + dk).rem_euclid(b as i64) as usize;
                        let wk = 0.5 * (1.0 + (PI * dk as f64 / (SPREAD_SPOKES + 1) as f64).cos());
                        let slot = &mut disp[ii as usize * b + kk];
                        *slot = slot.max(l * ws * wk);
                    }
                }
            }
        }
        // Puncture zones keep the rest wall.
        let dx = self.spacing();
        for &j in &pose.escaped {
            let s = pose.arc[j];
            let c = at_arc(&t.centre, &t.arc, s);
            let push = pose.points[j] - c;
            let lo = t.arc.partition_point(|&x| x < s - 0.75 * dx);
            let hi = t.arc.partition_point(|&x| x <= s + 0.75 * dx);
            for i in lo..hi {
                let nrm = t.normal[i];
                let p = (push - nrm * push.dot(&nrm)).try_normalize(1e-9);
                for k in 0..b {
                    let v = t.lumen.spoke(i, k);
                    if let (Some(p), Some(vh)) = (p, v.try_normalize(1e-9)) {
                        if vh.dot(&p) > (80f64).to_radians().cos() {
                            disp[i * b + k] = 0.0;
                        }
                    }
                }
            }
        }
        let mut tube = t.rest.clone();
        let mut moved = 0;
        for (idx, &d) in disp.iter().enumerate() {
            if d > 0.0 {
                let v = d3(tube.radial[idx]);
                let vl = v.norm();
                if vl > 1e-9 {
                    let nv = v * ((vl + d) / vl);
                    let nf = f3(nv);
                    if nf != tube.radial[idx] {
                        tube.radial[idx] = nf;
                        moved += 1;
                    }
                }
            }
        }
        (tube, moved)
    }

    fn make_frame(&self, t: &Track, index: usize, depth: f64, press: f64, escape: Option<(f64, f64, usize, f64)>) -> Frame {
        let depth = depth.clamp(0.0, Self::max_depth(t));
        let pose = self.pose(t, depth, press, escape);
        let (colon, deformed_tips) = self.deform(t, &pose);
        let scope = Rod::new(pose.points.iter().map(|&p| f3(p)).collect(), vec![self.radius_mm]).expect("scope is a valid rod");
        Frame {
            index,
            depth_mm: depth as f32,
            colon,
            scope,
            arc_mm: pose.arc.iter().map(|&a| a as f32).collect(),
            inserted: pose.inside.iter().take_while(|&&x| x).count(),
            inserted_mm: pose.inside_len as f32,
            escaping: escape.is_some(),
            escaped: pose.escaped,
            escaped_by_mm: pose.escaped_by.iter().map(|&e| e as f32).collect(),
            deformed_tips,
        }
    }

    /// One frame with the tip at `depth_mm` (colon arc length), the scope pressing
    /// [`Insertion::press_mm`] at bends and the wall deformed; no escapes.
    ///
    /// # Panics
    /// If the colon has fewer than 2 rings or the scope parameters are not positive.
    pub fn frame(&self, colon: &Tube, depth_mm: f32) -> Frame {
        self.check(colon);
        let t = Track::new(colon);
        self.make_frame(&t, 0, depth_mm as f64, self.press_mm as f64, None)
    }

    /// A deterministic sequence of `n_frames` frames: the tip starts at `start_depth_mm` and
    /// advances `mm_per_frame` (about 1 mm) along the midline each frame, stopping 30 mm before
    /// the last ring; the press varies slowly and, if [`Insertion::escapes`], seeded escape
    /// events push control points through the wall (see the module docs). Equal inputs give
    /// equal frames.
    ///
    /// # Panics
    /// As [`Insertion::frame`].
    pub fn frames(&self, colon: &Tube, n_frames: usize, start_depth_mm: f32, mm_per_frame: f32, seed: u64) -> Frames {
        self.check(colon);
        let track = Track::new(colon);
        // Separate streams, so a longer sequence starts with the same frames.
        let phase = Rng::new(seed, 0x9A5E).range(0.0, 2.0 * PI);
        let mut rng = Rng::new(seed, 0x5C09E);
        let mut events = Vec::new();
        if self.escapes {
            let mut f = rng.int(15, 45) as usize;
            while f < n_frames {
                let len = rng.int(12, 24) as usize;
                let peak_mm = rng.range(2.0, 5.0);
                let count = rng.int(1, 3) as usize;
                events.push(Event { start: f, len, peak_mm, count });
                f += len + rng.int(40, 120) as usize;
            }
        }
        Frames { insertion: self.clone(), track, n_frames, next: 0, start: start_depth_mm as f64, step: mm_per_frame as f64, phase, events, s_star: None }
    }
}

/// The frames of [`Insertion::frames`].
pub struct Frames {
    insertion: Insertion,
    track: Track,
    n_frames: usize,
    next: usize,
    start: f64,
    step: f64,
    phase: f64,
    events: Vec<Event>,
    /// (event index, where it pushes through) for the current event.
    s_star: Option<(usize, Option<f64>)>,
}

impl Frames {
    /// Where the scope presses hardest on the wall (its centre nearest the wall), away from the
    /// tip and the anus; `None` if it presses nowhere there.
    fn hardest_press(&self, depth: f64, press: f64) -> Option<f64> {
        let t = &self.track;
        let pose = self.insertion.pose(t, depth, press, None);
        let (lo, hi) = (ANUS_FREE_MM + 40.0, depth - TIP_FREE_MM - 40.0);
        let spacing = t.length() / (t.arc.len() - 1).max(1) as f64;
        let r = self.insertion.radius_mm as f64;
        let mut best: Option<(f64, f64)> = None;
        for j in 0..pose.points.len() {
            let s = pose.arc[j];
            if !pose.inside[j] || s < lo || s > hi {
                continue;
            }
            if let Some(p) = t.lumen.locate(f3(pose.points[j]), ((s / spacing) as usize).saturating_sub(1)) {
                let g = p.gap() - r;
                if best.is_none_or(|(b, _)| g < b) {
                    best = Some((g, p.s));
                }
            }
        }
        best.filter(|(g, _)| *g < 0.0).map(|(_, s)| s)
    }
}

impl Iterator for Frames {
    type Item = Frame;

    fn next(&mut self) -> Option<Frame> {
        if self.next >= self.n_frames {
            return None;
        }
        let f = self.next;
        self.next += 1;
        let depth = (self.start + self.step * f as f64).clamp(0.0, Insertion::max_depth(&self.track));
        let press = self.insertion.press_mm as f64 * (0.75 + 0.25 * (2.0 * PI * f as f64 / 97.0 + self.phase).sin());
        let mut escape = None;
        if let Some((ei, ev)) = self.events.iter().enumerate().find(|(_, e)| f >= e.start && f < e.start + e.len) {
            let ev = *ev;
            if self.s_star.is_none_or(|(k, _)| k != ei) {
                self.s_star = Some((ei, self.hardest_press(depth, press)));
            }
            if let Some((_, Some(s))) = self.s_star {
                // The push rises and falls over the event; the centres cross the wall once it is
                // strong enough.
                let x = (f - ev.start) as f64 + 0.5;
                let strength = (PI * x / ev.len as f64).sin();
                escape = Some((s, ev.peak_mm, ev.count, strength));
            }
        }
        Some(self.insertion.make_frame(&self.track, f, depth, press, escape))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.n_frames - self.next;
        (left, Some(left))
    }
}

impl ExactSizeIterator for Frames {}

/// A ready benchmark scene: the generated colon of `seed` (1.5 m, 1.2 mm rings, 32 spokes) with
/// the default scope inserted 1 m and pressing at the bends, the wall deformed, no escapes.
pub fn colonoscopy_scene(seed: u64) -> (Tube, Rod) {
    let colon = crate::colon::generate(&crate::colon::ColonParams::seeded(seed));
    let f = Insertion::default().frame(&colon, 1000.0);
    (f.colon, f.scope)
}
