//! A seeded insufflated colon given as a **surface and a midline**, the class of colon that CT
//! brings and the tube generator ([`crate::colon`]) cannot: lumens wider than their bends.
//!
//! **Midline.** A chain of straight runs and circular arcs, from the anus (origin, heading
//! `+z`) to the caecum: the anal canal, the rectum, a rectosigmoid flexure in the plane, a
//! sigmoid hairpin out of it, the descending colon, the splenic flexure, the transverse colon,
//! the hepatic flexure and the ascending colon. Each arc's bend radius is a third to a half of
//! the lumen's radius there ([`BEND_RATIO`]), its plane rolled about the tangent (out of the
//! previous bend's plane by up to 90 degrees). The seed moves run lengths (x0.8 to 1.2), turns
//! (+-15 degrees), ratios and rolls; a candidate whose distant parts come nearer than their
//! radii plus 5 mm is redrawn (up to [`MAX_ATTEMPTS`], then the template, which passes).
//!
//! **Lumen.** Radius `R(s)` between [`SurfaceParams::radius_mm`] (default 25 to 50 mm, narrow
//! in the rectum, widest in the caecum), blended smoothly between runs; an anal canal of
//! [`SurfaceParams::canal_radius_mm`] (default 3.25 mm, half a 13 mm scope's radius) over its
//! first 30 mm; elliptical sections (minor/major 0.65 to 0.95, the axes turning slowly);
//! haustral folds every [`SurfaceParams::fold_spacing_mm`] from the sigmoid on, semilunar (three
//! lobes between the taeniae), [`SurfaceParams::fold_depth`] (default 30%) of the radius deep.
//!
//! **Surface.** The lumen is the union of thin elliptical discs centred on the midline, one
//! every 0.5 mm (0.2 mm in bends): disc `i`, centre `c`, frame `(e1, e2, t)`, axes `a >= b`,
//! half-thickness `h = 5 mm`, holds the points where
//! `Q = sqrt(((u/a)^2 + (v/b)^2) / k(theta)^2 + (w/h)^2) <= 1`, with `(u, v, w)` the point's
//! coordinates in the frame and `k = 1 - fold(theta)` the haustral narrowing. The surface is the
//! zero level set of `min_i (Q_i - 1) b k`, meshed by surface nets ([`crate::nets`]) on a grid
//! of [`SurfaceParams::voxel_mm`]. A union never passes through itself: where a bend is tighter
//! than the lumen, the discs overlap on its inner side and the wall there is the envelope of
//! the outermost ones, as a CT surface is, while the sections a swept tube would use cross.

use crate::nets::{self, Grid};
use crate::rng::Rng;
use lumen_detect::Tube;
use lumen_import::geom::V3d;
use lumen_import::{Centerline, ImportError, ImportParams, ImportReport, Mesh};
use std::f64::consts::PI;

/// Bend radius of the flexures and the hairpin as a fraction of the lumen's radius there: the
/// seed draws in this range.
pub const BEND_RATIO: [f64; 2] = [1.0 / 3.0, 0.5];
/// Candidates tried per seed before the template.
pub const MAX_ATTEMPTS: u32 = 32;
/// Half-thickness of the discs (mm).
const DISC_HALF_MM: f64 = 5.0;

/// Parameters of [`generate`]. Lengths in millimetres.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceParams {
    /// The seed: equal parameters and seed give identical surfaces and midlines.
    pub seed: u64,
    /// Smallest and largest lumen radius outside the anal canal (default 25 and 50 mm).
    pub radius_mm: [f32; 2],
    /// Radius of the anal canal over the first 30 mm (default 3.25 mm).
    pub canal_radius_mm: f32,
    /// Depth of the haustral folds as a fraction of the radius (default 0.3).
    pub fold_depth: f32,
    /// Spacing of the haustral folds along the midline (default 35 mm).
    pub fold_spacing_mm: f32,
    /// Grid spacing of the surface mesh (default 1.5 mm).
    pub voxel_mm: f32,
}

impl Default for SurfaceParams {
    fn default() -> Self {
        Self { seed: 1, radius_mm: [25.0, 50.0], canal_radius_mm: 3.25, fold_depth: 0.3, fold_spacing_mm: 35.0, voxel_mm: 1.5 }
    }
}

/// A parameter of [`SurfaceParams`] out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name} = {value}: must be {expected}")]
pub struct ParamError {
    /// The field, as the command line names it (`radius`, `canal_radius`, ...).
    pub name: &'static str,
    pub value: String,
    pub expected: &'static str,
}

impl SurfaceParams {
    /// The defaults with `seed`.
    pub fn seeded(seed: u64) -> Self {
        Self { seed, ..Self::default() }
    }

    /// Checks every parameter; the error names the one that is wrong and what it must be.
    pub fn validate(&self) -> Result<(), ParamError> {
        let [lo, hi] = self.radius_mm;
        if !(lo.is_finite() && hi.is_finite() && 5.0 <= lo && lo <= hi && hi <= 100.0) {
            return Err(ParamError { name: "radius", value: format!("{lo},{hi}"), expected: "two radii in mm, 5 <= min <= max <= 100" });
        }
        let checks: [(&'static str, f32, bool, &'static str); 4] = [
            ("canal_radius", self.canal_radius_mm, (1.0..=lo).contains(&self.canal_radius_mm), "from 1 mm to the smallest radius"),
            ("fold_depth", self.fold_depth, (0.0..=0.5).contains(&self.fold_depth), "a fraction from 0 to 0.5"),
            ("fold_spacing", self.fold_spacing_mm, (10.0..=200.0).contains(&self.fold_spacing_mm), "from 10 to 200 mm"),
            ("voxel", self.voxel_mm, (0.25..=3.0).contains(&self.voxel_mm) && self.voxel_mm <= self.canal_radius_mm, "from 0.25 to 3 mm, at most the canal's radius"),
        ];
        match checks.into_iter().find(|c| !c.2) {
            Some((name, v, _, expected)) => Err(ParamError { name, value: v.to_string(), expected }),
            None => Ok(()),
        }
    }
}

/// One flexure or hairpin of the midline, as generated.
#[derive(Debug, Clone, PartialEq)]
pub struct Bend {
    /// What it is in the anatomy.
    pub name: &'static str,
    /// Arc length of the midline at the bend's middle (mm).
    pub at_mm: f64,
    /// How far the midline turns (degrees).
    pub turn_deg: f64,
    /// Bend radius of the midline (mm).
    pub radius_mm: f64,
    /// Lumen radius (the ellipse's major half-axis, before folds) at the bend's middle (mm).
    pub lumen_mm: f64,
    /// Angle between this bend's plane and the previous one's (degrees; 0 for the first).
    pub roll_deg: f64,
}

/// A generated colon surface with its midline.
#[derive(Debug, Clone)]
pub struct SurfaceColon {
    /// The wall, closed at both ends (mm).
    pub mesh: Mesh,
    /// The midline from the anus to the caecum, a point every 1 mm.
    pub line: Centerline,
    /// The bends, anus first.
    pub bends: Vec<Bend>,
    /// Midline length (mm).
    pub length_mm: f64,
    /// Which candidate of the seed was kept (1 first; 0: the template).
    pub attempt: u32,
}

#[derive(Debug, Clone, Copy)]
enum Piece {
    /// A straight run: length (mm), radius as a fraction of the range (0 narrowest).
    Run(f64, f64),
    /// An arc: name, turn (degrees), bend radius / lumen radius, roll of its plane (degrees).
    Arc(&'static str, f64, f64, f64),
}

/// The template, anus first (the canal's 40 mm run is sized by [`SurfaceParams::canal_radius_mm`]
/// over its first 30 mm).
const TEMPLATE: [Piece; 12] = [
    Piece::Run(40.0, 0.1),
    Piece::Run(80.0, 0.1),
    Piece::Arc("rectosigmoid flexure", 110.0, 0.45, 0.0),
    Piece::Run(70.0, 0.2),
    Piece::Arc("sigmoid hairpin", 150.0, 0.34, 90.0),
    Piece::Run(60.0, 0.3),
    Piece::Arc("descending bend", 70.0, 0.5, 180.0),
    Piece::Run(130.0, 0.45),
    Piece::Arc("splenic flexure", 140.0, 0.4, 60.0),
    Piece::Run(160.0, 0.75),
    Piece::Arc("hepatic flexure", 100.0, 0.5, -45.0),
    Piece::Run(110.0, 1.0),
];

/// The midline sampled densely: positions, tangents, a normal turning with the bends, arc
/// lengths, and the major radius at each sample.
struct Layout {
    points: Vec<V3d>,
    tangents: Vec<V3d>,
    normals: Vec<V3d>,
    arc: Vec<f64>,
    radius: Vec<f64>,
    bends: Vec<Bend>,
}

/// Rotates `v` about unit `axis` by `angle` radians (Rodrigues).
fn rotate(v: V3d, axis: V3d, angle: f64) -> V3d {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(&v) * s + axis * axis.dot(&v) * (1.0 - c)
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// Lays the pieces out from the origin heading `+z`, the first bend's plane the `y-z` plane.
fn layout(pieces: &[Piece], p: &SurfaceParams) -> Layout {
    let [r0, r1] = [p.radius_mm[0] as f64, p.radius_mm[1] as f64];
    let runs: Vec<usize> = (0..pieces.len()).filter(|&i| matches!(pieces[i], Piece::Run(..))).collect();
    let frac_at = |i: usize| match pieces[i] {
        Piece::Run(_, f) => f,
        Piece::Arc(..) => {
            let prev = runs.iter().rev().find(|&&k| k < i).copied().unwrap_or(runs[0]);
            let next = runs.iter().find(|&&k| k > i).copied().unwrap_or(prev);
            let f = |k: usize| if let Piece::Run(_, f) = pieces[k] { f } else { 0.0 };
            0.5 * (f(prev) + f(next))
        }
    };
    // Keyframes of the radius: the canal, then each piece's middle.
    let lengths: Vec<f64> = (0..pieces.len())
        .map(|i| match pieces[i] {
            Piece::Run(l, _) => l,
            Piece::Arc(_, turn, ratio, _) => ratio * (r0 + (r1 - r0) * frac_at(i)) * turn.to_radians(),
        })
        .collect();
    let mut keys: Vec<(f64, f64)> = vec![(0.0, p.canal_radius_mm as f64), (30.0, p.canal_radius_mm as f64)];
    let mut s = 0.0;
    for (i, l) in lengths.iter().enumerate() {
        if i > 0 {
            keys.push((s + 0.5 * l, r0 + (r1 - r0) * frac_at(i)));
        }
        s += l;
    }
    keys.push((s, keys.last().unwrap().1));
    let radius_at = |s: f64| {
        let k = keys.partition_point(|&(ks, _)| ks <= s).clamp(1, keys.len() - 1);
        let ((sa, ra), (sb, rb)) = (keys[k - 1], keys[k]);
        ra + (rb - ra) * smoothstep((s - sa) / (sb - sa).max(1e-9))
    };

    let (mut pos, mut t, mut n) = (V3d::zeros(), V3d::z(), V3d::y());
    let mut out = Layout { points: vec![pos], tangents: vec![t], normals: vec![n], arc: vec![0.0], radius: vec![radius_at(0.0)], bends: Vec::new() };
    let mut s = 0.0;
    for (i, piece) in pieces.iter().enumerate() {
        match *piece {
            Piece::Run(len, _) => {
                let steps = (len / 0.5).ceil() as usize;
                for _ in 0..steps {
                    pos += t * (len / steps as f64);
                    s += len / steps as f64;
                    out.push(pos, t, n, s, radius_at(s));
                }
            }
            Piece::Arc(name, turn, ratio, roll) => {
                let lumen = r0 + (r1 - r0) * frac_at(i);
                let rho = ratio * lumen;
                n = rotate(n, t, roll.to_radians());
                let axis = t.cross(&n).normalize();
                let steps = (rho * turn.to_radians() / 0.2).ceil() as usize;
                let dphi = turn.to_radians() / steps as f64;
                let centre = pos + n * rho;
                let at_mm = s + 0.5 * lengths[i];
                for _ in 0..steps {
                    // Turning about `axis` (t x n) by +dphi carries t towards n.
                    let arm = rotate(pos - centre, axis, dphi);
                    pos = centre + arm;
                    t = rotate(t, axis, dphi);
                    n = rotate(n, axis, dphi);
                    s += rho * dphi;
                    out.push(pos, t, n, s, radius_at(s));
                }
                out.bends.push(Bend { name, at_mm, turn_deg: turn, radius_mm: rho, lumen_mm: radius_at(at_mm), roll_deg: if out.bends.is_empty() { 0.0 } else { roll } });
            }
        }
    }
    out
}

impl Layout {
    fn push(&mut self, p: V3d, t: V3d, n: V3d, s: f64, r: f64) {
        self.points.push(p);
        self.tangents.push(t);
        self.normals.push(n);
        self.arc.push(s);
        self.radius.push(r);
    }

    /// Whether parts of the midline far apart along it (more than three times their radii
    /// summed, and 60 mm) keep their walls at least 5 mm apart.
    fn walls_apart(&self) -> bool {
        let idx: Vec<usize> = (0..self.points.len()).filter(|&i| self.arc[i] >= 30.0).step_by(8).collect();
        idx.iter().enumerate().all(|(k, &i)| {
            idx[k + 1..].iter().all(|&j| {
                let (ri, rj) = (self.radius[i], self.radius[j]);
                self.arc[j] - self.arc[i] < (3.0 * (ri + rj)).max(60.0) || (self.points[i] - self.points[j]).norm() > ri + rj + 5.0
            })
        })
    }
}

/// The template with the seed's moves, candidate `attempt` (0: the template itself).
fn pieces(seed: u64, attempt: u32) -> Vec<Piece> {
    if attempt == 0 {
        return TEMPLATE.to_vec();
    }
    let mut rng = Rng::new(seed, 0x1a5f + attempt as u64);
    TEMPLATE
        .iter()
        .enumerate()
        .map(|(i, p)| match *p {
            Piece::Run(l, f) if i == 0 => Piece::Run(l, f),
            Piece::Run(l, f) => Piece::Run(l * rng.range(0.8, 1.2), (f + rng.range(-0.1, 0.1)).clamp(0.0, 1.0)),
            Piece::Arc(name, turn, _, roll) => {
                let roll = if i == 2 { 0.0 } else { roll + rng.range(-40.0, 40.0) };
                Piece::Arc(name, turn + rng.range(-15.0, 15.0), rng.range(BEND_RATIO[0], BEND_RATIO[1]), roll)
            }
        })
        .collect()
}

/// Haustral folds: centre (mm of arc), depth (fraction), lobe phase (radians).
fn folds(p: &SurfaceParams, length: f64) -> Vec<(f64, f64, f64)> {
    let mut rng = Rng::new(p.seed, 0xf01d);
    let spacing = p.fold_spacing_mm as f64;
    let mut out = Vec::new();
    let mut s = 150.0 + rng.range(0.0, spacing);
    while s < length - 20.0 {
        out.push((s, p.fold_depth as f64 * rng.range(0.7, 1.0), rng.range(0.0, 2.0 * PI / 3.0)));
        s += spacing * rng.range(0.8, 1.2);
    }
    out
}

/// One disc of the union (see the module doc).
struct Disc {
    c: V3d,
    e1: V3d,
    e2: V3d,
    t: V3d,
    a: f64,
    b: f64,
    /// Fold narrowing `A + Bc cos 3theta + Bs sin 3theta`.
    fold: [f64; 3],
}

impl Disc {
    /// `(Q - 1) b k` at `p`: negative inside the disc, about millimetres near its rim.
    #[inline]
    fn value(&self, p: V3d) -> f64 {
        let d = p - self.c;
        let (u, v, w) = (d.dot(&self.e1) / self.a, d.dot(&self.e2) / self.b, d.dot(&self.t) / DISC_HALF_MM);
        let r2 = u * u + v * v;
        let k = if r2 > 1e-12 {
            let r = r2.sqrt();
            let (c, s) = (u / r, v / r);
            let (c3, s3) = (4.0 * c * c * c - 3.0 * c, 3.0 * s - 4.0 * s * s * s);
            (1.0 - self.fold[0] - self.fold[1] * c3 - self.fold[2] * s3).max(0.4)
        } else {
            1.0
        };
        ((r2 / (k * k) + w * w).sqrt() - 1.0) * self.b * k
    }
}

/// The colon of `p` (see the module doc), or which parameter is out of range.
pub fn generate(p: &SurfaceParams) -> Result<SurfaceColon, ParamError> {
    p.validate()?;
    let mut attempt = 1;
    let lay = loop {
        let l = layout(&pieces(p.seed, attempt), p);
        if l.walls_apart() {
            break l;
        }
        attempt = if attempt >= MAX_ATTEMPTS { 0 } else { attempt + 1 };
        if attempt == 0 {
            break layout(&pieces(p.seed, 0), p);
        }
    };
    let length = *lay.arc.last().unwrap();
    let folds = folds(p, length);
    let mut rng = Rng::new(p.seed, 0xe111);
    let (ph1, ph2, psi0) = (rng.range(0.0, 2.0 * PI), rng.range(0.0, 2.0 * PI), rng.range(0.0, PI));
    let fold_sigma = 4.0;

    // Discs every 0.5 mm of arc on runs, every sample (0.2 mm) in bends.
    let mut discs = Vec::new();
    let mut last = f64::NEG_INFINITY;
    for i in 0..lay.points.len() {
        let s = lay.arc[i];
        let in_bend = i > 0 && (lay.tangents[i] - lay.tangents[i - 1]).norm() > 1e-9;
        if !in_bend && s - last < 0.5 && i + 1 != lay.points.len() {
            continue;
        }
        last = s;
        let canal = smoothstep((s - 30.0) / 20.0);
        let aspect = 1.0 - canal * (0.2 + 0.15 * (2.0 * PI * s / 170.0 + ph1).sin());
        let psi = psi0 + 0.6 * (2.0 * PI * s / 230.0 + ph2).sin();
        let (t, n) = (lay.tangents[i], lay.normals[i]);
        let b0 = t.cross(&n);
        let e1 = n * psi.cos() + b0 * psi.sin();
        let mut fold = [0.0; 3];
        for &(fs, depth, phase) in folds.iter().filter(|f| (f.0 - s).abs() < 4.0 * fold_sigma) {
            let g = depth * (-0.5 * ((s - fs) / fold_sigma).powi(2)).exp() * 0.5;
            fold[0] += g;
            fold[1] += g * (3.0 * phase).cos();
            fold[2] += g * (3.0 * phase).sin();
        }
        let a = lay.radius[i];
        discs.push(Disc { c: lay.points[i], e1, e2: t.cross(&e1), t, a, b: a * aspect, fold });
    }

    // The grid: the midline's box widened by the largest radius and a margin.
    let vx = p.voxel_mm as f64;
    let rmax = lay.radius.iter().cloned().fold(0.0, f64::max) + DISC_HALF_MM + 3.0 * vx;
    let (mut lo, mut hi) = (V3d::repeat(f64::MAX), V3d::repeat(f64::MIN));
    for q in &lay.points {
        lo = lo.inf(q);
        hi = hi.sup(q);
    }
    lo -= V3d::repeat(rmax);
    hi += V3d::repeat(rmax);
    let dims = [0, 1, 2].map(|d| ((hi[d] - lo[d]) / vx).ceil() as usize + 1);
    let outside = (3.0 * vx) as f32;
    let mut grid = Grid::new(dims, [lo.x, lo.y, lo.z], vx, outside);
    let step = 0.7 * vx;
    let pad = 2.0 * vx;
    for d in &discs {
        let (na, nb, nw) = (((d.a + pad) / step).ceil() as i64, ((d.b + pad) / step).ceil() as i64, ((DISC_HALF_MM + pad) / step).ceil() as i64);
        for iu in -na..=na {
            let u = iu as f64 * step;
            for iv in -nb..=nb {
                let v = iv as f64 * step;
                if (u / (d.a + pad)).powi(2) + (v / (d.b + pad)).powi(2) > 1.0 {
                    continue;
                }
                for iw in -nw..=nw {
                    let q = d.c + d.e1 * u + d.e2 * v + d.t * (iw as f64 * step);
                    let g = [0, 1, 2].map(|k| ((q[k] - lo[k]) / vx).round() as usize);
                    let at = grid.index(g[0], g[1], g[2]);
                    if grid.values[at] < -outside {
                        continue;
                    }
                    let centre = grid.position(g[0], g[1], g[2]);
                    let val = d.value(V3d::new(centre[0], centre[1], centre[2])) as f32;
                    if val < grid.values[at] {
                        grid.values[at] = val;
                    }
                }
            }
        }
    }
    let mesh = nets::mesh(&grid);

    // The midline a point every 1 mm.
    let mut points = Vec::new();
    let mut s_out = Vec::new();
    let mut next = 0.0;
    for i in 0..lay.points.len() {
        if lay.arc[i] + 1e-9 >= next {
            points.push([0, 1, 2].map(|k| lay.points[i][k] as f32));
            s_out.push(lay.arc[i] as f32);
            next += 1.0;
        }
    }
    Ok(SurfaceColon { mesh, line: Centerline { points, s: Some(s_out), radius_median: None }, bends: lay.bends, length_mm: length, attempt })
}

/// Spokes of the `insufflated` scene's import: 32 leave the wall of these wide, elliptical,
/// folded sections 0.8 to 0.9 mm from the surface at p99, 48 within 0.5.
pub const IMPORT_SPOKES: usize = 48;

/// The `insufflated` scene: the default colon of `seed` imported through the gate
/// ([`lumen_import::import`]) at [`IMPORT_SPOKES`] spokes every 1 mm, the same model as
/// `lumen generate --seed S` followed by `lumen import ... --spokes 48`.
pub fn load(seed: u64) -> Result<(Tube, ImportReport), ImportError> {
    load_with(seed, &ImportParams { spokes: IMPORT_SPOKES, ..ImportParams::default() })
}

/// The default colon of `seed` imported through the gate with `params` (the benchmarks' other
/// spokes and ring spacings).
pub fn load_with(seed: u64, params: &ImportParams) -> Result<(Tube, ImportReport), ImportError> {
    let c = generate(&SurfaceParams::seeded(seed)).expect("the default parameters are valid");
    lumen_import::import(&c.mesh, &c.line, params)
}
