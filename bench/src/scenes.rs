//! The benchmark's scenes: a colon and a deterministic sequence of endoscope frames in it
//! ([`lumen_scene::endoscope::Insertion::frames`]), stored as flat states ready to be copied into
//! the one buffer the detectors read. The colon is one of `lumen-scene`'s ([`ColonKind`]) or a
//! model file ([`Model`], what `lumen import` writes).

use crate::{Error, Options};
use lumen_detect::model::{is_text_path, parse_model, ImportInfo};
use lumen_detect::{Body, ContactKind, Rod, Scene, SceneSpec, Tube};
use lumen_import::ImportParams;
use lumen_scene::colon::{generate, ColonParams};
use lumen_scene::endoscope::Insertion;
use lumen_scene::gca::{self, Source};
pub use lumen_scene::ColonKind;
use std::path::{Path, PathBuf};

/// Where a scene's colon comes from: one of `lumen-scene`'s colons, rebuilt at each spoke
/// count, or a model file, run as it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneKind {
    Colon(ColonKind),
    /// [`Options::model`]'s file (the report calls the scene `model`).
    Model,
}

impl SceneKind {
    /// The scene's name in the report: the colon's (`generated`, `gca`, ...), or `model`.
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Colon(k) => k.name(),
            SceneKind::Model => "model",
        }
    }

    /// Whether the colon is a real one (the GCA colon, or a model imported from a scan): judged
    /// against the real colon's reference, entered to the real colon's depth.
    pub fn real(self) -> bool {
        matches!(self, SceneKind::Colon(ColonKind::Gca | ColonKind::Insufflated) | SceneKind::Model)
    }
}

/// A tube model file, read with the loader of `lumen sim --model`
/// ([`lumen_detect::model::parse_model`]: the native format, or the text format when the name
/// ends in `.txt`).
#[derive(Debug, Clone)]
pub struct Model {
    pub path: PathBuf,
    pub tube: Tube,
    /// What the import that wrote it measured (the native files of `lumen import`); `None` for a
    /// text file or a model from elsewhere.
    pub import: Option<ImportInfo>,
}

impl Model {
    /// Reads `path`; every error names it.
    pub fn read(path: &Path) -> Result<Self, Error> {
        let bytes = std::fs::read(path).map_err(|source| Error::ModelRead { path: path.to_owned(), source })?;
        match parse_model(&bytes, is_text_path(path)) {
            Ok((Body::Tube(tube), import)) => match lumen_import::check(&tube) {
                Ok(()) => Ok(Self { path: path.to_owned(), tube, import }),
                Err(e) => Err(Error::Model { path: path.to_owned(), message: e.to_string() }),
            },
            Ok((Body::Rod(_), _)) => Err(Error::Model { path: path.to_owned(), message: "holds a rod, not a colon (a tube)".into() }),
            Err(e) => Err(Error::Model { path: path.to_owned(), message: e.to_string() }),
        }
    }

    /// Arc length between its rings, on average (mm).
    pub fn ring_spacing(&self) -> f64 {
        length(&self.tube) / (self.tube.rings().max(2) - 1) as f64
    }
}

/// A frame kept for judging: the colon and scope as generated.
#[derive(Debug, Clone)]
pub struct EvalFrame {
    pub index: usize,
    pub colon: Tube,
    pub scope: Rod,
    /// Scope control points inside the colon (`0..inserted`).
    pub inserted: usize,
    /// Scope control points pushed through the wall.
    pub escaped: Vec<usize>,
    /// For each scope control point, the colon arc length where it is (mm; negative behind the
    /// first ring).
    pub arc_mm: Vec<f32>,
}

/// One scene at one spoke count: its frames as states, and the frames to judge.
#[derive(Debug, Clone)]
pub struct SceneData {
    pub kind: SceneKind,
    pub spokes: usize,
    pub rings: usize,
    /// The scene spec at the default precision (precision and method are set per run).
    pub spec: SceneSpec,
    /// Floats per frame.
    pub floats: usize,
    /// All frames' states, back to back.
    states: Vec<f32>,
    pub frames: usize,
    pub eval: Vec<EvalFrame>,
    /// Frames with control points pushed through the wall.
    pub escaping_frames: usize,
    /// Tip depth of the first and last frame (mm of colon midline).
    pub depth_mm: [f32; 2],
    /// What the import repaired, and its wall against the source surface (gca; a model file
    /// that stores it).
    pub import: Option<ImportInfo>,
    /// Data credit (gca).
    pub attribution: Option<&'static str>,
}

impl SceneData {
    /// State of frame `f`.
    pub fn state(&self, f: usize) -> &[f32] {
        &self.states[f * self.floats..(f + 1) * self.floats]
    }
}

/// Ring spacing of the scenes (mm): generated (and its variants) 1.2 (~1,250 rings over 1.5 m),
/// gca 1.0.
pub fn ring_spacing(kind: ColonKind, opts: &Options) -> f32 {
    match kind {
        ColonKind::Gca | ColonKind::Insufflated => 1.0,
        _ => opts.generated_ring_spacing_mm,
    }
}

/// The colon of `kind` with `spokes` spokes, rings `ring_factor` times denser than usual.
pub fn colon(kind: ColonKind, spokes: usize, ring_factor: f32, opts: &Options, gca: Option<&Source>) -> Result<(Tube, Option<lumen_import::ImportReport>), Error> {
    let spacing = ring_spacing(kind, opts) / ring_factor;
    match kind.generated(opts.seed) {
        Some(p) => {
            let p = ColonParams { length_mm: opts.generated_length_mm, ring_spacing: spacing, spokes, ..p };
            Ok((generate(&p), None))
        }
        None if kind == ColonKind::Insufflated => {
            let (tube, rep) = lumen_scene::insufflated::load_with(opts.seed, &ImportParams { spokes, ring_spacing: spacing, ..ImportParams::default() }).map_err(Error::GcaImport)?;
            Ok((tube, Some(rep)))
        }
        None => {
            let g = gca.ok_or(Error::GcaNotLoaded)?;
            let p = ImportParams { spokes, ring_spacing: spacing, ..ImportParams::gca() };
            let (tube, rep) = g.tube(&p).map_err(Error::GcaImport)?;
            Ok((tube, Some(rep)))
        }
    }
}

/// Tip depth (mm of midline) at the first frame: 1 m in the generated colon (as the README's
/// benchmark), 700 mm in the shorter real one (and a model's); at most 60% of a short colon.
pub fn start_depth(kind: SceneKind, colon_length: f64) -> f32 {
    let d: f64 = if kind.real() { 700.0 } else { 1000.0 };
    d.min(0.6 * colon_length) as f32
}

fn length(t: &Tube) -> f64 {
    t.points.windows(2).map(|w| (0..3).map(|d| (w[1][d] as f64 - w[0][d] as f64).powi(2)).sum::<f64>().sqrt()).sum()
}

/// The frames to judge out of `frames`: every `every`-th, and every `escapes_every`-th of those
/// with control points pushed through the wall (0: none more).
pub fn is_eval(f: usize, escaped: bool, every: usize, escapes_every: usize) -> bool {
    (every > 0 && f.is_multiple_of(every)) || (escaped && escapes_every > 0 && f.is_multiple_of(escapes_every))
}

/// Builds a scene: colon, `opts.frames` frames of the default insertion (seed `opts.seed`,
/// 1 mm per frame), states, judged frames.
pub fn build(kind: ColonKind, spokes: usize, ring_factor: f32, opts: &Options, gca: Option<&Source>, keep_eval: bool) -> Result<SceneData, Error> {
    let (colon, import_report) = colon(kind, spokes, ring_factor, opts, gca)?;
    let attribution = (kind == ColonKind::Gca).then(gca::attribution);
    frames(SceneKind::Colon(kind), colon, import_report.map(|r| r.info()), attribution, opts, keep_eval)
}

/// Builds the scene of a model file as [`build`] does, at its own rings and spokes.
pub fn build_model(model: &Model, opts: &Options, keep_eval: bool) -> Result<SceneData, Error> {
    frames(SceneKind::Model, model.tube.clone(), model.import.clone(), None, opts, keep_eval)
}

fn frames(kind: SceneKind, colon: Tube, import: Option<ImportInfo>, attribution: Option<&'static str>, opts: &Options, keep_eval: bool) -> Result<SceneData, Error> {
    let (rings, spokes) = (colon.rings(), colon.spokes);
    let insertion = Insertion::default();
    let start = start_depth(kind, length(&colon));
    let mut spec = None;
    let mut floats = 0;
    let mut states = Vec::new();
    let mut eval = Vec::new();
    let mut escaping_frames = 0;
    let mut depth_mm = [0.0f32; 2];
    for f in insertion.frames(&colon, opts.frames, start, 1.0, opts.seed) {
        if f.index == 0 {
            depth_mm[0] = f.depth_mm;
        }
        depth_mm[1] = f.depth_mm;
        let escaped = !f.escaped.is_empty();
        let arc_mm = f.arc_mm.clone();
        escaping_frames += usize::from(escaped);
        let scene = Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", ContactKind::Interior);
        let state = scene.state();
        let sp = spec.get_or_insert_with(|| {
            let mut s = scene.spec();
            s.margin = opts.margin;
            s
        });
        // Every frame is validated once here, as the daemon validates frames on receipt; the
        // detectors are then timed on `detect_prevalidated`.
        lumen_detect::proto::StateLayout::of(sp).check(&sp.bodies, &state).map_err(|source| Error::Frame { scene: kind.name(), frame: f.index, source })?;
        floats = state.len();
        states.extend_from_slice(&state);
        if keep_eval && is_eval(f.index, escaped, opts.eval_every, opts.eval_escapes_every) {
            let Scene { bodies, .. } = scene;
            let mut it = bodies.into_iter().map(|(_, b)| b);
            let (Some(lumen_detect::Body::Tube(colon)), Some(lumen_detect::Body::Rod(scope))) = (it.next(), it.next()) else { unreachable!() };
            eval.push(EvalFrame { index: f.index, colon, scope, inserted: f.inserted, escaped: f.escaped, arc_mm });
        }
    }
    let spec = spec.ok_or(Error::NoFrames)?;
    Ok(SceneData { kind, spokes, rings, spec, floats, states, frames: opts.frames, eval, escaping_frames, depth_mm, import, attribution })
}

/// `base` with its colon extended past its last ring by `extra` rings (straight on along the last
/// segment, same spacing, the last ring's spokes), in every frame: the same endoscope and the
/// same contacts in a longer colon. Nothing is kept for judging.
pub fn extended(base: &SceneData, extra: usize) -> SceneData {
    use lumen_detect::proto::Shape;
    let b = base.spokes;
    let stride = 3 * (b + 1);
    let tube_floats = base.rings * stride;
    let rings = base.rings + extra;
    let mut spec = base.spec.clone();
    for body in &mut spec.bodies {
        if let Shape::Tube { rings: r, .. } = &mut body.shape {
            *r = rings;
        }
    }
    let floats = base.floats + extra * stride;
    let mut states = Vec::with_capacity(base.frames * floats);
    for f in 0..base.frames {
        let st = base.state(f);
        let (tube, rod) = st.split_at(tube_floats);
        states.extend_from_slice(tube);
        let last = &tube[(base.rings - 1) * stride..];
        let prev = &tube[(base.rings - 2) * stride..];
        let step = [last[0] - prev[0], last[1] - prev[1], last[2] - prev[2]];
        for j in 1..=extra {
            let t = j as f32;
            states.extend_from_slice(&[last[0] + t * step[0], last[1] + t * step[1], last[2] + t * step[2]]);
            states.extend_from_slice(&last[3..stride]);
        }
        states.extend_from_slice(rod);
    }
    SceneData { spec, floats, states, rings, eval: Vec::new(), import: None, ..base.clone_empty() }
}

impl SceneData {
    /// This scene's figures without its states or judged frames.
    fn clone_empty(&self) -> SceneData {
        SceneData {
            kind: self.kind,
            spokes: self.spokes,
            rings: self.rings,
            spec: self.spec.clone(),
            floats: self.floats,
            states: Vec::new(),
            frames: self.frames,
            eval: Vec::new(),
            escaping_frames: self.escaping_frames,
            depth_mm: self.depth_mm,
            import: None,
            attribution: self.attribution,
        }
    }
}
