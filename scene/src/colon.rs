//! A seeded, anatomically plausible colon, in millimetres.
//!
//! **Coordinates** (millimetres, patient frame): `x` towards the patient's left, `y` anterior
//! (towards the belly), `z` cranial (towards the head); the anus is at the origin and the first
//! ring, and the midline runs from there through the rectum, the sigmoid loop, the descending
//! colon, the splenic flexure, the sagging transverse colon, the hepatic flexure and the
//! ascending colon to the caecum, the last ring.
//!
//! **Midline.** A uniform cubic B-spline (C2: curvature is continuous) through a template of
//! anatomical waypoints, each moved by a seeded random offset of up to
//! [`ColonParams::jitter_mm`], then scaled uniformly to [`ColonParams::length_mm`] and resampled
//! every [`ColonParams::ring_spacing`] along its arc. A candidate is kept only if its bends are
//! gentle enough for the lumen (bend radius at least [`MIN_BEND_RATIO`] times the local lumen
//! radius, so rings never cross inside the lumen) and its loops keep their walls apart (midline
//! points more than `max(40 mm, 1.5 (R_i + R_j))` apart along the arc are further apart in space
//! than `R_i + R_j` plus [`MIN_WALL_GAP_MM`], `R` the largest radius of each ring; nearer pairs
//! are the bend check's business, since no chord exceeds its arc); otherwise the next candidate of the same seed is tried, and after
//! [`MAX_ATTEMPTS`] the unperturbed template (which passes; a test checks it) is used.
//!
//! **Lumen.** Radius `R(s, theta)` in `[radius_mm[0], radius_mm[1]]` (default 20-35 mm, the
//! insufflated colon): a base radius per region (narrowest in the sigmoid, widest in the
//! caecum) blended smoothly over 40 mm at region boundaries; three taeniae coli 120 degrees
//! apart, slowly twisting, where the section is slightly narrower (a rounded triangle); and
//! haustral folds: semilunar ridges between each pair of taeniae, every
//! [`ColonParams::haustra_spacing_mm`] along the arc (staggered between the three sectors,
//! jittered by the seed), up to [`ColonParams::haustra_depth_mm`] deep, absent in the rectum and
//! shallower in the sigmoid. Below 1.5 m of midline the radii shrink in proportion (so a short
//! colon is a scaled-down one, free of overlaps).
//!
//! **Hard variants.** [`ColonParams::narrowings`] narrow the lumen; [`ColonParams::tight_bends`]
//! gather the turning of stretches of the midline into arcs tighter than the lumen (the bend
//! check, and the wall gap check beside them, waived there only: [`TightBend`]);
//! [`ColonParams::sigmoid_loop`] replaces the template's sigmoid with a loop that passes beside
//! itself ([`SigmoidLoop`], every check kept, and its own: [`MIN_LOOP_TURN_DEG`],
//! [`MAX_LOOP_PASS_GAP_MM`]). [`GeneratedColon`] reports what each became.
//!
//! **Folds.** Where a bend is tighter than the lumen (the tight bends), the planes of its rings
//! cross inside the lumen, and the spokes on the inside of the bend that reach past a crossing
//! are shortened to short of it ([`Tube::unfold`]): the lumen there is what the sections hold
//! without passing over one another ([`GeneratedColon::folds`] says how much).
//!
//! **Rings.** Spoke `k` of a ring points along `cos(a) n + sin(a) b`, `a = 2 pi k / B`, with
//! `(n, b)` a rotation-minimising frame and `b = t x n` (`t` the unit tangent): counter-
//! clockwise about the tangent.

use crate::rng::{hash_unit, Rng};
use lumen_detect::model::FoldReport;
use lumen_detect::Tube;
use lumen_import::geom::{any_perpendicular, arc_lengths, at_arc, locate_arc, rotation_minimising, V3d};
use std::f64::consts::{PI, TAU};

/// Smallest accepted ratio of midline bend radius to local lumen radius.
pub const MIN_BEND_RATIO: f64 = 1.5;
/// Smallest accepted wall-to-wall gap between loops, millimetres (at 1.5 m; scaled below).
pub const MIN_WALL_GAP_MM: f64 = 5.0;
/// Candidates tried per seed before falling back to the template.
pub const MAX_ATTEMPTS: u32 = 64;

/// Parameters of [`generate`]. Lengths in millimetres.
#[derive(Debug, Clone, PartialEq)]
pub struct ColonParams {
    /// Midline length (default 1500 mm, the adult colon).
    pub length_mm: f32,
    /// Arc length between rings (default 1.2 mm: about 1,250 rings).
    pub ring_spacing: f32,
    /// Radial vectors per ring (default 32).
    pub spokes: usize,
    /// Smallest and largest lumen radius (default 20 and 35 mm, insufflated), for a 1.5 m
    /// colon; shorter colons scale them down in proportion.
    pub radius_mm: [f32; 2],
    /// Spacing of haustral folds along the arc (default 30 mm).
    pub haustra_spacing_mm: f32,
    /// Depth of the haustral folds (default 4 mm; at most 30% of the radius range is used).
    pub haustra_depth_mm: f32,
    /// Size (RMS) of the smooth random displacement of the anatomical waypoints, at 1.5 m
    /// (default 10 mm).
    pub jitter_mm: f32,
    /// The seed: equal parameters and seed give bit-identical tubes.
    pub seed: u64,
    /// Places where the lumen narrows (default none): a spastic or collapsed segment, the anal
    /// canal. Each takes the whole section down to its radius.
    pub narrowings: Vec<Narrowing>,
    /// Bends made tighter than the lumen (default none): each gathers the midline's turning
    /// over its window into one circular arc whose radius is a fraction of the lumen's. This is
    /// the explicit option that lets a bend past the generator's bend check
    /// ([`MIN_BEND_RATIO`]): the check is waived inside these windows only, and so is the wall
    /// gap check between two places both in or beside the same window (its inner wall folds
    /// over itself); everywhere else both checks apply as for the default colon.
    pub tight_bends: Vec<TightBend>,
    /// A sigmoid that loops once around (default none): see [`SigmoidLoop`]. The generator's
    /// checks all apply, and the loop's own ([`MIN_LOOP_TURN_DEG`], the gap between its two
    /// passes in `[MIN_WALL_GAP_MM, MAX_LOOP_PASS_GAP_MM]`).
    pub sigmoid_loop: Option<SigmoidLoop>,
}

/// A bend tighter than the lumen ([`ColonParams::tight_bends`]): the midline between
/// `at_mm - half_window_mm` and `at_mm + half_window_mm` from the anus (both at 1.5 m, in
/// proportion for other lengths) is replaced by a straight run along its first tangent, a
/// circular arc of radius `ratio` times the largest lumen radius in the window, and a straight
/// run along its last tangent, meeting the rest of the midline with the same position and
/// tangent (C1: the curvature jumps there). The window's chord out of the plane of the two
/// tangents (the sigmoid twists) is spread smoothly over the straight runs. The arc turns as
/// much as the midline did between the window's ends, which must be at least
/// [`MIN_TIGHT_TURN_DEG`] (otherwise the candidate is not kept); the window gets a little
/// longer, and the whole midline is scaled back to its length. With `ratio < 1` the ring planes
/// of the arc cross inside the lumen on the inner side of the bend.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TightBend {
    pub at_mm: f32,
    pub half_window_mm: f32,
    pub ratio: f32,
}

/// A sigmoid loop that doubles back ([`ColonParams::sigmoid_loop`]): from the rectosigmoid
/// junction the midline winds once around
/// an axis towards the patient's left, radius `radius_mm[0]` (up, anterior, down past the
/// rectum, posterior and up again: an alpha loop seen from the side), its second pass
/// `pitch_mm` to the left of its first (midline to midline), on for another 30 degrees; then
/// an exit bend of radius `radius_mm[1]` turns it 55 degrees to the left and one of 50 mm up
/// into the descending colon. The loop keeps its shape whatever the seed (it moves as a whole
/// with the waypoints around it; the rest of the colon varies as usual). Millimetres at 1.5 m,
/// in proportion for other lengths; both radii must stay at least [`MIN_BEND_RATIO`] times the
/// lumen's and the pitch must leave [`MIN_WALL_GAP_MM`] between the passes' walls (checked).
/// An exit bend tighter than the loop is where the scripted colonoscopy pushes (the sigmoid's
/// sharpest bend), so the scope lies through the whole loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmoidLoop {
    pub radius_mm: [f32; 2],
    pub pitch_mm: f32,
}

/// Smallest turning of a [`TightBend`]'s window, degrees.
pub const MIN_TIGHT_TURN_DEG: f64 = 45.0;
/// Smallest total turning of the midline over a [`SigmoidLoop`]'s revolution, degrees.
pub const MIN_LOOP_TURN_DEG: f64 = 330.0;
/// Largest wall-to-wall gap between a [`SigmoidLoop`]'s two passes, mm (at 1.5 m): nearer than
/// this the loop passes near itself.
pub const MAX_LOOP_PASS_GAP_MM: f64 = 30.0;

/// A stretch of the colon whose lumen is at most `radius_mm` over `length_mm` of midline
/// centred `at_mm` from the anus, easing back to the normal lumen over [`NARROWING_RAMP_MM`]
/// either side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Narrowing {
    pub at_mm: f32,
    pub radius_mm: f32,
    pub length_mm: f32,
}

/// Arc length over which a narrowing eases in and out (mm).
pub const NARROWING_RAMP_MM: f64 = 25.0;

impl Narrowing {
    /// The radius `r` at arc `s` under this narrowing.
    fn apply(&self, s: f64, r: f64) -> f64 {
        let target = self.radius_mm as f64;
        if target >= r {
            return r;
        }
        let d = (s - self.at_mm as f64).abs() - 0.5 * self.length_mm as f64;
        let w = if d <= 0.0 { 1.0 } else { 1.0 - smoothstep(d / NARROWING_RAMP_MM) };
        r + (target - r) * w
    }
}

impl Default for ColonParams {
    fn default() -> Self {
        Self {
            length_mm: 1500.0,
            ring_spacing: 1.2,
            spokes: 32,
            radius_mm: [20.0, 35.0],
            haustra_spacing_mm: 30.0,
            haustra_depth_mm: 4.0,
            jitter_mm: 10.0,
            seed: 0,
            narrowings: Vec::new(),
            tight_bends: Vec::new(),
            sigmoid_loop: None,
        }
    }
}

impl ColonParams {
    /// The defaults with this seed.
    pub fn seeded(seed: u64) -> Self {
        Self { seed, ..Self::default() }
    }
}

/// Anatomical regions, in order from the anus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Region {
    Rectum,
    Sigmoid,
    Descending,
    SplenicFlexure,
    Transverse,
    HepaticFlexure,
    Ascending,
    Caecum,
}

impl Region {
    pub const ALL: [Region; 8] = [Region::Rectum, Region::Sigmoid, Region::Descending, Region::SplenicFlexure, Region::Transverse, Region::HepaticFlexure, Region::Ascending, Region::Caecum];

    /// Base lumen level in [0, 1] of the radius range.
    fn level(self) -> f64 {
        match self {
            Region::Rectum => 0.45,
            Region::Sigmoid => 0.0,
            Region::Descending => 0.25,
            Region::SplenicFlexure => 0.4,
            Region::Transverse => 0.55,
            Region::HepaticFlexure => 0.6,
            Region::Ascending => 0.75,
            Region::Caecum => 1.0,
        }
    }

    /// Haustral fold strength in [0, 1].
    fn haustra(self) -> f64 {
        match self {
            Region::Rectum => 0.0,
            Region::Sigmoid => 0.6,
            _ => 1.0,
        }
    }
}

/// The template: waypoints of a 1.5 m adult colon (mm, patient frame) and the region that
/// starts at each waypoint, if any.
const TEMPLATE: [([f64; 3], Option<Region>); 47] = [
    ([0.0, 0.0, 0.0], Some(Region::Rectum)),               // 0
    ([0.0, -15.0, 40.0], None),                            // 1
    ([0.0, -35.0, 80.0], None),                            // 2
    ([0.0, -40.0, 120.0], None),                           // 3
    ([-5.0, -30.0, 160.0], Some(Region::Sigmoid)),         // 4
    ([-20.0, -10.0, 195.0], None),                         // 5
    ([-45.0, 12.0, 218.0], None),                          // 6
    ([-61.0, 42.0, 238.0], None),                          // 7
    ([-61.0, 81.0, 248.0], None),                          // 8
    ([-35.0, 112.0, 253.0], None),                         // 9
    ([5.0, 119.0, 250.0], None),                           // 10
    ([41.0, 99.0, 240.0], None),                           // 11
    ([70.0, 70.0, 227.0], None),                           // 12
    ([100.0, 40.0, 212.0], None),                          // 13
    ([118.0, 10.0, 203.0], None),                          // 14
    ([131.0, -20.0, 207.0], None),                         // 15
    ([138.0, -45.0, 225.0], None),                         // 16
    ([140.0, -60.0, 258.0], Some(Region::Descending)),     // 17
    ([139.0, -62.0, 298.0], None),                         // 18
    ([135.0, -55.0, 340.0], None),                         // 19
    ([128.0, -44.0, 385.0], None),                         // 20
    ([122.0, -36.0, 420.0], Some(Region::SplenicFlexure)), // 21
    ([114.0, -14.0, 447.0], None),                         // 22
    ([104.0, 16.0, 457.0], None),                          // 23
    ([93.0, 46.0, 450.0], None),                           // 24
    ([82.0, 68.0, 428.0], None),                           // 25
    ([72.0, 78.0, 400.0], Some(Region::Transverse)),       // 26
    ([60.0, 90.0, 372.0], None),                           // 27
    ([42.0, 101.0, 354.0], None),                          // 28
    ([20.0, 106.0, 344.0], None),                          // 29
    ([-5.0, 108.0, 340.0], None),                          // 30
    ([-30.0, 106.0, 344.0], None),                         // 31
    ([-52.0, 101.0, 354.0], None),                         // 32
    ([-70.0, 92.0, 372.0], None),                          // 33
    ([-82.0, 88.0, 400.0], Some(Region::HepaticFlexure)),  // 34
    ([-95.0, 81.0, 433.0], None),                          // 35
    ([-108.0, 56.0, 458.0], None),                         // 36
    ([-118.0, 23.0, 467.0], None),                         // 37
    ([-127.0, -10.0, 458.0], None),                        // 38
    ([-133.0, -35.0, 433.0], None),                        // 39
    ([-137.0, -44.0, 400.0], Some(Region::Ascending)),     // 40
    ([-138.0, -50.0, 360.0], None),                        // 41
    ([-135.0, -50.0, 318.0], None),                        // 42
    ([-130.0, -44.0, 278.0], None),                        // 43
    ([-124.0, -34.0, 240.0], Some(Region::Caecum)),        // 44
    ([-121.0, -21.0, 212.0], None),                        // 45
    ([-119.0, -8.0, 188.0], None),                         // 46
];

/// Reference midline length of the template's scale, mm.
const REFERENCE_MM: f64 = 1500.0;

/// A generated colon with what the generator knows about it.
#[derive(Debug, Clone)]
pub struct GeneratedColon {
    pub tube: Tube,
    /// Arc length of each ring, mm (ring `i` at `i * ring_spacing`).
    pub arc: Vec<f32>,
    /// Each region with the arc length where it starts, in order.
    pub regions: Vec<(Region, f32)>,
    /// Which candidate was kept (1 = the first); 0 when the template was used.
    pub attempt: u32,
    /// Smallest midline bend radius over the local lumen radius.
    pub min_bend_ratio: f32,
    /// Smallest wall-to-wall gap between loops, mm (on the midline-and-radius envelope).
    pub min_wall_gap_mm: f32,
    /// What each of [`ColonParams::tight_bends`] became, in order.
    pub tight_bends: Vec<TightBendReport>,
    /// What [`ColonParams::sigmoid_loop`] became.
    pub sigmoid_loop: Option<LoopReport>,
    /// The spokes shortened where ring planes cross inside the lumen ([`Tube::unfold`]): none
    /// unless a bend is tighter than the lumen.
    pub folds: FoldReport,
}

/// A tight bend as generated (the generator's own measures, on its dense midline).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TightBendReport {
    /// The window replaced, arc from the anus, mm.
    pub window_mm: [f32; 2],
    /// The arc's middle, mm from the anus.
    pub at_mm: f32,
    /// The arc's bend radius, mm.
    pub radius_mm: f32,
    /// Smallest bend radius over the largest lumen radius in the window (below 1: ring planes
    /// cross inside the lumen).
    pub ratio: f32,
    /// How far the midline turns over the window, degrees.
    pub turn_deg: f32,
}

/// A sigmoid loop as generated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopReport {
    /// Where its one revolution starts and ends, arc from the anus, mm.
    pub arc_mm: [f32; 2],
    /// The midline's total turning over the revolution (the integral of its curvature), degrees.
    pub turn_deg: f32,
    /// Smallest wall-to-wall gap between its two passes (the midline within 40 mm of the
    /// revolution's start against the midline within 40 mm of its end), mm, on the
    /// midline-and-radius envelope.
    pub pass_gap_mm: f32,
}

impl GeneratedColon {
    /// The region holding arc length `s`.
    pub fn region_at(&self, s: f32) -> Region {
        let mut r = self.regions[0].0;
        for &(reg, start) in &self.regions {
            if s >= start {
                r = reg;
            }
        }
        r
    }
}

/// Generates the colon for `params` (see the module docs).
///
/// # Panics
/// If a parameter is out of range: length or spacing not positive, fewer than 2 or more than
/// 65,536 rings, spokes outside 3..=256, radii not `0 < min <= max`.
pub fn generate(params: &ColonParams) -> Tube {
    generate_detailed(params).tube
}

/// Uniform cubic B-spline span through `w[i-1..=i+2]` at `u`: position and derivative.
fn bspline(w: &[V3d], i: usize, u: f64) -> (V3d, V3d) {
    let (p0, p1, p2, p3) = (w[i], w[i + 1], w[i + 2], w[i + 3]);
    let u2 = u * u;
    let u3 = u2 * u;
    let pos = (p0 * (1.0 - u).powi(3) + p1 * (3.0 * u3 - 6.0 * u2 + 4.0) + p2 * (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) + p3 * u3) / 6.0;
    let der = (p0 * (-3.0 * (1.0 - u) * (1.0 - u)) + p1 * (9.0 * u2 - 12.0 * u) + p2 * (-9.0 * u2 + 6.0 * u + 3.0) + p3 * (3.0 * u2)) / 6.0;
    (pos, der)
}

/// Dense samples of the spline through `way` (phantom end points make it start and end at the
/// first and last waypoint with zero curvature): positions, tangents, arc, and the arc length
/// nearest each waypoint.
struct Dense {
    pos: Vec<V3d>,
    tan: Vec<V3d>,
    arc: Vec<f64>,
    way_arc: Vec<f64>,
}

const PER_SPAN: usize = 256;

fn dense(way: &[V3d]) -> Dense {
    let m = way.len();
    let mut w = Vec::with_capacity(m + 2);
    w.push(way[0] * 2.0 - way[1]);
    w.extend_from_slice(way);
    w.push(way[m - 1] * 2.0 - way[m - 2]);
    let mut pos = Vec::new();
    let mut tan = Vec::new();
    for i in 0..m - 1 {
        for j in 0..PER_SPAN {
            let (p, d) = bspline(&w, i, j as f64 / PER_SPAN as f64);
            pos.push(p);
            tan.push(d.normalize());
        }
    }
    let (p, d) = bspline(&w, m - 2, 1.0);
    pos.push(p);
    tan.push(d.normalize());
    let arc = arc_lengths(&pos);
    // The B-spline passes near waypoint k at parameter k (span k, u = 0).
    let way_arc = (0..m).map(|k| arc[(k * PER_SPAN).min(pos.len() - 1)]).collect();
    Dense { pos, tan, arc, way_arc }
}

/// Radius model of one colon: everything `R(s, theta)` needs.
struct RadiusModel {
    lo: f64,
    span: f64,
    fold: f64,
    sector: f64,
    /// (start arc, region)
    regions: Vec<(f64, Region)>,
    haustra_spacing: f64,
    seed: u64,
    taenia_phase: f64,
}

const BLEND_MM: f64 = 40.0;

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl RadiusModel {
    /// A region property blended smoothly over `BLEND_MM` around each boundary.
    fn blended(&self, s: f64, f: impl Fn(Region) -> f64) -> f64 {
        let mut v = f(self.regions[0].1);
        for w in self.regions.windows(2) {
            let (start, reg) = w[1];
            let t = smoothstep((s - (start - BLEND_MM / 2.0)) / BLEND_MM);
            v = v * (1.0 - t) + f(reg) * t;
        }
        v
    }

    fn taenia_angle(&self, s: f64) -> f64 {
        self.taenia_phase + 0.4 * (TAU * s / 700.0).sin()
    }

    /// Lumen radius at arc `s`, angle `theta` from the frame's normal towards its binormal.
    fn radius(&self, s: f64, theta: f64) -> f64 {
        let base = self.blended(s, Region::level);
        let haustra = self.blended(s, Region::haustra);
        let rel = (theta - self.taenia_angle(s)).rem_euclid(TAU);
        // Rounded triangle: narrowest at the three taeniae (cos(3 rel) = 1 there).
        let sector = -(3.0 * rel).cos();
        // Fold window between taeniae: zero at the taeniae.
        let window = (1.5 * rel).sin().powi(2);
        let j = (rel / (TAU / 3.0)).floor() as i64;
        let h = self.haustra_spacing;
        let phase = s / h - j as f64 / 3.0;
        let nearest = phase.round();
        let mut fold = 0.0;
        for n in [nearest - 1.0, nearest, nearest + 1.0] {
            let jitter = 0.3 * (hash_unit(self.seed, n as i64 as u64, j as u64) - 0.5);
            let d = (phase - n - jitter) * h;
            let half = 0.3 * h;
            if d.abs() < half {
                fold = f64::max(fold, 0.5 * (1.0 + (PI * d / half).cos()));
            }
        }
        self.lo + self.fold + self.sector + base * (self.span - self.fold - 2.0 * self.sector) + self.sector * sector - self.fold * haustra * window * fold
    }

    /// Largest radius at `s` over all angles (an envelope for the clearance check).
    fn max_radius(&self, s: f64) -> f64 {
        let base = self.blended(s, Region::level);
        self.lo + self.fold + self.sector + base * (self.span - self.fold - 2.0 * self.sector) + self.sector
    }
}

struct Candidate {
    pos: Vec<V3d>,
    tan: Vec<V3d>,
    arc: Vec<f64>,
    regions: Vec<(f64, Region)>,
    /// The arcs of a sigmoid loop's revolution.
    loop_arc: Option<[f64; 2]>,
}

/// The waypoints a candidate starts from, and the roles of some of them in the jitter.
struct Template {
    way: Vec<V3d>,
    regions: Vec<Option<Region>>,
    /// The sigmoid loop's waypoints, scaled together by the seed.
    sig: Vec<usize>,
    /// Added to the template's indices of the transverse colon (the sag).
    shift: usize,
    /// First and last waypoint of a loop's revolution.
    loop_way: Option<[usize; 2]>,
    /// First and last waypoint that keep their shape under the seed's proportions.
    rigid: Option<[usize; 2]>,
}

impl Template {
    /// [`TEMPLATE`], or with its sigmoid (waypoints 5 to 18) replaced by `sl`'s loop.
    fn new(sl: Option<&SigmoidLoop>) -> Self {
        let v = |p: [f64; 3]| V3d::new(p[0], p[1], p[2]);
        let Some(sl) = sl else {
            return Self { way: TEMPLATE.iter().map(|(p, _)| v(*p)).collect(), regions: TEMPLATE.iter().map(|(_, r)| *r).collect(), sig: (6..=12).collect(), shift: 0, loop_way: None, rigid: None };
        };
        let (mut way, mut regions): (Vec<V3d>, Vec<Option<Region>>) = TEMPLATE[..=4].iter().map(|(p, r)| (v(*p), *r)).unzip();
        // The revolution starts at the rectosigmoid junction (waypoint 4), heading up, and winds
        // about an axis along x (a waypoint every 30 degrees), drifting `pitch` to the left.
        let start = way[4];
        let [r_loop, r_exit] = sl.radius_mm.map(|r| r as f64);
        let pitch = sl.pitch_mm as f64;
        let (yc, zc) = (start.y + r_loop, start.z);
        let first = way.len() - 1;
        let c = pitch / TAU;
        let helix = |phi: f64| V3d::new(start.x + c * phi, yc - r_loop * phi.cos(), zc + r_loop * phi.sin());
        for k in 1..=13 {
            way.push(helix(k as f64 * PI / 6.0));
            regions.push(None);
        }
        // Then a bend of radius `r_exit` turning the heading 65 degrees towards the left, and one
        // of 50 mm turning it up (and a little posterior) into the descending colon (template
        // waypoint 19 on); a waypoint every 13 degrees.
        let phi = 13.0 * PI / 6.0;
        let mut at = way[way.len() - 1];
        let mut heading = V3d::new(c, r_loop * phi.sin(), r_loop * phi.cos()).normalize();
        // A circular bend from `at` turning `heading` by `angle` towards `toward`.
        fn bend(at: &mut V3d, heading: &mut V3d, toward: V3d, angle: f64, r: f64, way: &mut Vec<V3d>, regions: &mut Vec<Option<Region>>) {
            let n = (toward - *heading * toward.dot(heading)).normalize();
            let steps = (angle / 13f64.to_radians()).ceil().max(1.0) as usize;
            for j in 1..=steps {
                let psi = angle * j as f64 / steps as f64;
                way.push(*at + (*heading * psi.sin() + n * (1.0 - psi.cos())) * r);
                regions.push(None);
            }
            *at = way[way.len() - 1];
            *heading = *heading * angle.cos() + n * angle.sin();
        }
        bend(&mut at, &mut heading, V3d::new(1.0, -0.7, 0.0), 55f64.to_radians(), r_exit, &mut way, &mut regions);
        let up = V3d::new(-0.15, -0.25, 1.0).normalize();
        let angle = heading.dot(&up).clamp(-1.0, 1.0).acos();
        bend(&mut at, &mut heading, up, angle, 50.0, &mut way, &mut regions);
        *regions.last_mut().expect("exit waypoints") = Some(Region::Descending);
        let last = way.len() - 1;
        let shift = way.len() - 19;
        way.extend(TEMPLATE[19..].iter().map(|(p, _)| v(*p)));
        regions.extend(TEMPLATE[19..].iter().map(|(_, r)| *r));
        // No seeded scale of the loop: its radii and pitch are the parameters'.
        Self { way, regions, sig: Vec::new(), shift, loop_way: Some([first, first + 12]), rigid: Some([first, last]) }
    }
}

/// Builds a candidate midline (dense, scaled to `length`).
fn candidate(length: f64, jitter: f64, rng: Option<&mut Rng>, template: &Template) -> Candidate {
    let scale0 = length / REFERENCE_MM;
    let mut way = template.way.clone();
    if let Some(rng) = rng {
        // Global variation: sigmoid loop size, transverse sag, body proportions.
        let sig = &template.sig;
        let c = sig.iter().map(|&k| way[k]).sum::<V3d>() / sig.len().max(1) as f64;
        let loop_scale = rng.range(0.9, 1.1);
        for &k in sig {
            way[k] = c + (way[k] - c) * loop_scale;
        }
        let sag = rng.range(-15.0, 15.0);
        for (k, w) in [(27usize, 0.3), (28, 0.6), (29, 0.9), (30, 1.0), (31, 0.9), (32, 0.6), (33, 0.3)] {
            way[k + template.shift].z += sag * w;
        }
        let aniso = V3d::new(rng.range(0.95, 1.05), rng.range(0.95, 1.05), rng.range(0.95, 1.05));
        for w in way.iter_mut() {
            *w = w.component_mul(&aniso);
        }

        // A smooth random displacement field along the waypoints: Fourier modes with amplitude
        // falling as 1/m, so neighbouring waypoints move together and bends stay round.
        let m_count = way.len() as f64;
        let modes: Vec<(f64, V3d, V3d)> = (1..=8)
            .map(|m| {
                let mut v = || V3d::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                (m as f64, v(), v())
            })
            .collect();
        // Each mode's expected squared size is 1 / m^2: scale the sum to an RMS of `jitter`.
        let rms = modes.iter().map(|(m, _, _)| 1.0 / (m * m)).sum::<f64>().sqrt();
        for (k, w) in way.iter_mut().enumerate() {
            let x = PI * k as f64 / (m_count - 1.0);
            let mut d = V3d::zeros();
            for (m, a, b) in &modes {
                d += (a * (m * x).sin() + b * (m * x).cos()) / *m;
            }
            // The anus stays at the origin.
            let ramp = (k as f64 / 3.0).min(1.0);
            *w += d * (jitter * ramp / rms);
        }
        // A loop keeps its shape: it moves as a whole, by the mean of its waypoints' moves.
        if let Some([a, b]) = template.rigid {
            let moved = (a..=b).map(|k| way[k] - template.way[k]).sum::<V3d>() / (b - a + 1) as f64;
            for (w, t) in way[a..=b].iter_mut().zip(&template.way[a..=b]) {
                *w = t + moved;
            }
        }
    }
    for w in way.iter_mut() {
        *w *= scale0;
    }
    let d = dense(&way);
    let k = length / d.arc[d.arc.len() - 1];
    let pos = d.pos.iter().map(|p| p * k).collect();
    let arc = d.arc.iter().map(|a| a * k).collect();
    let regions = template.regions.iter().zip(&d.way_arc).filter_map(|(r, &a)| r.map(|r| (a * k, r))).collect();
    let loop_arc = template.loop_way.map(|w| w.map(|i| d.way_arc[i] * k));
    Candidate { pos, tan: d.tan, arc, regions, loop_arc }
}

/// What [`check`] measures of a candidate.
struct Checks {
    /// Smallest bend ratio outside the tight bends' windows.
    ratio: f64,
    /// Smallest wall gap, pairs beside one tight bend left out.
    gap: f64,
    /// Smallest bend ratio in each tight bend's window.
    tight: Vec<f64>,
    /// A loop's turning (degrees) and the gap between its passes.
    loop_turn_deg: f64,
    loop_gap: f64,
}

/// Bend ratio and wall gap of a candidate, on samples every `step` mm, the bend check waived in
/// the `windows` of its tight bends and the gap check between two samples both within `margin`
/// of one window; with the measures of its tight bends and its loop.
fn check(c: &Candidate, rm: &RadiusModel, step: f64, windows: &[[f64; 2]], margin: f64) -> Checks {
    let total = c.arc[c.arc.len() - 1];
    let n = (total / step).floor() as usize + 1;
    let s: Vec<f64> = (0..n).map(|i| i as f64 * step).collect();
    let p: Vec<V3d> = s.iter().map(|&x| at_arc(&c.pos, &c.arc, x)).collect();
    let r: Vec<f64> = s.iter().map(|&x| rm.max_radius(x)).collect();
    // Which windows each sample is within `margin` of, as bits.
    let near: Vec<u64> = s.iter().map(|&x| windows.iter().enumerate().filter(|(_, w)| x >= w[0] - margin && x <= w[1] + margin).fold(0, |m, (k, _)| m | 1 << k.min(63))).collect();
    let mut gap = f64::INFINITY;
    for i in 0..n {
        for j in i + 1..n {
            if s[j] - s[i] <= (1.5 * (r[i] + r[j])).max(40.0) || near[i] & near[j] != 0 {
                continue;
            }
            gap = gap.min((p[i] - p[j]).norm() - r[i] - r[j]);
        }
    }
    // Bend radius from the dense tangents: |dt/ds| over a short window.
    let mut ratio = f64::INFINITY;
    let mut tight = vec![f64::INFINITY; windows.len()];
    let h = 2.0;
    for i in 0..n {
        let (a, b) = (s[i] - h, s[i] + h);
        if a < 0.0 || b > total {
            continue;
        }
        let ta = at_arc(&c.tan, &c.arc, a).normalize();
        let tb = at_arc(&c.tan, &c.arc, b).normalize();
        let kappa = 2.0 * (0.5 * (ta - tb).norm()).asin() / (b - a);
        if kappa > 0.0 {
            let q = 1.0 / kappa / r[i];
            match windows.iter().position(|w| s[i] >= w[0] && s[i] <= w[1]) {
                Some(w) => tight[w] = tight[w].min(q),
                None => ratio = ratio.min(q),
            }
        }
    }
    let (mut loop_turn_deg, mut loop_gap) = (0.0, f64::INFINITY);
    if let Some([s0, s1]) = c.loop_arc {
        let (i0, i1) = (c.arc.partition_point(|&a| a < s0), c.arc.partition_point(|&a| a <= s1));
        loop_turn_deg = c.tan[i0..i1].windows(2).map(|w| w[0].normalize().dot(&w[1].normalize()).clamp(-1.0, 1.0).acos()).sum::<f64>().to_degrees();
        let reach = 40.0 * rm.span / 15.0;
        for i in (0..n).filter(|&i| (s[i] - s0).abs() <= reach) {
            for j in (0..n).filter(|&j| (s[j] - s1).abs() <= reach) {
                loop_gap = loop_gap.min((p[i] - p[j]).norm() - r[i] - r[j]);
            }
        }
    }
    Checks { ratio, gap, tight, loop_turn_deg, loop_gap }
}

/// A tight bend as built, before the candidate's checks.
struct Tightened {
    window: [f64; 2],
    at: f64,
    radius: f64,
    turn_deg: f64,
}

/// Gathers each tight bend's turning into its arc (see [`TightBend`]), then scales the midline
/// back to `length`; `None` if a window turns less than [`MIN_TIGHT_TURN_DEG`] or cannot hold
/// its arc. `scale0` is the template's scale (`length / 1500 mm`).
fn tighten(mut c: Candidate, bends: &[TightBend], rm: &RadiusModel, scale0: f64, length: f64) -> Option<(Candidate, Vec<Tightened>)> {
    if bends.is_empty() {
        return Some((c, Vec::new()));
    }
    // From the far end, so the arcs of the windows still to do stay where they were.
    let mut order: Vec<usize> = (0..bends.len()).collect();
    order.sort_by(|&i, &j| bends[j].at_mm.total_cmp(&bends[i].at_mm));
    let mut done: Vec<(usize, Tightened)> = Vec::new();
    for &bi in &order {
        let tb = &bends[bi];
        let total = c.arc[c.arc.len() - 1];
        let (a, b) = ((tb.at_mm - tb.half_window_mm) as f64 * scale0, (tb.at_mm + tb.half_window_mm) as f64 * scale0);
        if !(a > 0.0 && b < total && a < b) {
            return None;
        }
        let (pa, pb) = (at_arc(&c.pos, &c.arc, a), at_arc(&c.pos, &c.arc, b));
        let (ta, tbn) = (at_arc(&c.tan, &c.arc, a).normalize(), at_arc(&c.tan, &c.arc, b).normalize());
        let cos = ta.dot(&tbn).clamp(-1.0, 1.0);
        let theta = cos.acos();
        if theta.to_degrees() < MIN_TIGHT_TURN_DEG {
            return None;
        }
        let steps = ((b - a) / 0.5).ceil() as usize;
        let biggest = (0..=steps).map(|k| rm.max_radius(a + (b - a) * k as f64 / steps as f64)).fold(0.0, f64::max);
        let rho = tb.ratio as f64 * biggest;
        // Straight along ta for l1, the arc, straight along tb for l2: the arc's chord is
        // m (ta + tb); what is left of the window's chord out of the plane of ta, tb is e.
        let m = rho * (0.5 * theta).tan();
        let d = pb - pa - (ta + tbn) * m;
        let det = 1.0 - cos * cos;
        let (da, db) = (d.dot(&ta), d.dot(&tbn));
        let l1 = (da - cos * db) / det;
        let l2 = (db - cos * da) / det;
        let e = d - ta * l1 - tbn * l2;
        let least = 0.1 * (b - a);
        if !(l1 >= least && l2 >= least && e.norm() <= 0.5 * l1.min(l2)) {
            return None;
        }
        let nrm = (tbn - ta * cos).normalize();
        let ds = c.arc[1] - c.arc[0];
        let mut pos = Vec::new();
        let mut tan = Vec::new();
        // The out-of-plane rest: 0 to e/2 over the first run, e/2 along the arc, to e over the second.
        let leg = |l: f64, from: V3d, t: V3d, w0: f64, pos: &mut Vec<V3d>, tan: &mut Vec<V3d>, last: bool| {
            let k = (l / ds).ceil().max(1.0) as usize;
            for j in 0..k + usize::from(last) {
                let u = j as f64 / k as f64;
                pos.push(from + t * (l * u) + e * (w0 + 0.5 * smoothstep(u)));
                tan.push((t + e * (0.5 * 6.0 * u * (1.0 - u) / l)).normalize());
            }
        };
        leg(l1, pa, ta, 0.0, &mut pos, &mut tan, false);
        let p1 = pa + ta * l1;
        let k = ((rho * theta) / ds).ceil().max(1.0) as usize;
        for j in 0..k {
            let phi = theta * j as f64 / k as f64;
            pos.push(p1 + ta * (rho * phi.sin()) + nrm * (rho * (1.0 - phi.cos())) + e * 0.5);
            tan.push(ta * phi.cos() + nrm * phi.sin());
        }
        let p2 = p1 + (ta + tbn) * m;
        leg(l2, p2, tbn, 0.5, &mut pos, &mut tan, true);
        let (ia, ib) = (c.arc.partition_point(|&s| s < a), c.arc.partition_point(|&s| s <= b));
        let added = pos.len();
        let mut p = c.pos[..ia].to_vec();
        p.extend(pos);
        p.extend_from_slice(&c.pos[ib..]);
        let mut t = c.tan[..ia].to_vec();
        t.extend(tan);
        t.extend_from_slice(&c.tan[ib..]);
        let arc = arc_lengths(&p);
        // The window's new length, from the first old point after it.
        let delta = match arc.get(ia + added) {
            Some(&s) => s - c.arc[ib],
            None => arc[arc.len() - 1] - c.arc[c.arc.len() - 1],
        };
        let new_len = b - a + delta;
        let remap = |s: f64| {
            if s <= a {
                s
            } else if s >= b {
                s + delta
            } else {
                a + (s - a) * new_len / (b - a)
            }
        };
        c.arc = arc;
        c.pos = p;
        c.tan = t;
        for r in c.regions.iter_mut() {
            r.0 = remap(r.0);
        }
        c.loop_arc = c.loop_arc.map(|w| w.map(remap));
        for (_, t) in done.iter_mut() {
            t.window = t.window.map(remap);
            t.at = remap(t.at);
        }
        done.push((bi, Tightened { window: [a, a + new_len], at: a + l1 + 0.5 * rho * theta, radius: rho, turn_deg: theta.to_degrees() }));
    }
    let k = length / c.arc[c.arc.len() - 1];
    c.pos.iter_mut().for_each(|p| *p *= k);
    c.arc.iter_mut().for_each(|s| *s *= k);
    c.regions.iter_mut().for_each(|r| r.0 *= k);
    c.loop_arc = c.loop_arc.map(|w| w.map(|s| s * k));
    done.sort_by_key(|(i, _)| *i);
    Some((c, done.into_iter().map(|(_, t)| Tightened { window: t.window.map(|s| s * k), at: t.at * k, radius: t.radius * k, turn_deg: t.turn_deg }).collect()))
}

/// [`generate`], with the arc of each ring, the regions and the checks.
///
/// # Panics
/// As [`generate`], and if the unperturbed template (the fallback) cannot hold a tight bend.
pub fn generate_detailed(params: &ColonParams) -> GeneratedColon {
    let length = params.length_mm as f64;
    let spacing = params.ring_spacing as f64;
    assert!(length.is_finite() && length > 0.0, "length_mm must be > 0, got {}", params.length_mm);
    assert!(spacing.is_finite() && spacing > 0.0, "ring_spacing must be > 0, got {}", params.ring_spacing);
    let rings = (length / spacing + 1e-9).floor() as usize + 1;
    assert!((2..=65_536).contains(&rings), "{rings} rings (length {length} mm / spacing {spacing} mm); 2 to 65,536 are allowed");
    assert!((3..=256).contains(&params.spokes), "{} spokes; 3 to 256 are allowed", params.spokes);
    let [rmin, rmax] = params.radius_mm.map(|r| r as f64);
    assert!(rmin > 0.0 && rmin <= rmax && rmax.is_finite(), "radius_mm must satisfy 0 < min <= max, got {:?}", params.radius_mm);
    let shrink = (length / REFERENCE_MM).min(1.0);
    let scale0 = length / REFERENCE_MM;
    let (lo, hi) = (rmin * shrink, rmax * shrink);
    let span = hi - lo;
    let fold = (params.haustra_depth_mm as f64 * shrink).clamp(0.0, 0.3 * span);
    let sector = 0.1 * span;
    let jitter = params.jitter_mm.max(0.0) as f64;
    let template = Template::new(params.sigmoid_loop.as_ref());

    let make_rm = |regions: &[(f64, Region)]| RadiusModel {
        lo,
        span,
        fold,
        sector,
        regions: regions.to_vec(),
        haustra_spacing: (params.haustra_spacing_mm as f64 * shrink).max(1e-3),
        seed: params.seed,
        taenia_phase: hash_unit(params.seed, 0x7a, 0) * TAU,
    };
    let step = (2.0 * shrink).max(spacing.min(2.0));
    let min_gap = MIN_WALL_GAP_MM * shrink;
    // The tight bends, and the checks of a candidate that has them.
    let build = |c: Candidate| -> Option<(Candidate, RadiusModel, Vec<Tightened>, Checks)> {
        let rm = make_rm(&c.regions);
        let (c, tight) = tighten(c, &params.tight_bends, &rm, scale0, length)?;
        let rm = make_rm(&c.regions);
        let windows: Vec<[f64; 2]> = tight.iter().map(|t| t.window).collect();
        let checks = check(&c, &rm, step, &windows, 40.0 * shrink);
        Some((c, rm, tight, checks))
    };
    let passes = |k: &Checks| {
        let looped = params.sigmoid_loop.is_none() || (k.loop_turn_deg >= MIN_LOOP_TURN_DEG && k.loop_gap >= min_gap && k.loop_gap <= MAX_LOOP_PASS_GAP_MM * shrink);
        k.ratio >= MIN_BEND_RATIO && k.gap >= min_gap && looped
    };

    let mut rng = Rng::new(params.seed, 0xC0_10_4E);
    let mut chosen = None;
    for attempt in 1..=MAX_ATTEMPTS {
        if let Some(b) = build(candidate(length, jitter, Some(&mut rng), &template)).filter(|b| passes(&b.3)) {
            chosen = Some((b, attempt));
            break;
        }
    }
    let ((c, rm, tight, checks), attempt) = chosen.unwrap_or_else(|| (build(candidate(length, 0.0, None, &template)).expect("the unperturbed template holds the tight bends"), 0));
    let (ratio, gap) = (checks.ratio, checks.gap);

    // Rings every `spacing` along the arc, with a rotation-minimising frame.
    let arc: Vec<f64> = (0..rings).map(|i| i as f64 * spacing).collect();
    let pts: Vec<V3d> = arc.iter().map(|&s| at_arc(&c.pos, &c.arc, s)).collect();
    let tan: Vec<V3d> = arc
        .iter()
        .map(|&s| {
            let (i, u) = locate_arc(&c.arc, s);
            (c.tan[i] * (1.0 - u) + c.tan[(i + 1).min(c.tan.len() - 1)] * u).normalize()
        })
        .collect();
    // Start the frame with n pointing anterior-ish (y), so angles are comparable across seeds.
    let n0 = {
        let t = tan[0];
        let y = V3d::y();
        (y - t * y.dot(&t)).try_normalize(1e-6).unwrap_or_else(|| any_perpendicular(t))
    };
    let nrm = rotation_minimising(&pts, &tan, n0);
    let b = params.spokes;
    let mut radial = Vec::with_capacity(rings * b);
    for i in 0..rings {
        let bin = tan[i].cross(&nrm[i]);
        for k in 0..b {
            let a = TAU * k as f64 / b as f64;
            let dir = nrm[i] * a.cos() + bin * a.sin();
            let r = params.narrowings.iter().fold(rm.radius(arc[i], a), |r, n| n.apply(arc[i], r));
            radial.push(lumen_import::geom::f3(dir * r));
        }
    }
    let points = pts.into_iter().map(lumen_import::geom::f3).collect();
    let mut tube = Tube::new(points, radial, b).expect("generated colon is a valid tube");
    let folds = tube.unfold();
    GeneratedColon {
        tube,
        folds,
        arc: arc.iter().map(|&a| a as f32).collect(),
        regions: c.regions.iter().map(|&(a, r)| (r, a as f32)).collect(),
        attempt,
        min_bend_ratio: ratio as f32,
        min_wall_gap_mm: gap as f32,
        tight_bends: tight
            .iter()
            .zip(&checks.tight)
            .map(|(t, &q)| TightBendReport { window_mm: t.window.map(|s| s as f32), at_mm: t.at as f32, radius_mm: t.radius as f32, ratio: q as f32, turn_deg: t.turn_deg as f32 })
            .collect(),
        sigmoid_loop: c.loop_arc.map(|w| LoopReport { arc_mm: w.map(|s| s as f32), turn_deg: checks.loop_turn_deg as f32, pass_gap_mm: checks.loop_gap as f32 }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn template_passes_its_own_checks() {
        for length in [500.0, 1500.0, 3000.0] {
            let c = candidate(length, 0.0, None, &Template::new(None));
            let shrink = (length / REFERENCE_MM).min(1.0);
            let span = 15.0 * shrink;
            let rm = RadiusModel { lo: 20.0 * shrink, span, fold: (4.0 * shrink).min(0.3 * span), sector: 0.1 * span, regions: c.regions.clone(), haustra_spacing: 30.0, seed: 0, taenia_phase: 0.0 };
            let Checks { ratio, gap, .. } = check(&c, &rm, 2.0 * shrink, &[], 0.0);
            eprintln!("template at {length} mm: bend ratio {ratio:.2}, wall gap {gap:.1} mm");
            assert!(ratio >= MIN_BEND_RATIO, "bend ratio {ratio}");
            assert!(gap >= MIN_WALL_GAP_MM * shrink, "wall gap {gap}");
        }
    }

    #[test]
    fn the_variants_templates_pass_their_own_checks() {
        // The fallback after MAX_ATTEMPTS: the unperturbed template must hold the variants.
        let rm_of = |c: &Candidate| RadiusModel { lo: 20.0, span: 15.0, fold: 4.0, sector: 1.5, regions: c.regions.clone(), haustra_spacing: 30.0, seed: 0, taenia_phase: 0.0 };
        let c = candidate(1500.0, 0.0, None, &Template::new(Some(&crate::SIGMOID_LOOP)));
        let k = check(&c, &rm_of(&c), 2.0, &[], 0.0);
        eprintln!("loop template: bend ratio {:.2}, wall gap {:.1} mm, turning {:.1} degrees, passes {:.1} mm apart", k.ratio, k.gap, k.loop_turn_deg, k.loop_gap);
        assert!(k.ratio >= MIN_BEND_RATIO && k.gap >= MIN_WALL_GAP_MM && k.loop_turn_deg >= MIN_LOOP_TURN_DEG && (MIN_WALL_GAP_MM..=MAX_LOOP_PASS_GAP_MM).contains(&k.loop_gap));
        let c = candidate(1500.0, 0.0, None, &Template::new(None));
        let rm = rm_of(&c);
        let (c, tight) = tighten(c, &crate::TIGHT_BENDS, &rm, 1.0, 1500.0).expect("the template holds the tight bends");
        let windows: Vec<[f64; 2]> = tight.iter().map(|t| t.window).collect();
        let k = check(&c, &rm_of(&c), 2.0, &windows, 40.0);
        eprintln!("tight-bend template: bend ratio {:.2} outside, {:?} inside; wall gap {:.1} mm", k.ratio, k.tight, k.gap);
        assert!(k.ratio >= MIN_BEND_RATIO && k.gap >= MIN_WALL_GAP_MM && k.tight.iter().all(|&q| q < 0.8));
    }
}
