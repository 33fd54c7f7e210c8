//! Tubes and rods as owned data: what files hold and what a scene is built from.
//!
//! The pipeline itself reads the flat frame state (see [`lumen_proto::state`]); these types are
//! for loading, saving, generating and checking models, and [`Scene`] turns them into a spec
//! and a state.

mod fold;
mod native;
mod overlap;
mod text;

pub use fold::{crossings as fold_crossings, FoldReport, Within as FoldWithin, CLIP as FOLD_CLIP, KEEP as FOLD_KEEP, WINDOW as FOLD_WINDOW};
pub use native::{load_native, load_native_with, save_native, save_native_with};
pub use overlap::OverlapReport;
pub use text::{parse_text, to_text};

use crate::V3;
use lumen_proto::limits::{MAX_POINTS, MAX_SPOKES, MIN_POINTS, MIN_SPOKES};
use lumen_proto::{BodySpec, ContactKind, Method, PairSpec, SceneSpec, Shape};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A model that cannot be read or used.
#[derive(Debug, Error)]
pub enum ModelError {
    #[error("line {line}: {message}")]
    Parse { line: usize, message: String },
    #[error("{0}")]
    Invalid(String),
    #[error("not a Lumen model file: {0}")]
    Format(String),
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// A tube: control points along its midline and, per point, radial vectors to its wall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tube {
    /// Control points (rings), in order along the midline.
    pub points: Vec<[f32; 3]>,
    /// `points.len() * spokes` radial vectors, ring after ring, relative to their point.
    pub radial: Vec<[f32; 3]>,
    /// Radial vectors per ring (`B`).
    pub spokes: usize,
}

/// A rod: control points and radii (one for all, or one per point).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rod {
    pub points: Vec<[f32; 3]>,
    pub radius: Vec<f32>,
}

/// Either kind of body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Body {
    Tube(Tube),
    Rod(Rod),
}

/// What the import that wrote a model measured, stored beside its body in the native format
/// (`lumen import` writes it), so that whoever runs the model can tell how far its wall lies from
/// the surface it came from.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImportInfo {
    /// The wall (before inflation) to the source surface, in mm: p50, p99, max.
    pub fidelity_mm: [f64; 3],
    /// The p99 over the wall points drawn between kept spokes only (no repaired ray among
    /// those it is drawn from), mm.
    pub kept_p99_mm: f64,
    /// Wall points measured.
    pub samples: u64,
    /// The import's report, as `lumen import` printed it (rays kept and repaired, radii,
    /// fidelity).
    pub report: String,
}

/// A model file's contents: `text` for the method's text format (a tube; no [`ImportInfo`]),
/// else the native format. Every reader of model files (`lumen sim --model`, `lumen bench
/// detect --model`) goes through here; the caller names the file in its errors.
pub fn parse_model(bytes: &[u8], text: bool) -> Result<(Body, Option<ImportInfo>), ModelError> {
    if text {
        parse_text(&String::from_utf8_lossy(bytes)).map(|t| (Body::Tube(t), None))
    } else {
        load_native_with(bytes)
    }
}

/// Whether `path` names a model in the method's text format (it ends in `.txt`).
pub fn is_text_path(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("txt"))
}

fn check_counts(points: usize, spokes: Option<usize>) -> Result<(), ModelError> {
    if !(MIN_POINTS..=MAX_POINTS).contains(&points) {
        return Err(ModelError::Invalid(format!("{points} control points; between {MIN_POINTS} and {MAX_POINTS} are allowed")));
    }
    if let Some(b) = spokes {
        if !(MIN_SPOKES..=MAX_SPOKES).contains(&b) {
            return Err(ModelError::Invalid(format!("{b} radial vectors per ring; between {MIN_SPOKES} and {MAX_SPOKES} are allowed")));
        }
    }
    Ok(())
}

fn v(a: [f32; 3]) -> V3 {
    V3::new(a[0], a[1], a[2])
}

impl Tube {
    /// A tube from its parts, checked: counts within limits, every value finite.
    pub fn new(points: Vec<[f32; 3]>, radial: Vec<[f32; 3]>, spokes: usize) -> Result<Self, ModelError> {
        let t = Self { points, radial, spokes };
        t.validate()?;
        Ok(t)
    }

    /// Checks counts, limits and finiteness; the error names ring and spoke.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_counts(self.points.len(), Some(self.spokes))?;
        if self.radial.len() != self.points.len() * self.spokes {
            return Err(ModelError::Invalid(format!("{} radial vectors for {} rings of {}; expected {}", self.radial.len(), self.points.len(), self.spokes, self.points.len() * self.spokes)));
        }
        if let Some(i) = self.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(ModelError::Invalid(format!("control point {i} is not finite: {:?}", self.points[i])));
        }
        if let Some(j) = self.radial.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(ModelError::Invalid(format!("radial vector {} of ring {} is not finite: {:?}", j % self.spokes, j / self.spokes, self.radial[j])));
        }
        Ok(())
    }

    /// Number of rings (control points).
    pub fn rings(&self) -> usize {
        self.points.len()
    }

    /// Radial vector `k` of ring `i`.
    pub fn spoke(&self, i: usize, k: usize) -> [f32; 3] {
        self.radial[i * self.spokes + k]
    }

    /// The first ring whose section is not star-shaped about its control point, with the spoke
    /// where the turning goes backwards. Angles are measured in the plane of the ring (its area
    /// normal); a section is star-shaped when its radial vectors turn one way around the point
    /// and close after exactly one turn.
    pub fn first_non_star(&self) -> Option<(usize, usize)> {
        let b = self.spokes;
        for i in 0..self.rings() {
            let s: Vec<V3> = (0..b).map(|k| v(self.spoke(i, k))).collect();
            let mut n = V3::zeros();
            for k in 0..b {
                n += s[k].cross(&s[(k + 1) % b]);
            }
            let nn = n.norm();
            if nn == 0.0 {
                continue; // collapsed: degenerate but not folded
            }
            let n = n / nn;
            let mut total = 0.0f32;
            for k in 0..b {
                let (a, c) = (s[k], s[(k + 1) % b]);
                let turn = a.cross(&c).dot(&n).atan2(a.dot(&c));
                if turn < -1e-6 {
                    return Some((i, k));
                }
                total += turn;
            }
            if (total - std::f32::consts::TAU).abs() > 1e-2 {
                return Some((i, 0));
            }
        }
        None
    }

    /// Appends this tube's floats to a frame state.
    pub fn write_state(&self, out: &mut Vec<f32>) {
        for i in 0..self.rings() {
            out.extend_from_slice(&self.points[i]);
            for k in 0..self.spokes {
                out.extend_from_slice(&self.spoke(i, k));
            }
        }
    }
}

impl Rod {
    /// A rod from its parts, checked.
    pub fn new(points: Vec<[f32; 3]>, radius: Vec<f32>) -> Result<Self, ModelError> {
        check_counts(points.len(), None)?;
        if radius.len() != 1 && radius.len() != points.len() {
            return Err(ModelError::Invalid(format!("{} radii for {} points; give 1 or {}", radius.len(), points.len(), points.len())));
        }
        if let Some(i) = radius.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(ModelError::Invalid(format!("radius {i} is {}; radii must be finite and > 0", radius[i])));
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(ModelError::Invalid(format!("control point {i} is not finite: {:?}", points[i])));
        }
        Ok(Self { points, radius })
    }

    /// Appends this rod's floats to a frame state.
    pub fn write_state(&self, out: &mut Vec<f32>) {
        for p in &self.points {
            out.extend_from_slice(p);
        }
    }
}

impl Body {
    fn shape(&self) -> Shape {
        match self {
            Body::Tube(t) => Shape::Tube { rings: t.rings(), spokes: t.spokes },
            Body::Rod(r) => Shape::Rod { points: r.points.len(), radius: r.radius.clone() },
        }
    }
}

/// Named bodies and the pairs to compute: builds a [`SceneSpec`] and the matching state.
///
/// ```
/// use lumen_detect::{Scene, Rod, Tube, ContactKind};
/// let ring = |r: f32| (0..8).map(move |k| {
///     let a = k as f32 * std::f32::consts::TAU / 8.0;
///     [0.0, r * a.cos(), r * a.sin()]
/// });
/// let colon = Tube::new(
///     (0..4).map(|i| [i as f32 * 10.0, 0.0, 0.0]).collect(),
///     (0..4).flat_map(|_| ring(20.0)).collect(), 8).unwrap();
/// let scope = Rod::new(vec![[0.0, 0.0, 0.0], [30.0, 0.0, 0.0]], vec![6.5]).unwrap();
/// let scene = Scene::new().tube("colon", colon).rod("scope", scope)
///     .pair("scope", "colon", ContactKind::Interior);
/// assert_eq!(scene.state().len(), 4 * 9 * 3 + 2 * 3);
/// ```
#[derive(Debug, Clone, Default)]
pub struct Scene {
    pub bodies: Vec<(String, Body)>,
    pub pairs: Vec<PairSpec>,
    pub precision: Option<u32>,
    pub alpha: Option<f32>,
    pub margin: f32,
    pub method: Method,
    /// `None`: the spec's default (the nearest wall point).
    pub nearest: Option<bool>,
    pub refine: u32,
}

impl Scene {
    pub fn new() -> Self {
        Self::default()
    }
    /// Adds a tube named `name`.
    pub fn tube(mut self, name: &str, t: Tube) -> Self {
        self.bodies.push((name.to_owned(), Body::Tube(t)));
        self
    }
    /// Adds a rod named `name`.
    pub fn rod(mut self, name: &str, r: Rod) -> Self {
        self.bodies.push((name.to_owned(), Body::Rod(r)));
        self
    }
    /// Declares a pair to compute (`a` must be a rod).
    pub fn pair(mut self, a: &str, b: &str, kind: ContactKind) -> Self {
        self.pairs.push(PairSpec { a: a.to_owned(), b: b.to_owned(), kind });
        self
    }
    /// Sets the precision `x`.
    pub fn precision(mut self, x: u32) -> Self {
        self.precision = Some(x);
        self
    }
    /// Sets the method.
    pub fn method(mut self, m: Method) -> Self {
        self.method = m;
        self
    }
    /// Contacts at the nearest point of the continuous wall (`SceneSpec::nearest`, the
    /// default), or `false`: the `sections` reading.
    pub fn nearest(mut self, on: bool) -> Self {
        self.nearest = Some(on);
        self
    }
    /// Axial re-projections of every section reading (`SceneSpec::refine`).
    pub fn refine(mut self, n: u32) -> Self {
        self.refine = n;
        self
    }
    /// The spec of this scene.
    pub fn spec(&self) -> SceneSpec {
        let bodies = self.bodies.iter().map(|(name, b)| BodySpec { name: name.clone(), shape: b.shape() }).collect();
        let mut s = SceneSpec::new(bodies, self.pairs.clone());
        if let Some(x) = self.precision {
            s.precision = x;
        }
        if let Some(a) = self.alpha {
            s.alpha = a;
        }
        s.margin = self.margin;
        s.method = self.method;
        if let Some(on) = self.nearest {
            s.nearest = on;
        }
        s.refine = self.refine;
        s
    }
    /// The frame state of this scene, bodies in order.
    pub fn state(&self) -> Vec<f32> {
        let mut out = Vec::new();
        for (_, b) in &self.bodies {
            match b {
                Body::Tube(t) => t.write_state(&mut out),
                Body::Rod(r) => r.write_state(&mut out),
            }
        }
        out
    }
}
