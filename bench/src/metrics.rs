//! Accuracy against the dense reference ([`lumen_oracle::Reference`]).
//!
//! A [`Truth`] is one frame's reference: the deformed colon finely tessellated, and the
//! endoscope sampled densely ([`DENSE_PER_SEGMENT`] points per segment, [`lumen_oracle::dense_rod`])
//! with the reference's signed distance, nearest wall point and normal at every point. Only the
//! part of the rod inside the colon is judged: the segments whose two control points are both
//! inside (the scope's part behind the anus is outside the tube by construction, not an escape).
//! A method's samples at precision `x` are dense points too (`u = s / x` is `u = (s 64 / x) / 64`),
//! so their reference values are shared across precisions.
//!
//! [`evaluate`] adds one frame's reported contacts of one method to a [`Tally`]:
//! - **depth error**, at every reported contact: `|depth - (sd + r)|`, with `sd` the reference
//!   signed distance (negative inside) of the point where the method computed the contact: the
//!   rod sample for `lumen-detect`'s methods, the capsule's axis point for parry, and `r` the rod
//!   radius (`sd + r` is the reference penetration depth);
//! - **false contacts**: reported contacts whose reference gap `-(sd + r)` is
//!   [`TOLERANCE_MM`] (0.1 mm) or more;
//! - **missed contacts**: dense points penetrating the reference wall by [`TOLERANCE_MM`] or
//!   more (`sd + r >= 0.1`) with no reported contact within one sample spacing (the arc length
//!   of their rod segment over `x`, plus 1 um); `missed` counts *places* (maximal runs of
//!   consecutive missed dense points), `missed_dense` the points;
//! - **normal error**: angle between the reported normal and the reference's outward normal at
//!   the nearest wall point of the contact's point. Where two wall points are (almost) equally
//!   near, "the nearest" is ill-defined (a point on the medial axis of a fold, or equidistant
//!   from two faces of a crease), so the reference normal at the method's *own* wall point (the
//!   reference queried at the reported wall point) is also accepted, and so is the distance's
//!   own direction there (from the point to its reference wall point inside the wall, from the
//!   wall point to it outside; where they lie [`GRADIENT_MM`] apart or more): on a crease of the
//!   wall (a ring where the spokes change pace, a fold's valley) the nearest point is on the
//!   crease, neither face's normal is the wall's, and the direction in which the distance
//!   grows, the one that separates the two, lies between them. The smallest of the angles
//!   counts;
//! - **other walls**: a `lumen-detect` contact flagged `FLAG_OTHER_WALL` (bit 2) is a sample's
//!   contact with another wall than its nearest (a corner, a pocket): it is judged on its own
//!   wall point `w` (the reference's nearest wall point to the reported one): depth error
//!   against `r - |p - w|`, normal error against the reference normal at `w`, false when
//!   `-(r - |p - w|)` is [`TOLERANCE_MM`] or more;
//! - **escapes**: the method's samples whose centre is outside the reference wall (`sd > 0`);
//!   one is *detected* when the method reports a contact at that sample (for parry: of either
//!   capsule ending at that sample) that knows the centre is through the wall: depth at least `r - 0.1 mm` and a
//!   normal within 90 degrees of the reference's outward normal, so that resolving the contact
//!   pushes the scope back in.
//!
//! **Reference accuracy.** [`Reference::bound`] is a bound over the whole tube; a wall that
//! twists between rings (the imported colon's repaired spokes) can make it large where no
//! contact happens. So every judged point also gets the *local* bound: the same formula
//! evaluated on the cells (ring segment x spoke pair) whose tips' box, grown by 1 mm, holds the
//! reference's nearest wall point; both are reported.

use lumen_detect::proto::contact::FLAG_OTHER_WALL;
use lumen_detect::spline::Cubic;
use lumen_detect::{Rod, Tube, V3};
use lumen_oracle::{dense_rod, RefQuery, Reference};

/// Dense points per rod segment (the issue asks for 64 or more).
pub const DENSE_PER_SEGMENT: usize = 64;
/// Penetration, gap and escape-depth tolerance (mm): 0.1.
pub const TOLERANCE_MM: f32 = 0.1;
/// Findings kept per kind and run.
pub const FINDINGS_KEPT: usize = 6;

/// One dense rod point and the reference there.
#[derive(Debug, Clone, Copy)]
pub struct Dense {
    pub p: [f32; 3],
    pub r: f32,
    pub q: RefQuery,
}

impl Dense {
    /// Reference penetration depth `sd + r` (positive: the rod overlaps the wall).
    pub fn depth(&self) -> f32 {
        self.q.sd + self.r
    }
}

/// Per-cell facts of a tube's wall: the reference's accuracy bound there (the formula of
/// [`lumen_oracle`]) and whether the wall folds (an axial edge runs backwards against the
/// midline: neighbouring rings cross inside the lumen, as on the inner side of bends tighter
/// than the lumen's radius, and the wall passes through the lumen).
struct Cells {
    cell: Vec<f32>,
    folded: Vec<bool>,
    tips: Vec<[f32; 3]>,
    spokes: usize,
    /// Arc length of each ring along the control polygon.
    ring_arc: Vec<f32>,
}

/// Distance (mm) from a folded cell's tips within which a wall point is not judged.
pub const FOLD_MARGIN_MM: f32 = 2.0;

impl Cells {
    fn new(t: &Tube, alpha: f32, steps: usize) -> Self {
        let (n, b) = (t.rings(), t.spokes);
        let h = 1.0 / steps.max(1) as f64;
        let o = t.points[0];
        let local = |j: usize| V3::new(t.points[j][0] - o[0], t.points[j][1] - o[1], t.points[j][2] - o[2]);
        let spoke = |i: usize, k: usize| -> [f64; 3] { t.radial[i * b + k].map(|x| x as f64) };
        let tips: Vec<[f32; 3]> = (0..n * b)
            .map(|ik| {
                let (p, v) = (t.points[ik / b], t.radial[ik]);
                [p[0] + v[0], p[1] + v[1], p[2] + v[2]]
            })
            .collect();
        let mut cell = Vec::with_capacity(n.saturating_sub(1) * b);
        let mut folded = Vec::with_capacity(n.saturating_sub(1) * b);
        for i in 0..n.saturating_sub(1) {
            let c = Cubic::of_chain(local, n, i, alpha);
            let (c2, c3) = (c.c[2].cast::<f64>() * 2.0, c.c[3].cast::<f64>() * 6.0);
            let m2 = c2.norm().max((c2 + c3).norm());
            let tangent = c.tangent(0.5);
            let back = |k: usize| (V3::from(tips[(i + 1) * b + k]) - V3::from(tips[i * b + k])).dot(&tangent) < 0.0;
            for k in 0..b {
                let k1 = (k + 1) % b;
                let (a0, a1, b0, b1) = (spoke(i, k), spoke(i + 1, k), spoke(i, k1), spoke(i + 1, k1));
                let tw = (0..3).map(|d| ((b1[d] - b0[d]) - (a1[d] - a0[d])).powi(2)).sum::<f64>().sqrt();
                cell.push(((h * h * m2 + 2.0 * h * tw) / 8.0) as f32);
                folded.push(back(k) || back(k1));
            }
        }
        let mut ring_arc = Vec::with_capacity(n);
        let mut acc = 0.0f32;
        for i in 0..n {
            if i > 0 {
                acc += dist(t.points[i - 1], t.points[i]);
            }
            ring_arc.push(acc);
        }
        Self { cell, folded, tips, spokes: b, ring_arc }
    }

    fn folded_cells(&self) -> usize {
        self.folded.iter().filter(|&&f| f).count()
    }

    /// For wall point `w`, among the cells of ring segments `rings`: the largest reference bound
    /// of the cells whose tips' box grown by 1 mm holds `w`; whether a folded cell's box grown by
    /// [`FOLD_MARGIN_MM`] holds it; and the arc length (mid-segment) of the cell whose tips'
    /// centre is nearest `w`.
    fn at(&self, w: [f32; 3], rings: std::ops::Range<usize>) -> (f32, bool, f32) {
        let b = self.spokes;
        let segs = self.cell.len() / b.max(1);
        let mut bound = 0.0f32;
        let mut fold = false;
        let mut nearest = (f32::INFINITY, 0usize);
        for i in rings.start..rings.end.min(segs) {
            for k in 0..b {
                let k1 = (k + 1) % b;
                let (mut lo, mut hi, mut c) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3], [0.0f32; 3]);
                for tip in [self.tips[i * b + k], self.tips[i * b + k1], self.tips[(i + 1) * b + k], self.tips[(i + 1) * b + k1]] {
                    for d in 0..3 {
                        lo[d] = lo[d].min(tip[d]);
                        hi[d] = hi[d].max(tip[d]);
                        c[d] += 0.25 * tip[d];
                    }
                }
                let within = |m: f32| (0..3).all(|d| w[d] >= lo[d] - m && w[d] <= hi[d] + m);
                if within(1.0) {
                    bound = bound.max(self.cell[i * b + k]);
                }
                if self.folded[i * b + k] && within(FOLD_MARGIN_MM) {
                    fold = true;
                }
                let dc = dist(c, w);
                if dc < nearest.0 {
                    nearest = (dc, i);
                }
            }
        }
        let i = nearest.1;
        let arc = 0.5 * (self.ring_arc[i.min(self.ring_arc.len() - 1)] + self.ring_arc[(i + 1).min(self.ring_arc.len() - 1)]);
        (bound, fold, arc)
    }
}

/// A wall point further than this (mm of midline) from the judged point's own place belongs to
/// another part of the colon (a loop or fold coming back): not judged.
pub const FOREIGN_MM: f32 = 30.0;

/// A point to look up in the reference, with the colon arc length it belongs to (which picks
/// its window).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QueryPoint {
    pub p: [f32; 3],
    pub arc: f32,
}

/// The reference's answer at a point, with what is known about the wall there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Answer {
    pub q: RefQuery,
    /// The reference's accuracy bound on the cells around the nearest wall point.
    pub local_bound: f32,
    /// The nearest wall point is on or within [`FOLD_MARGIN_MM`] of a folded cell, or belongs
    /// to a part of the colon more than [`FOREIGN_MM`] of midline from the point's own place:
    /// not judged.
    pub folded: bool,
    /// Arc length of the nearest wall point's cell (mm of midline).
    pub wall_arc: f32,
}

/// How the reference is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthParams {
    /// Axial subdivisions per ring segment.
    pub steps: usize,
    /// Half-length of a window of the colon (mm of midline arc); 0: one reference of the whole
    /// colon.
    pub window_mm: f32,
    /// Threads building windows.
    pub threads: usize,
}

impl Default for TruthParams {
    fn default() -> Self {
        Self { steps: 32, window_mm: 60.0, threads: 1 }
    }
}

/// One frame's reference answers along its rod (the judged part), and at extra points.
///
/// **Windows.** Where a colon's loops overlap (the real colon, inflated x2, touches itself where
/// the sigmoid meets the rectum), the nearest wall of a point inside the scope's own section can
/// be another loop's, seen from outside, and a single reference of the whole colon calls the
/// point outside. The truth is the wall of the section the scope is in, so points are judged
/// against a reference of a window of the colon around their own arc length (the insertion's
/// [`lumen_scene::Frame::arc_mm`]): windows of `2 window_mm` of midline, centred every
/// `window_mm`, each point in the window whose centre is nearest (so at least `window_mm / 2`
/// from its ends; the window's end caps are that far away). Interior segments of a window have
/// exactly the colon's spline (Catmull-Rom uses the same four control points).
///
/// **Folds.** Where the wall itself folds through the lumen (neighbouring rings crossing),
/// nothing is the truth: points whose nearest wall point lies on or near a folded cell are
/// counted and left out of every figure.
pub struct Truth {
    dense: Vec<Dense>,
    dense_ans: Vec<Answer>,
    extra: Vec<Answer>,
    /// Arc length of each judged rod segment (sum of its dense chords).
    seg_arc: Vec<f32>,
    bound: f32,
    windows: usize,
    folded_cells: usize,
    steps: usize,
}

impl std::fmt::Debug for Truth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Truth").field("dense", &self.dense.len()).field("segments", &self.seg_arc.len()).field("bound", &self.bound).field("windows", &self.windows).finish_non_exhaustive()
    }
}

/// Colon arc length at rod parameter (segment `j`, `u`), from the arc of each control point.
pub fn arc_at(arc_mm: &[f32], j: usize, u: f32) -> f32 {
    match (arc_mm.get(j), arc_mm.get(j + 1)) {
        (Some(&a), Some(&b)) => a + (b - a) * u,
        (Some(&a), None) => a,
        _ => arc_mm.last().copied().unwrap_or(0.0),
    }
}

impl Truth {
    /// The reference of `tube` along `rod`'s segments whose control points are both among the
    /// first `inside` (the part inside the colon), `arc_mm` the colon arc of each rod control
    /// point; plus answers at `extra` points, in order.
    pub fn new(tube: &Tube, rod: &Rod, inside: usize, arc_mm: &[f32], alpha: f32, params: TruthParams, extra: &[QueryPoint]) -> Truth {
        let cells = Cells::new(tube, alpha, params.steps);
        let segs = inside.min(rod.points.len()).saturating_sub(1);
        let pts = dense_rod(rod, alpha, DENSE_PER_SEGMENT);
        let n = if segs == 0 { 0 } else { segs * DENSE_PER_SEGMENT + 1 };
        let mut queries: Vec<QueryPoint> = (0..n)
            .map(|i| {
                let (j, m) = (i / DENSE_PER_SEGMENT, i % DENSE_PER_SEGMENT);
                QueryPoint { p: pts[i].0, arc: arc_at(arc_mm, j, m as f32 / DENSE_PER_SEGMENT as f32) }
            })
            .collect();
        queries.extend_from_slice(extra);

        // Ring arcs along the control polygon.
        let rings = tube.rings();
        let mut ring_arc = Vec::with_capacity(rings);
        let mut acc = 0.0f32;
        for i in 0..rings {
            if i > 0 {
                acc += dist(tube.points[i - 1], tube.points[i]);
            }
            ring_arc.push(acc);
        }
        let h = params.window_mm;
        // Window of each query: the nearest centre `k h`.
        let window_of = |a: f32| if h > 0.0 { (a.max(0.0) / h).round() as usize } else { 0 };
        let mut wins: Vec<usize> = queries.iter().map(|q| window_of(q.arc)).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
        wins.sort_unstable();
        let ring_range = |k: usize| -> std::ops::Range<usize> {
            if h <= 0.0 {
                return 0..rings;
            }
            let c = k as f32 * h;
            let i0 = ring_arc.partition_point(|&a| a < c - h).saturating_sub(2);
            let i1 = (ring_arc.partition_point(|&a| a <= c + h) + 2).min(rings);
            if i1 - i0 < 4 {
                i0.min(rings.saturating_sub(4))..(i0 + 4).min(rings)
            } else {
                i0..i1
            }
        };
        let answers = std::sync::Mutex::new(vec![None::<Answer>; queries.len()]);
        let bound = std::sync::Mutex::new(0.0f32);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let work = || loop {
            let w = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let Some(&k) = wins.get(w) else { break };
            let r = ring_range(k);
            let sub = Tube { points: tube.points[r.clone()].to_vec(), radial: tube.radial[r.start * tube.spokes..r.end * tube.spokes].to_vec(), spokes: tube.spokes };
            let reference = Reference::new(&sub, alpha, params.steps);
            let cell_range = r.start..r.end.saturating_sub(1);
            let mine: Vec<(usize, Answer)> = queries
                .iter()
                .enumerate()
                .filter(|(_, q)| window_of(q.arc) == k)
                .map(|(i, qp)| {
                    let q = reference.query(qp.p);
                    let (local_bound, fold, wall_arc) = cells.at(q.point, cell_range.clone());
                    let folded = fold || (wall_arc - qp.arc).abs() > FOREIGN_MM;
                    (i, Answer { q, local_bound, folded, wall_arc })
                })
                .collect();
            let mut b = bound.lock().unwrap();
            *b = b.max(reference.bound());
            drop(b);
            let mut a = answers.lock().unwrap();
            for (i, ans) in mine {
                a[i] = Some(ans);
            }
        };
        let threads = params.threads.max(1).min(wins.len().max(1));
        std::thread::scope(|s| {
            for _ in 1..threads {
                s.spawn(work);
            }
            work();
        });
        let mut all: Vec<Answer> = answers.into_inner().unwrap().into_iter().map(|a| a.expect("every query answered")).collect();
        let extra_ans = all.split_off(n);
        let dense: Vec<Dense> = (0..n).map(|i| Dense { p: pts[i].0, r: pts[i].1, q: all[i].q }).collect();
        let seg_arc = (0..segs).map(|j| (0..DENSE_PER_SEGMENT).map(|m| dist(dense[j * DENSE_PER_SEGMENT + m].p, dense[j * DENSE_PER_SEGMENT + m + 1].p)).sum()).collect();
        Truth { dense, dense_ans: all, extra: extra_ans, seg_arc, bound: bound.into_inner().unwrap(), windows: wins.len(), folded_cells: cells.folded_cells(), steps: params.steps }
    }

    /// The references' largest global bound (mm).
    pub fn bound(&self) -> f32 {
        self.bound
    }

    /// Axial subdivisions of the reference.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Windows built.
    pub fn windows(&self) -> usize {
        self.windows
    }

    /// Folded wall cells of the frame's colon.
    pub fn folded_cells(&self) -> usize {
        self.folded_cells
    }

    /// The dense points of the judged part of the rod.
    pub fn dense(&self) -> &[Dense] {
        &self.dense
    }

    /// Answers at the dense points.
    pub fn dense_answers(&self) -> &[Answer] {
        &self.dense_ans
    }

    /// Answers at the extra points.
    pub fn extra(&self) -> &[Answer] {
        &self.extra
    }

    /// Judged rod segments.
    pub fn segments(&self) -> usize {
        self.seg_arc.len()
    }

    /// Judged samples at precision `x` (a divisor of [`DENSE_PER_SEGMENT`]):
    /// `segments * x + 1` (none if no segment is judged).
    pub fn samples(&self, x: usize) -> usize {
        if self.seg_arc.is_empty() {
            0
        } else {
            self.seg_arc.len() * x + 1
        }
    }

    /// Index of sample `s` at precision `x` among the dense points.
    pub fn sample_index(&self, x: usize, s: usize) -> usize {
        s * (DENSE_PER_SEGMENT / x)
    }

    /// One sample spacing around dense point `i` at precision `x`.
    fn spacing(&self, i: usize, x: usize) -> f32 {
        let j = (i / DENSE_PER_SEGMENT).min(self.seg_arc.len() - 1);
        self.seg_arc[j] / x as f32
    }
}

/// The extra points [`evaluate`] needs for `reported` (at precision `x`, rod control points at
/// colon arcs `arc_mm`): per contact, its own point if it has one, then its wall point.
pub fn plan(reported: &[Reported], x: usize, arc_mm: &[f32]) -> Vec<QueryPoint> {
    let mut v = Vec::with_capacity(2 * reported.len());
    for c in reported {
        let s = c.sample as usize;
        let arc = arc_at(arc_mm, s / x, (s % x) as f32 / x as f32);
        if let Some(p) = c.at {
            v.push(QueryPoint { p, arc });
        }
        v.push(QueryPoint { p: c.wall, arc });
    }
    v
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Least distance between a point and its wall point for the direction between them to count as
/// a reference normal (mm): nearer, rounding turns it.
pub const GRADIENT_MM: f32 = 0.05;

/// The angle between `n` and the distance's direction at `p` to its wall point `w`, outward
/// (from `p` to `w` where `sd < 0`, the point inside the wall; from `w` to `p` outside); 180
/// where they lie less than [`GRADIENT_MM`] apart.
pub fn gradient_angle(n: [f32; 3], p: [f32; 3], w: [f32; 3], sd: f32) -> f32 {
    let d = V3::from(w) - V3::from(p);
    if d.norm() < GRADIENT_MM {
        return 180.0;
    }
    let out = if sd < 0.0 { d } else { -d };
    angle_deg(n, out.into())
}

/// Angle between two directions, degrees (180 if either has no length).
pub fn angle_deg(a: [f32; 3], b: [f32; 3]) -> f32 {
    let (a, b) = (V3::from(a).cast::<f64>(), V3::from(b).cast::<f64>());
    let (na, nb) = (a.norm(), b.norm());
    if !(na > 0.0 && nb > 0.0) {
        return 180.0;
    }
    (a.dot(&b) / (na * nb)).clamp(-1.0, 1.0).acos().to_degrees() as f32
}

/// One contact as a method reported it, for judging.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reported {
    /// Rod sample (`segment * x + step`).
    pub sample: u32,
    /// Where the method computed it, if not at the sample itself (parry: the capsule's axis
    /// point).
    pub at: Option<[f32; 3]>,
    /// Penetration depth (positive: overlapping).
    pub depth: f32,
    /// Unit normal from the rod towards the wall.
    pub normal: [f32; 3],
    /// The method's wall point.
    pub wall: [f32; 3],
    /// `lumen-detect` contacts: tube ring pair, spoke pair, parameter along the ring pair, flags.
    pub place: Option<Place>,
}

/// Where on the tube a `lumen-detect` contact says it is.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Place {
    pub ring: u32,
    pub spoke: u32,
    pub param: f32,
    /// `FLAG_*` bits (1: section not star-shaped, 2: sample outside the wall, 4: another wall
    /// than the sample's nearest).
    pub flags: u8,
}

impl Reported {
    /// A `lumen-detect` contact (computed at its sample).
    pub fn of_contact(c: &lumen_detect::Contact) -> Self {
        Self { sample: c.sample, at: None, depth: c.depth, normal: c.normal, wall: c.point_b, place: Some(Place { ring: c.index_b, spoke: c.spoke_b, param: c.param_b, flags: c.flags }) }
    }

    /// A parry baseline contact (computed at its capsule's axis point).
    pub fn of_parry(c: &crate::baseline::ParryContact) -> Self {
        Self { sample: c.sample, at: Some(c.centre), depth: c.depth, normal: c.normal, wall: c.wall, place: None }
    }
}

/// Something wrong, located: for the report, so it can be reproduced and fixed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Finding {
    /// `depth_error`, `missed`, `false_contact`, `escape_missed` or `normal_error`.
    pub kind: String,
    pub frame: usize,
    /// Rod sample at the run's precision (for `missed`: the dense point's position in samples,
    /// fractional).
    pub sample: f32,
    /// The rod point judged (mm).
    pub point: [f32; 3],
    /// Reported depth, or `None` where nothing was reported.
    pub reported_depth: Option<f32>,
    /// Reference depth `sd + r` there.
    pub reference_depth: f32,
    /// Normal error (degrees), for reported contacts.
    pub normal_err_deg: Option<f32>,
    /// The reference's local bound there.
    pub reference_local_bound_mm: f32,
    /// The method's wall point, and the reference's signed distance there (0 if the method's
    /// wall were the reference's).
    pub reported_wall: Option<[f32; 3]>,
    pub reported_wall_sd: Option<f32>,
    /// Whether the method's wall point lies on or near a folded cell, or on a part of the colon
    /// more than [`FOREIGN_MM`] from the sample's own place (the method used a wall that is not
    /// the truth there).
    pub reported_wall_excluded: Option<bool>,
    /// Where the method placed it on the tube (`lumen-detect` methods).
    pub place: Option<Place>,
}

/// Everything [`evaluate`] gathered for one method and configuration.
#[derive(Debug, Clone, Default)]
pub struct Tally {
    pub frames: usize,
    pub contacts: usize,
    /// Reported contacts at samples outside the judged part of the rod (not judged).
    pub outside_domain: usize,
    pub depth_err: Vec<f32>,
    pub normal_err: Vec<f32>,
    pub local_bound: Vec<f32>,
    pub false_contacts: usize,
    pub penetrating_dense: usize,
    pub missed: usize,
    pub missed_dense: usize,
    pub escaped_detected: usize,
    pub escaped_total: usize,
    pub findings: Vec<Finding>,
    /// The global bounds of the references used.
    pub bound_max: f32,
    /// Not judged, because the reference's nearest wall point is on or near a folded cell:
    /// reported contacts, penetrating dense points, escaped samples.
    pub excluded_contacts: usize,
    pub excluded_dense: usize,
    pub excluded_escapes: usize,
}

/// The figures of a [`Tally`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Metrics {
    pub frames_evaluated: usize,
    pub contacts_evaluated: usize,
    pub contacts_outside_domain: usize,
    pub depth_err_mean_mm: Option<f64>,
    pub depth_err_p99_mm: Option<f64>,
    pub depth_err_max_mm: Option<f64>,
    pub normal_err_p50_deg: Option<f64>,
    pub normal_err_p99_deg: Option<f64>,
    pub missed: usize,
    pub missed_dense: usize,
    pub penetrating_dense: usize,
    pub false_contacts: usize,
    pub escaped_detected: usize,
    pub escaped_total: usize,
    pub reference_bound_mm: f64,
    pub reference_local_bound_p99_mm: Option<f64>,
    pub reference_local_bound_max_mm: Option<f64>,
    pub excluded_contacts: usize,
    pub excluded_dense: usize,
    pub excluded_escapes: usize,
}

/// Nearest-rank percentile `p` (0..=100) of `v` (sorted in place); `None` if empty.
pub fn percentile(v: &mut [f32], p: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    let rank = ((p / 100.0 * v.len() as f64).ceil() as usize).clamp(1, v.len());
    Some(v[rank - 1] as f64)
}

impl Tally {
    /// Summary figures.
    pub fn metrics(&self) -> Metrics {
        let (mut d, mut n, mut b) = (self.depth_err.clone(), self.normal_err.clone(), self.local_bound.clone());
        let mean = (!d.is_empty()).then(|| d.iter().map(|&e| e as f64).sum::<f64>() / d.len() as f64);
        Metrics {
            frames_evaluated: self.frames,
            contacts_evaluated: self.contacts,
            contacts_outside_domain: self.outside_domain,
            depth_err_mean_mm: mean,
            depth_err_p99_mm: percentile(&mut d, 99.0),
            depth_err_max_mm: percentile(&mut d, 100.0),
            normal_err_p50_deg: percentile(&mut n, 50.0),
            normal_err_p99_deg: percentile(&mut n, 99.0),
            missed: self.missed,
            missed_dense: self.missed_dense,
            penetrating_dense: self.penetrating_dense,
            false_contacts: self.false_contacts,
            escaped_detected: self.escaped_detected,
            escaped_total: self.escaped_total,
            reference_bound_mm: self.bound_max as f64,
            reference_local_bound_p99_mm: percentile(&mut b, 99.0),
            reference_local_bound_max_mm: percentile(&mut b, 100.0),
            excluded_contacts: self.excluded_contacts,
            excluded_dense: self.excluded_dense,
            excluded_escapes: self.excluded_escapes,
        }
    }

    /// Adds `o` (another frame's tally of the same configuration) to this one.
    pub fn merge(&mut self, o: Tally) {
        self.frames += o.frames;
        self.contacts += o.contacts;
        self.outside_domain += o.outside_domain;
        self.depth_err.extend(o.depth_err);
        self.normal_err.extend(o.normal_err);
        self.local_bound.extend(o.local_bound);
        self.false_contacts += o.false_contacts;
        self.penetrating_dense += o.penetrating_dense;
        self.missed += o.missed;
        self.missed_dense += o.missed_dense;
        self.escaped_detected += o.escaped_detected;
        self.escaped_total += o.escaped_total;
        self.bound_max = self.bound_max.max(o.bound_max);
        self.excluded_contacts += o.excluded_contacts;
        self.excluded_dense += o.excluded_dense;
        self.excluded_escapes += o.excluded_escapes;
        for f in o.findings {
            self.find(f);
        }
    }

    fn find(&mut self, f: Finding) {
        if self.findings.iter().filter(|g| g.kind == f.kind).count() < FINDINGS_KEPT {
            self.findings.push(f);
        }
    }
}

/// Judges one frame's `reported` contacts of a method run at precision `x` (a divisor of
/// [`DENSE_PER_SEGMENT`]) against `truth`, adding to `tally`. `answers` are the truth's answers
/// at the points [`plan`] listed for `reported`; `frame` is only for the findings.
pub fn evaluate(truth: &Truth, x: usize, frame: usize, reported: &[Reported], answers: &[Answer], tally: &mut Tally) {
    let x = x.max(1);
    assert!(DENSE_PER_SEGMENT.is_multiple_of(x), "precision {x} does not divide {DENSE_PER_SEGMENT}");
    let n_samples = truth.samples(x);
    tally.frames += 1;
    tally.bound_max = tally.bound_max.max(truth.bound());
    let dense = truth.dense();
    let dans = truth.dense_answers();
    let mut centres: Vec<[f32; 3]> = Vec::with_capacity(reported.len());
    let mut worst_depth: Option<Finding> = None;
    let mut next = 0;
    for c in reported {
        let s = c.sample as usize;
        let own_at = c.at.map(|_| {
            next += 1;
            answers[next - 1]
        });
        let wall = answers[next];
        next += 1;
        if s >= n_samples {
            tally.outside_domain += 1;
            continue;
        }
        let di = truth.sample_index(x, s);
        let (p, r, ans) = match (c.at, own_at) {
            (Some(p), Some(a)) => (p, dense[di].r, a),
            _ => (dense[di].p, dense[di].r, dans[di]),
        };
        // Wherever it lies, a reported contact covers its place for the missed count.
        centres.push(p);
        if ans.folded {
            tally.excluded_contacts += 1;
            continue;
        }
        let other_wall = c.place.is_some_and(|pl| pl.flags & FLAG_OTHER_WALL != 0);
        if other_wall && wall.folded {
            tally.excluded_contacts += 1;
            continue;
        }
        tally.contacts += 1;
        let q = ans.q;
        let (ref_depth, nerr) = if other_wall {
            (r - dist(p, wall.q.point), angle_deg(c.normal, wall.q.normal).min(gradient_angle(c.normal, p, wall.q.point, -1.0)))
        } else {
            (q.sd + r, angle_deg(c.normal, q.normal).min(angle_deg(c.normal, wall.q.normal)).min(gradient_angle(c.normal, p, q.point, q.sd)))
        };
        let err = (c.depth - ref_depth).abs();
        let lb = ans.local_bound;
        tally.depth_err.push(err);
        tally.normal_err.push(nerr);
        tally.local_bound.push(lb);
        let finding = |kind: &str| Finding {
            kind: kind.into(),
            frame,
            sample: s as f32,
            point: p,
            reported_depth: Some(c.depth),
            reference_depth: ref_depth,
            normal_err_deg: Some(nerr),
            reference_local_bound_mm: lb,
            reported_wall: Some(c.wall),
            reported_wall_sd: Some(wall.q.sd),
            reported_wall_excluded: Some(wall.folded),
            place: c.place,
        };
        if -ref_depth >= TOLERANCE_MM {
            tally.false_contacts += 1;
            tally.find(finding("false_contact"));
        }
        if nerr > 3.0 {
            tally.find(finding("normal_error"));
        }
        if err > 0.05 && worst_depth.as_ref().is_none_or(|w| (w.reported_depth.unwrap() - w.reference_depth).abs() < err) {
            worst_depth = Some(finding("depth_error"));
        }
    }
    debug_assert_eq!(next, answers.len());
    if let Some(w) = worst_depth {
        tally.find(w);
    }

    // Missed: penetrating dense points with no reported contact within one sample spacing.
    let mut prev_missed = false;
    for (i, d) in dense.iter().enumerate() {
        let mut missed = false;
        if d.depth() >= TOLERANCE_MM {
            if dans[i].folded {
                tally.excluded_dense += 1;
            } else {
                tally.penetrating_dense += 1;
                let reach = truth.spacing(i, x) + 1e-3;
                if !centres.iter().any(|&c| dist(c, d.p) <= reach) {
                    missed = true;
                    tally.missed_dense += 1;
                    if !prev_missed {
                        tally.missed += 1;
                        tally.find(Finding {
                            kind: "missed".into(),
                            frame,
                            sample: (i as f32) * x as f32 / DENSE_PER_SEGMENT as f32,
                            point: d.p,
                            reported_depth: None,
                            reference_depth: d.depth(),
                            normal_err_deg: None,
                            reference_local_bound_mm: dans[i].local_bound,
                            reported_wall: None,
                            reported_wall_sd: None,
                            reported_wall_excluded: None,
                            place: None,
                        });
                    }
                }
            }
        }
        prev_missed = missed;
    }

    // Escapes: samples whose centre is outside the reference wall.
    for s in 0..n_samples {
        let di = truth.sample_index(x, s);
        let d = &dense[di];
        if d.q.sd <= 0.0 {
            continue;
        }
        if dans[di].folded {
            tally.excluded_escapes += 1;
            continue;
        }
        tally.escaped_total += 1;
        // The contact at the sample; for contacts computed off the samples (parry's capsules),
        // that of either capsule ending at it.
        let knows = |c: &&Reported| c.depth >= d.r - TOLERANCE_MM && V3::from(c.normal).dot(&V3::from(d.q.normal)) > 0.0;
        let mine = |c: &&Reported| c.sample as usize == s || (c.at.is_some() && c.sample as usize + 1 == s);
        let hit = reported.iter().filter(mine).find(knows).or_else(|| reported.iter().find(mine));
        let ok = hit.is_some_and(|c| knows(&c));
        if ok {
            tally.escaped_detected += 1;
        } else {
            tally.find(Finding {
                kind: "escape_missed".into(),
                frame,
                sample: s as f32,
                point: d.p,
                reported_depth: hit.map(|c| c.depth),
                reference_depth: d.depth(),
                normal_err_deg: hit.map(|c| angle_deg(c.normal, d.q.normal)),
                reference_local_bound_mm: dans[di].local_bound,
                reported_wall: hit.map(|c| c.wall),
                reported_wall_sd: None,
                reported_wall_excluded: None,
                place: hit.and_then(|c| c.place),
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_distances_direction_is_outward_and_only_where_the_wall_is_far_enough() {
        // Inside the wall (sd < 0) the outward normal points from the point to its wall point;
        // outside, from the wall point to the point.
        let (p, w) = ([1.0, 2.0, 3.0], [1.0, 2.0, 5.0]);
        assert!(gradient_angle([0.0, 0.0, 1.0], p, w, -2.0) < 1e-3);
        assert!((gradient_angle([0.0, 0.0, -1.0], p, w, -2.0) - 180.0).abs() < 1e-3);
        assert!(gradient_angle([0.0, 0.0, -1.0], p, w, 2.0) < 1e-3);
        assert!((gradient_angle([1.0, 0.0, 1.0], p, w, -2.0) - 45.0).abs() < 1e-3);
        // Nearer than GRADIENT_MM the direction is not taken: 180, which no minimum picks.
        let near = [1.0, 2.0, 3.0 + 0.5 * GRADIENT_MM];
        assert_eq!(gradient_angle([0.0, 0.0, 1.0], p, near, -0.5 * GRADIENT_MM), 180.0);
    }
}
