//! A tube model from a triangle surface and a midline, by ray casting.

use crate::geom::{any_perpendicular, arc_lengths, at_arc, f3, rotation_minimising, smooth_along, tangents, V3d};
use crate::{Centerline, ImportError, Mesh};
use lumen_detect::Tube;
use parry3d::math::Vector;
use parry3d::query::{Ray, RayCast};
use parry3d::shape::TriMesh;
use std::collections::HashMap;
use std::fmt;

/// Parameters of [`build_tube`]. Lengths in the mesh's unit (mm for the GCA colon).
#[derive(Debug, Clone, PartialEq)]
pub struct ImportParams {
    /// Radial vectors per ring (default 32).
    pub spokes: usize,
    /// Arc length between rings (default 1 mm).
    pub ring_spacing: f32,
    /// Factor on every radial vector (default 1; 2 turns the collapsed CT lumen of the GCA colon
    /// into an insufflated one).
    pub inflate: f32,
    /// Gaussian smoothing of the midline's tangents along the arc, sigma (default 4 mm): CT
    /// midlines are noisy, and ring planes follow the tangents. The narrowest width the import
    /// tries; it may choose a wider one ([`crate::slice`]).
    pub tangent_smoothing_mm: f32,
    /// Gaussian smoothing of the midline's points, sigma (default 1 mm).
    pub point_smoothing_mm: f32,
    /// The widest tangent smoothing the import tries for the ring planes (default 64 mm; equal
    /// to `tangent_smoothing_mm`, the planes follow that one smoothing: [`crate::slice`]).
    pub widest_smoothing_mm: f32,
    /// The wall's 99th-percentile distance to the surface (before inflation) the import aims
    /// for, in the mesh's unit: where the wall at `spokes` lies farther, it casts again with
    /// [`SPOKES_STEP`] more spokes a ring, up to [`MAX_AUTO_SPOKES`], and keeps the truest
    /// ([`ImportReport::spokes_tried`]). 0 (the default): `spokes` as given (`lumen import
    /// --fidelity`).
    pub fidelity_mm: f32,
}

/// Spokes a ring the import adds at each try for [`ImportParams::fidelity_mm`].
pub const SPOKES_STEP: usize = 8;

/// Most spokes a ring the import raises to for [`ImportParams::fidelity_mm`]: each try casts the
/// whole colon again (about 20 s for the GCA colon at 40 spokes), and the detector's cost per
/// sample grows with the spokes it reads.
pub const MAX_AUTO_SPOKES: usize = 64;

impl Default for ImportParams {
    fn default() -> Self {
        Self { spokes: 32, ring_spacing: 1.0, inflate: 1.0, tangent_smoothing_mm: 4.0, point_smoothing_mm: 1.0, widest_smoothing_mm: crate::slice::WIDEST as f32, fidelity_mm: 0.0 }
    }
}

impl ImportParams {
    /// Checks every parameter; the error names the one that is wrong and what it must be.
    pub fn validate(&self) -> Result<(), ImportError> {
        let max = lumen_detect::proto::limits::MAX_SPOKES;
        if !(3..=max).contains(&self.spokes) {
            return Err(ImportError::Param { name: "spokes", value: self.spokes.to_string(), expected: format!("3 to {max}") });
        }
        for (name, v) in [("ring_spacing", self.ring_spacing), ("inflate", self.inflate)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ImportError::Param { name, value: v.to_string(), expected: "a positive number".into() });
            }
        }
        for (name, v) in [("tangent_smoothing", self.tangent_smoothing_mm), ("point_smoothing", self.point_smoothing_mm)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ImportError::Param { name, value: v.to_string(), expected: "a number >= 0".into() });
            }
        }
        if !(self.fidelity_mm.is_finite() && self.fidelity_mm >= 0.0) {
            return Err(ImportError::Param { name: "fidelity", value: self.fidelity_mm.to_string(), expected: "a number >= 0 (0: the spokes as given)".into() });
        }
        let w = self.widest_smoothing_mm;
        if !(w.is_finite() && w >= self.tangent_smoothing_mm) {
            return Err(ImportError::Param { name: "widest_smoothing", value: w.to_string(), expected: format!("a number >= the tangent smoothing ({})", self.tangent_smoothing_mm) });
        }
        Ok(())
    }

    /// Lumen's parameters for the GCA colon (EdinGCA_3D_00090), used by the `gca` scene
    /// everywhere: 32 spokes every 1 mm, inflated [`GCA_INFLATE`] times, the default tangent
    /// smoothing (the import widens it where sections would cross).
    pub fn gca() -> Self {
        Self { spokes: 32, ring_spacing: 1.0, inflate: GCA_INFLATE, ..Self::default() }
    }
}

/// Inflation of the GCA colon: its CT lumen is collapsed, a colonoscopy's is insufflated.
pub const GCA_INFLATE: f32 = 2.0;

/// A ray whose hit is kept is never repaired; every other ray is counted here by why it was
/// rejected and by how it was replaced.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ImportReport {
    pub rings: usize,
    pub spokes: usize,
    /// Midline length used (mm).
    pub centerline_mm: f64,
    pub inflate: f64,
    /// Rays cast (`rings * spokes`).
    pub rays: usize,
    /// Rays whose first wall hit was kept.
    pub kept: usize,
    /// Rays that hit nothing.
    pub missed: usize,
    /// Rays whose first hit was a wall seen from outside (the midline point is outside the
    /// surface there, or two surfaces overlap). Only when the surface is oriented (`oriented`).
    pub from_outside: usize,
    /// Rays that reached a neighbouring loop (the hit is much nearer a part of the midline far
    /// along the arc than this ring's point, and that part sees it with no wall between: the
    /// colon touches itself and the surface has a gap).
    pub neighbouring_loop: usize,
    /// Rays jumping from the same spoke of both neighbouring rings (more than 1.8 times the
    /// larger, plus 2 mm), or in a run of at most a quarter turn that steps up that much from the
    /// spoke before it and back down to the spoke after it. A hit that is merely far above its
    /// ring's median (a midline off the lumen's centre, a pocket) is kept.
    pub outliers: usize,
    /// Repairs: interpolated from the nearest kept spokes of the same ring on both sides.
    pub interpolated: usize,
    /// Repairs: set to the ring's median (runs longer than a quarter turn, or no neighbours).
    pub clamped: usize,
    /// Rings with fewer than a quarter of their rays kept, whose median came from the nearest
    /// rings with enough.
    pub rings_borrowed: usize,
    /// Rings whose midline bends tighter than the lumen's radius on the inside of the bend (the
    /// centre of curvature lies inside the lumen, so neighbouring rings cross there). Not
    /// repaired; for information.
    pub tight_bends: usize,
    /// Spokes that reach past another ring's plane within that ring's reach, after inflation
    /// ([`Tube::folds`]): where the wall passes over itself. 0 unless the ring planes could not be
    /// fanned clear of the lumen ([`crate::slice`]); the quality gate refuses a model with any.
    pub folds: lumen_detect::model::FoldReport,
    /// The smoothing width of the ring planes' tangents the import chose (mm; see
    /// [`crate::slice`]), how many widths it tried, and the largest angle between a ring's
    /// plane normal and the midline's tangent at the import's own smoothing (degrees).
    pub smoothing_mm: f64,
    pub widths_tried: usize,
    pub max_tilt_deg: f64,
    /// Spokes whose tips still lay past another ring's plane inside its section, after the
    /// planes were chosen and the spokes inflated, shortened to just short of it
    /// ([`Tube::clip_folds`]; after the fidelity measure): where the bend is tighter than any
    /// tilt clears, or where inflated loops press on each other.
    pub clipped: lumen_detect::model::FoldReport,
    /// Spoke tips, after inflation and clipping, inside another part of the lumen, far along it
    /// ([`Tube::overlaps`]): loops inflated past the space between them, side by side, where
    /// no ring plane crosses another inside the lumen (so the fold check sees nothing). A point
    /// there lies in the sections of both parts. Reported, not refused: the real colon
    /// inflated twice and four times overlaps, and those are the wide lumens a simulator is
    /// tried on.
    pub overlaps: lumen_detect::model::OverlapReport,
    /// When spokes crossed on the given midline, the import also sliced the midline re-traced
    /// through the middle of the lumen ([`crate::axis`]) and kept the better of the two: what
    /// that try gave. `None`: nothing crossed, or no path could be traced.
    pub retraced: Option<Retraced>,
    /// Radial vector lengths after inflation: min, 5th percentile, median, 95th, max.
    pub radius_mm: [f64; 5],
    /// Whether at least 80% of first hits agree on which way the surface faces, so hits from
    /// outside can be told apart (`from_outside`).
    pub oriented: bool,
    /// Whether the surface faced its lumen (normals pointing at the midline) and was read
    /// flipped.
    pub flipped: bool,
    /// Fraction of first hits on triangles facing the majority's way (0.5 to 1).
    pub orientation_agreement: f64,
    /// Rays whose first wall has a second wall right behind it (within 2% of the hit's distance)
    /// or is a triangle written twice: a duplicated or double surface. Not repaired.
    pub doubled: usize,
    /// How far the midline's bounding box reaches beyond the surface's, in the surface's unit
    /// (0 when inside): a midline in other units than its surface reaches far out.
    pub midline_beyond_surface: f64,
    /// The surface's bounding-box diagonal, in its unit.
    pub surface_diagonal: f64,
    /// Rings where the midline's points turn back on themselves (by more than 120 degrees from
    /// one point to the next): points out of order, or a midline stitched from pieces.
    pub turns_back: Vec<usize>,
    /// The wall (before inflation) against the surface, in its unit.
    pub fidelity: crate::fidelity::Fidelity,
    /// Where the import raised the spokes for [`ImportParams::fidelity_mm`]: each count tried
    /// with its wall's p99 distance to the surface, in order (empty where the first was within
    /// the target or no target was set).
    pub spokes_tried: Vec<(usize, f64)>,
    /// The [`ImportParams::fidelity_mm`] the spokes were raised for (0 where they were not).
    pub fidelity_target: f64,
    /// Every ring's counts, in order along the midline, for naming where a problem lies.
    pub ring_tallies: Vec<RingTally>,
}

/// The re-traced axis replaces the given midline only when its wall's p99 distance to the
/// surface is less than the given one's divided by this: it moves every ring, and on the GCA
/// colon inflated four times, where both walls are about as true (0.57 and 0.52 mm) and it
/// clips fewer spokes, it let the scripted scope through the wall (11.9 mm) where the given
/// midline held it (1.4 mm).
pub const RETRACE_GAIN: f64 = 2.0;

/// The import's try of a midline re-traced through the lumen ([`crate::axis`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retraced {
    /// Whether the rings lie on it (else on the given midline).
    pub used: bool,
    /// Grid spacing of the path (mm).
    pub voxel_mm: f64,
    /// Gaussian smoothing along the path, median sigma (mm).
    pub smoothing_mm: f64,
    /// The slicing not kept: its wall's p99 distance to the surface (mm) and its spokes
    /// clipped.
    pub other_p99_mm: f64,
    pub other_clipped: usize,
}

/// One ring's rays by what became of them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RingTally {
    /// Rays repaired, whatever the cause.
    pub repaired: u16,
    /// Rays that hit nothing.
    pub missed: u16,
    /// Rays whose first hit was a wall seen from outside.
    pub from_outside: u16,
    /// Rays whose first wall was doubled.
    pub doubled: u16,
    /// Whether the ring borrowed its median from neighbouring rings.
    pub borrowed: bool,
}

impl RingTally {
    /// Whether the ring's midline point lies outside the surface: at least half its rays miss
    /// the surface or meet it from outside.
    pub fn outside(&self, spokes: usize) -> bool {
        2 * (self.missed as usize + self.from_outside as usize) >= spokes
    }
}

impl ImportReport {
    /// Rays repaired (all but the kept ones).
    pub fn repaired(&self) -> usize {
        self.rays - self.kept
    }

    /// What a model file stores of this import ([`lumen_detect::model::ImportInfo`]): the
    /// fidelity and this report's text.
    pub fn info(&self) -> lumen_detect::model::ImportInfo {
        let w = &self.fidelity;
        lumen_detect::model::ImportInfo { fidelity_mm: [w.p50, w.p99, w.max], kept_p99_mm: w.kept_p99, samples: w.samples as u64, report: self.to_string() }
    }

    /// Repaired fraction of all rays.
    pub fn repaired_fraction(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            self.repaired() as f64 / self.rays as f64
        }
    }
}

impl fmt::Display for ImportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [r0, r5, r50, r95, r100] = self.radius_mm;
        write!(
            f,
            "Imported {} rings x {} spokes along {:.1} mm of midline ({} rays), radii x{}: {} rays kept their first wall hit and {} ({:.2}%) were repaired: {} missed the surface, {} hit a neighbouring loop, {} were outliers against their neighbouring rings or spokes{}; {} were interpolated from the nearest kept spokes of their ring and {} clamped to their ring's median, and {} rings borrowed their median from neighbouring rings. Radius min / p5 / median / p95 / max: {:.1} / {:.1} / {:.1} / {:.1} / {:.1} mm. {} rings lie in bends tighter than the lumen's radius on their inner side; {}.",
            self.rings,
            self.spokes,
            self.centerline_mm,
            self.rays,
            self.inflate,
            self.kept,
            self.repaired(),
            100.0 * self.repaired_fraction(),
            self.missed,
            self.neighbouring_loop,
            self.outliers,
            if self.oriented {
                format!(", {} hit a wall from outside", self.from_outside)
            } else {
                format!(" (the surface faces both ways: {:.0}% of first hits agree on its side, so hits from outside were not told apart)", 100.0 * self.orientation_agreement)
            },
            self.interpolated,
            self.clamped,
            self.rings_borrowed,
            r0,
            r5,
            r50,
            r95,
            r100,
            self.tight_bends,
            match self.folds.ring_range {
                None => format!(
                    "no spoke reaches past another ring's plane inside its section: ring planes follow the midline's tangent smoothed over {:.1} mm (of {} widths tried; up to {:.0} degrees off the tangent), and {} spokes of {} rings were clipped short of a crossing (by up to {:.1} mm, {:.0}% of a spoke)",
                    self.smoothing_mm,
                    self.widths_tried,
                    self.max_tilt_deg,
                    self.clipped.spokes,
                    self.clipped.rings,
                    self.clipped.max_cut,
                    100.0 * self.clipped.max_cut_fraction
                ),
                Some((a, z)) => format!(
                    "{} spokes of {} rings (rings {a}-{z}) reach past another ring's plane inside its section, by up to {:.1} mm ({:.0}% of a spoke)",
                    self.folds.spokes,
                    self.folds.rings,
                    self.folds.max_cut,
                    100.0 * self.folds.max_cut_fraction
                ),
            }
        )?;
        let w = &self.fidelity;
        write!(
            f,
            " Wall (before inflation) to surface, p50 / p99 / max: {:.2} / {:.2} / {:.2} mm over {} points; p99 {:.2} mm over the {} drawn between kept spokes only.",
            w.p50,
            w.p99,
            w.max,
            w.samples,
            w.kept_p99,
            w.samples - w.near_repaired
        )?;
        match &self.retraced {
            Some(r) if r.used => write!(f, " The rings lie on the midline re-traced through the middle of the lumen ({:.1} mm grid, smoothed over {:.1} mm): on the given midline the wall lay {:.2} mm from the surface at p99, with {} spokes clipped.", r.voxel_mm, r.smoothing_mm, r.other_p99_mm, r.other_clipped)?,
            Some(r) => write!(f, " The rings lie on the given midline: re-traced through the middle of the lumen ({:.1} mm grid, smoothed over {:.1} mm), its wall lay {:.2} mm from the surface at p99 with {} spokes clipped, not under half the given one's.", r.voxel_mm, r.smoothing_mm, r.other_p99_mm, r.other_clipped)?,
            None => {}
        }
        if !self.spokes_tried.is_empty() {
            let tried: Vec<String> = self.spokes_tried.iter().map(|(b, p99)| format!("{b} ({p99:.2} mm)")).collect();
            write!(f, " Spokes a ring raised for a wall within {:.2} mm of the surface at p99: {}; kept {}.", self.fidelity_target, tried.join(", "), self.spokes)?;
        }
        let o = &self.overlaps;
        if o.tips > 0 {
            write!(f, " {} spoke tips of {} rings lie inside another part of the lumen, up to {} rings along it: loops side by side overlap (inflated past the space between them), and a point there lies in two sections.", o.tips, o.rings, o.farthest)?;
        } else {
            write!(f, " No spoke tip lies inside another part of the lumen.")?;
        }
        if self.flipped {
            write!(f, " The surface's normals faced its lumen; it was read flipped.")?;
        }
        if self.doubled > 0 {
            write!(f, " {} rays met a doubled wall (a second surface right behind the first, or a triangle written twice).", self.doubled)?;
        }
        Ok(())
    }
}

/// A ray's first wall hit: its distance, whether the triangle's normal faces away from the ray's
/// origin, and whether a second wall lies right behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FirstHit {
    t: f64,
    away: bool,
    doubled: bool,
}

/// Triangles whose three corners another triangle has too (in any order or winding): a surface
/// written twice over itself.
fn duplicated_triangles(mesh: &Mesh) -> std::collections::HashSet<u32> {
    let key = |t: &[u32; 3]| {
        let mut c = t.map(|i| mesh.vertices[i as usize].map(f32::to_bits));
        c.sort();
        c
    };
    let mut first: HashMap<[[u32; 3]; 3], u32> = HashMap::with_capacity(mesh.triangles.len());
    let mut dup = std::collections::HashSet::new();
    for (n, t) in mesh.triangles.iter().enumerate() {
        let m = *first.entry(key(t)).or_insert(n as u32);
        if m != n as u32 {
            dup.insert(m);
            dup.insert(n as u32);
        }
    }
    dup
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Ray1 {
    Hit(f64),
    Missed,
    Outside,
    Neighbour,
    Outlier,
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let x = q * (sorted.len() - 1) as f64;
    let (i, u) = (x.floor() as usize, x - x.floor());
    sorted[i] * (1.0 - u) + sorted[(i + 1).min(sorted.len() - 1)] * u
}

/// Whether the wall point `h` is in sight of `p`: the surface's first hit on the way from `p`
/// to `h` is `h` itself (within [`SIGHT`] of the way), not a wall in between.
fn sees(surface: &TriMesh, p: V3d, h: V3d) -> bool {
    let d = h - p;
    let len = d.norm();
    if len < 1e-9 {
        return true;
    }
    let u = d / len;
    let ray = Ray::new(Vector::new(p.x as f32, p.y as f32, p.z as f32), Vector::new(u.x as f32, u.y as f32, u.z as f32));
    surface.cast_local_ray(&ray, ((1.0 - SIGHT) * len) as f32, false).is_none()
}

/// Uniform grid over the ring points, for "which rings are within `r` of this point".
struct Grid {
    cell: f64,
    map: HashMap<(i32, i32, i32), Vec<u32>>,
}

impl Grid {
    fn new(points: &[V3d], cell: f64) -> Self {
        let mut map: HashMap<(i32, i32, i32), Vec<u32>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            map.entry(Self::key(p, cell)).or_default().push(i as u32);
        }
        Self { cell, map }
    }
    fn key(p: &V3d, cell: f64) -> (i32, i32, i32) {
        ((p.x / cell).floor() as i32, (p.y / cell).floor() as i32, (p.z / cell).floor() as i32)
    }
    /// Calls `f` with every ring within `r` of `p` (and maybe a few more).
    fn near(&self, p: &V3d, r: f64, mut f: impl FnMut(u32) -> bool) -> bool {
        let (lo, hi) = (Self::key(&(p - V3d::repeat(r)), self.cell), Self::key(&(p + V3d::repeat(r)), self.cell));
        for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                for z in lo.2..=hi.2 {
                    if let Some(v) = self.map.get(&(x, y, z)) {
                        for &i in v {
                            if f(i) {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }
}

const JUMP_FACTOR: f64 = 1.8;
const JUMP_MM: f64 = 2.0;
/// A hit belongs to a neighbouring loop if a midline point more than
/// `max(NEIGHBOUR_ARC_MM, t)` along the arc is nearer to it than `NEIGHBOUR_RATIO t` (`t` = hit
/// distance). On a smooth bend of radius above `t` no midline point is nearer to an own-wall hit
/// than `t`, whatever its arc; below that the rings cross inside the lumen anyway. The midline
/// point must also see the hit ([`sees`]): a loop that merely passes behind the ring's own wall
/// (the wall between them) is not reached by the ray.
const NEIGHBOUR_ARC_MM: f64 = 20.0;
const NEIGHBOUR_RATIO: f64 = 0.75;
/// A wall point is in sight of a midline point when the surface has nothing on the way to it
/// short of this fraction of the way.
const SIGHT: f64 = 0.02;
/// A second wall behind a ray's first hit, closer than this fraction of the hit's distance,
/// makes the hit a doubled wall.
const DOUBLE_WALL: f64 = 0.02;
/// Turn (radians) of a ray cast again after slipping through an edge between triangles.
const EDGE_NUDGE: f64 = 1e-4;
/// Cosine of the turn (120 degrees) between consecutive midline steps that counts as turning
/// back.
const TURN_BACK_COS: f64 = -0.5;
/// The surface is oriented when at least this fraction of first hits agree on which way it faces.
const ORIENTED_AGREEMENT: f64 = 0.8;

/// Builds a tube from a closed triangle surface and a midline inside it (see the module docs
/// of [`crate`]): rings every `ring_spacing` along the (lightly smoothed) midline, a
/// rotation-minimising frame on smoothed tangents, `spokes` rays per ring in its plane
/// (counter-clockwise about the tangent, spoke 0 along the frame's normal), the first wall hit
/// of each kept, the others repaired and counted in the [`ImportReport`], all scaled by
/// `inflate`. Where spokes still cross on the given midline (and it never turns back), the midline re-traced through the
/// middle of the lumen ([`crate::axis`]) is sliced too and replaces it when its wall is more
/// than [`RETRACE_GAIN`] times truer ([`ImportReport::retraced`]).
///
/// With [`ImportParams::fidelity_mm`] set, where that wall lies farther from the surface at p99,
/// the whole import again with [`SPOKES_STEP`] more spokes, up to [`MAX_AUTO_SPOKES`]: the
/// truest is kept.
pub fn build_tube(mesh: &Mesh, centerline: &Centerline, params: &ImportParams) -> Result<(Tube, ImportReport), ImportError> {
    let (tube, mut report) = build_raised(mesh, centerline, params)?;
    report.overlaps = tube.overlaps();
    Ok((tube, report))
}

/// [`build_tube`] but for the overlap count: the spokes raised for [`ImportParams::fidelity_mm`].
fn build_raised(mesh: &Mesh, centerline: &Centerline, params: &ImportParams) -> Result<(Tube, ImportReport), ImportError> {
    let mut best = build_sliced(mesh, centerline, params)?;
    let target = params.fidelity_mm as f64;
    if target <= 0.0 || best.1.fidelity.p99 <= target {
        return Ok(best);
    }
    let mut tried = vec![(params.spokes, best.1.fidelity.p99)];
    let mut spokes = params.spokes;
    while best.1.fidelity.p99 > target && spokes + SPOKES_STEP <= MAX_AUTO_SPOKES {
        spokes += SPOKES_STEP;
        let next = build_sliced(mesh, centerline, &ImportParams { spokes, ..params.clone() })?;
        tried.push((spokes, next.1.fidelity.p99));
        if next.1.fidelity.p99 < best.1.fidelity.p99 {
            best = next;
        }
    }
    best.1.spokes_tried = tried;
    best.1.fidelity_target = target;
    Ok(best)
}

/// [`build_tube`] at `params.spokes`.
fn build_sliced(mesh: &Mesh, centerline: &Centerline, params: &ImportParams) -> Result<(Tube, ImportReport), ImportError> {
    let (tube, report) = build_along(mesh, centerline, params)?;
    // Sections still crossed on the given midline: try the one re-traced through the lumen,
    // unless the given one runs back on itself (points out of order: the gate says so, and a
    // path between its ends might not be the colon it meant).
    if report.clipped.spokes == 0 || !report.turns_back.is_empty() {
        return Ok((tube, report));
    }
    let given: Vec<V3d> = centerline.points.iter().map(|&p| crate::geom::d3(p)).collect();
    let reach = report.radius_mm[4] / report.inflate.max(1e-9);
    let voxel = (report.radius_mm[2] / report.inflate.max(1e-9) / 10.0).clamp(1.0, 2.0);
    let Some(axis) = crate::axis::retrace(mesh, &given, voxel, reach) else {
        return Ok((tube, report));
    };
    let line = Centerline { points: axis.points.iter().map(|&p| f3(p)).collect(), s: None, radius_median: None };
    let Ok((tube2, report2)) = build_along(mesh, &line, params) else {
        return Ok((tube, report));
    };
    // The re-traced axis moves every ring: it is kept only where it makes an untrue wall true.
    let used = report2.fidelity.p99 * RETRACE_GAIN < report.fidelity.p99;
    let (mut kept, other) = if used { ((tube2, report2), report) } else { ((tube, report), report2) };
    kept.1.retraced = Some(Retraced { used, voxel_mm: axis.voxel_mm, smoothing_mm: axis.smoothing_mm, other_p99_mm: other.fidelity.p99, other_clipped: other.clipped.spokes });
    Ok(kept)
}

/// [`build_tube`] on the midline as given.
fn build_along(mesh: &Mesh, centerline: &Centerline, params: &ImportParams) -> Result<(Tube, ImportReport), ImportError> {
    params.validate()?;
    let b = params.spokes;
    let spacing = params.ring_spacing as f64;
    let inflate = params.inflate as f64;
    if mesh.triangles.is_empty() {
        return Err(ImportError::Invalid("the surface has no triangles".into()));
    }
    // Midline: drop repeated points, smooth, resample.
    let mut raw: Vec<V3d> = Vec::with_capacity(centerline.points.len());
    for p in &centerline.points {
        let q = crate::geom::d3(*p);
        if raw.last().is_none_or(|l: &V3d| (l - q).norm() > 1e-9) {
            raw.push(q);
        }
    }
    if raw.len() < 2 {
        return Err(ImportError::Invalid("the midline needs at least 2 distinct points".into()));
    }
    let raw_arc = arc_lengths(&raw);
    let length = raw_arc[raw_arc.len() - 1];
    let mut turns_back: Vec<usize> = Vec::new();
    for j in 1..raw.len() - 1 {
        let (a, c) = (raw[j] - raw[j - 1], raw[j + 1] - raw[j]);
        if a.dot(&c) < TURN_BACK_COS * a.norm() * c.norm() {
            let ring = (raw_arc[j] / spacing).round() as usize;
            if turns_back.last() != Some(&ring) {
                turns_back.push(ring);
            }
        }
    }
    let rings = (length / spacing + 1e-9).floor() as usize + 1;
    if !(2..=65_536).contains(&rings) {
        return Err(ImportError::Invalid(format!("{rings} rings ({length:.3} mm of midline every {spacing} mm); 2 to 65,536 are allowed (are the files in mm? lumen import --units converts)")));
    }
    let smooth = smooth_along(&raw, &raw_arc, params.point_smoothing_mm as f64);
    let pts: Vec<V3d> = (0..rings).map(|i| at_arc(&smooth, &raw_arc, i as f64 * spacing)).collect();
    let arc = arc_lengths(&pts);
    let tan = tangents(&pts, &arc, params.tangent_smoothing_mm as f64);
    let s_nominal: Vec<f64> = (0..rings).map(|i| i as f64 * spacing).collect();

    // Surface.
    let verts: Vec<Vector> = mesh.vertices.iter().map(|v| Vector::new(v[0], v[1], v[2])).collect();
    let nv = verts.len() as u32;
    if let Some(t) = mesh.triangles.iter().find(|t| t.iter().any(|&i| i >= nv)) {
        return Err(ImportError::Invalid(format!("triangle {t:?} refers to a vertex beyond the {nv} given")));
    }
    let duplicates = duplicated_triangles(mesh);
    let trimesh = TriMesh::new(verts, mesh.triangles.clone()).map_err(|e| ImportError::Invalid(format!("surface: {e:?}")))?;
    let (lo, hi) = mesh.bounds();
    let diag = (0..3).map(|d| (hi[d] as f64 - lo[d] as f64).powi(2)).sum::<f64>().sqrt();

    // Cast: every ray's first hit, which way that triangle faces, and whether a second wall lies
    // right behind it.
    let cast_ring = |o: V3d, normal: V3d, dirs: &[V3d], out: &mut [Option<FirstHit>]| {
        for k in 0..b {
            // A ray through a shared edge or vertex can slip between the triangles (parry's test
            // is not watertight): a miss is cast again, turned a hair about the plane's normal.
            let cast = |d: V3d| {
                let ray = Ray::new(Vector::new(o.x as f32, o.y as f32, o.z as f32), Vector::new(d.x as f32, d.y as f32, d.z as f32));
                trimesh.cast_local_ray_and_get_normal(&ray, (2.0 * diag) as f32, false).map(|h| (ray, h))
            };
            let d = dirs[k];
            let side = normal.cross(&d);
            out[k] = None;
            let Some((ray, hit)) = cast(d).or_else(|| cast((d + side * EDGE_NUDGE).normalize())).or_else(|| cast((d - side * EDGE_NUDGE).normalize())) else {
                continue;
            };
            let t = hit.time_of_impact as f64;
            let tri = trimesh.triangle(hit.subshape);
            let n = (tri.b - tri.a).cross(tri.c - tri.a);
            let away = n.x as f64 * d.x + n.y as f64 * d.y + n.z as f64 * d.z > 0.0;
            // A second wall within DOUBLE_WALL of the first, behind it: a duplicated or
            // double-sided surface.
            let h = o + d * t;
            let behind = h + d * (1e-4 * t.max(1e-9));
            let again = Ray::new(Vector::new(behind.x as f32, behind.y as f32, behind.z as f32), ray.dir);
            let doubled = trimesh.cast_local_ray(&again, (DOUBLE_WALL * t) as f32, false).is_some() || duplicates.contains(&hit.subshape);
            out[k] = Some(FirstHit { t, away, doubled });
        }
    };
    let ring_dirs = |normal: V3d, e1: V3d| -> Vec<V3d> {
        let e2 = normal.cross(&e1);
        (0..b)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / b as f64;
                e1 * a.cos() + e2 * a.sin()
            })
            .collect()
    };
    // The whole tube sliced at each width of the ladder (crate::slice), each finished as a
    // candidate: the wall truest to the surface, and of those the fewest spokes clipped.
    let base = (params.tangent_smoothing_mm as f64).max(0.0);
    let ladder = crate::slice::ladder(base, spacing, params.widest_smoothing_mm as f64);
    let slice_at = |w: f64| {
        let normal = tangents(&pts, &arc, w);
        let e1 = rotation_minimising(&pts, &normal, any_perpendicular(normal[0]));
        let dirs: Vec<Vec<V3d>> = (0..rings).map(|i| ring_dirs(normal[i], e1[i])).collect();
        let mut hits: Vec<Option<FirstHit>> = vec![None; rings * b];
        for i in 0..rings {
            cast_ring(pts[i], normal[i], &dirs[i], &mut hits[i * b..(i + 1) * b]);
        }
        (normal, dirs, hits)
    };
    // What every slicing shares: which rings lie near a wall point, how far the midline reaches
    // beyond the surface.
    let grid = Grid::new(&pts, 8.0f64.max(2.0 * spacing));
    let (mlo, mhi) =
        (centerline.points.iter().fold([f32::INFINITY; 3], |a, p| [0, 1, 2].map(|d| a[d].min(p[d]))), centerline.points.iter().fold([f32::NEG_INFINITY; 3], |a, p| [0, 1, 2].map(|d| a[d].max(p[d]))));
    let midline_beyond_surface = (0..3).map(|d| (lo[d] - mlo[d]).max(mhi[d] - hi[d]).max(0.0) as f64).fold(0.0, f64::max);
    let finish = |w: f64, normal: &[V3d], dirs: &[Vec<V3d>], hits: &[Option<FirstHit>]| -> Result<(Tube, ImportReport), ImportError> {
        // Orientation relative to the midline: from inside the lumen the wall's outward normal faces
        // away from the ray's origin. The majority of first hits says which way the surface faces;
        // the rays that see the other side hit a wall from outside, unless the surface faces both
        // ways too often to tell.
        let seen = hits.iter().flatten().count();
        let away = hits.iter().flatten().filter(|h| h.away).count();
        let flipped = 2 * away < seen;
        let agree = if seen == 0 { 0.0 } else { away.max(seen - away) as f64 / seen as f64 };
        let oriented = seen > 0 && agree >= ORIENTED_AGREEMENT;
        let mut cls = vec![Ray1::Missed; rings * b];
        for i in 0..rings {
            for k in 0..b {
                let Some(hit) = hits[i * b + k] else { continue };
                let t = hit.t;
                cls[i * b + k] = if oriented && hit.away == flipped {
                    Ray1::Outside
                } else {
                    let h = pts[i] + dirs[i][k] * t;
                    let reach = NEIGHBOUR_ARC_MM.max(t);
                    let r = NEIGHBOUR_RATIO * t;
                    let foreign = grid.near(&h, r, |j| {
                        let j = j as usize;
                        (s_nominal[j] - s_nominal[i]).abs() > reach && (pts[j] - h).norm() < r && sees(&trimesh, pts[j], h)
                    });
                    if foreign {
                        Ray1::Neighbour
                    } else {
                        Ray1::Hit(t)
                    }
                };
            }
        }
        // Outliers: jumps against both neighbouring rings. (Not hits merely far above the ring's
        // median: where the midline runs off the lumen's centre, or past a pocket, the far wall is
        // continuous with its neighbours and is the ring's own; repairing it put the GCA colon's
        // wall 2 to 12 mm off its surface there.)
        let raw_t = |i: usize, k: usize, c: &[Ray1]| match c[i * b + k] {
            Ray1::Hit(t) => Some(t),
            _ => None,
        };
        let snapshot = cls.clone();
        for i in 1..rings.saturating_sub(1) {
            for k in 0..b {
                if let (Some(t), Some(p), Some(n)) = (raw_t(i, k, &snapshot), raw_t(i - 1, k, &snapshot), raw_t(i + 1, k, &snapshot)) {
                    if t > JUMP_FACTOR * p.max(n) + JUMP_MM {
                        cls[i * b + k] = Ray1::Outlier;
                    }
                }
            }
        }
        // Angular steps: a run of at most a quarter turn of spokes that steps up from its ring's
        // neighbouring spoke and back down again (a ray bundle through a gap into another lumen).
        for i in 0..rings {
            let ts: Vec<Option<f64>> = (0..b).map(|k| raw_t(i, k, &cls)).collect();
            let steep = |hi: f64, lo: f64| hi > JUMP_FACTOR * lo + JUMP_MM;
            for start in 0..b {
                let prev = (start + b - 1) % b;
                let (Some(t0), Some(tp)) = (ts[start], ts[prev]) else { continue };
                if !steep(t0, tp) {
                    continue;
                }
                // Find the step back down within a quarter turn.
                for len in 1..=b / 4 {
                    let last = (start + len - 1) % b;
                    let next = (start + len) % b;
                    let (Some(tl), Some(tn)) = (ts[last], ts[next]) else { break };
                    if steep(tl, tn) {
                        for d in 0..len {
                            cls[i * b + (start + d) % b] = Ray1::Outlier;
                        }
                        break;
                    }
                }
            }
        }
        let enough = (b / 4).max(3);
        let mut medians: Vec<f64> = (0..rings)
            .map(|i| {
                let mut v: Vec<f64> = (0..b).filter_map(|k| raw_t(i, k, &cls)).collect();
                if v.len() >= enough {
                    median(&mut v)
                } else {
                    f64::NAN
                }
            })
            .collect();
        let doubled = hits.iter().flatten().filter(|h| h.doubled).count();
        let mut report = ImportReport {
            rings,
            spokes: b,
            centerline_mm: length,
            inflate,
            rays: rings * b,
            oriented,
            flipped: oriented && flipped,
            orientation_agreement: agree,
            doubled,
            midline_beyond_surface,
            surface_diagonal: diag,
            turns_back: turns_back.clone(),
            ring_tallies: vec![RingTally::default(); rings],
            ..Default::default()
        };
        for (n, h) in hits.iter().enumerate() {
            if h.is_some_and(|h| h.doubled) {
                report.ring_tallies[n / b].doubled += 1;
            }
        }
        // Rings without enough hits borrow the nearest good median.
        let mut all: Vec<f64> = cls.iter().filter_map(|c| if let Ray1::Hit(t) = c { Some(*t) } else { None }).collect();
        let global = median(&mut all);
        let good = medians.clone();
        for i in 0..rings {
            if good[i].is_nan() {
                report.rings_borrowed += 1;
                report.ring_tallies[i].borrowed = true;
                let mut found = f64::NAN;
                for d in 1..rings {
                    let cands = [i.checked_sub(d), (i + d < rings).then_some(i + d)];
                    let vals: Vec<f64> = cands.iter().flatten().map(|&j| good[j]).filter(|x| !x.is_nan()).collect();
                    if !vals.is_empty() {
                        found = vals.iter().sum::<f64>() / vals.len() as f64;
                        break;
                    }
                }
                medians[i] = if found.is_nan() {
                    if global.is_nan() {
                        1.0
                    } else {
                        global
                    }
                } else {
                    found
                };
            }
        }
        // Repair and build.
        let mut radial = Vec::with_capacity(rings * b);
        let mut lengths = Vec::with_capacity(rings * b);
        for i in 0..rings {
            let ts: Vec<Option<f64>> = (0..b).map(|k| raw_t(i, k, &cls)).collect();
            for k in 0..b {
                let t = match cls[i * b + k] {
                    Ray1::Hit(t) => {
                        report.kept += 1;
                        t
                    }
                    c => {
                        let tally = &mut report.ring_tallies[i];
                        tally.repaired += 1;
                        match c {
                            Ray1::Missed => {
                                report.missed += 1;
                                tally.missed += 1;
                            }
                            Ray1::Outside => {
                                report.from_outside += 1;
                                tally.from_outside += 1;
                            }
                            Ray1::Neighbour => report.neighbouring_loop += 1,
                            _ => report.outliers += 1,
                        }
                        let before = (1..b).find_map(|d| ts[(k + b - d) % b].map(|t| (d, t)));
                        let after = (1..b).find_map(|d| ts[(k + d) % b].map(|t| (d, t)));
                        match (before, after) {
                            (Some((d0, t0)), Some((d1, t1))) if d0 + d1 - 1 <= b / 4 => {
                                report.interpolated += 1;
                                t0 + (t1 - t0) * d0 as f64 / (d0 + d1) as f64
                            }
                            _ => {
                                report.clamped += 1;
                                medians[i]
                            }
                        }
                    }
                };
                let r = t * inflate;
                lengths.push(r);
                radial.push(f3(dirs[i][k] * r));
            }
        }
        // Bends tighter than the ring: the inner wall further from the midline than the centre of
        // curvature, so neighbouring rings cross inside the lumen.
        for i in 1..rings.saturating_sub(1) {
            let ds = arc[i + 1] - arc[i - 1];
            if ds <= 0.0 {
                continue;
            }
            let kv = (tan[i + 1] - tan[i - 1]) / ds;
            let kv = kv - tan[i] * kv.dot(&tan[i]);
            let kappa = kv.norm();
            if kappa < 1e-12 {
                continue;
            }
            let spokes: Vec<V3d> = (0..b).map(|k| dirs[i][k] * lengths[i * b + k]).collect();
            let inner = crate::probe::section_radius(&spokes, tan[i], 1.0, kv / kappa);
            if kappa * inner > 1.0 {
                report.tight_bends += 1;
            }
        }
        let mut sorted = lengths.clone();
        sorted.sort_by(f64::total_cmp);
        report.radius_mm = [0.0, 0.05, 0.5, 0.95, 1.0].map(|q| quantile(&sorted, q));
        let mut tube = Tube::new(pts.iter().map(|&p| f3(p)).collect(), radial, b).map_err(|e| ImportError::Invalid(format!("imported tube: {e}")))?;
        let repaired: Vec<bool> = cls.iter().map(|c| !matches!(c, Ray1::Hit(_))).collect();
        report.fidelity = crate::fidelity::wall_to_surface(&tube, params.inflate, &trimesh, &repaired);
        report.clipped = tube.clip_folds();
        report.folds = tube.folds();
        report.smoothing_mm = w;
        report.max_tilt_deg = (0..rings).map(|i| normal[i].dot(&tan[i]).clamp(-1.0, 1.0).acos().to_degrees()).fold(0.0, f64::max);
        Ok((tube, report))
    };
    let mut candidates: Vec<(Tube, ImportReport)> = Vec::with_capacity(ladder.len());
    for &w in &ladder {
        let (normal, dirs, hits) = slice_at(w);
        let (tube, report) = finish(w, &normal, &dirs, &hits)?;
        let clean = report.clipped.spokes == 0;
        candidates.push((tube, report));
        if clean {
            break;
        }
    }
    let fidelity: Vec<f64> = candidates.iter().map(|(_, r)| r.fidelity.p99).collect();
    let clipped: Vec<usize> = candidates.iter().map(|(_, r)| r.clipped.spokes).collect();
    let pick = crate::slice::pick(&fidelity, &clipped);
    let tried = candidates.len();
    let (tube, mut report) = candidates.swap_remove(pick);
    report.widths_tried = tried;
    Ok((tube, report))
}
