//! `lumen bench detect`: speed against error for Lumen's collision methods, measured side by
//! side in one run, with a picture.
//!
//! Three methods on the same frames:
//! - `thesis`: the published method ([`lumen_detect::Method::Thesis`]);
//! - `default`: signed containment with temporal coherence ([`lumen_detect::Method::Signed`]),
//!   called through [`lumen_detect::Detector::detect_prevalidated`]: every frame is validated
//!   once when the sequence is built (as the daemon validates frames on receipt), so the timed
//!   call skips the O(state) finiteness scan. The thesis method is timed the same way;
//! - `parry`: the generic choice, a parry3d `TriMesh` refit every frame and a chain of capsules
//!   ([`baseline`]).
//!
//! Scenes ([`scenes`]): `generated` (the seeded colon of `lumen-scene`) and `gca` (the real
//! colon, imported at 1 ring per mm, inflated x2; skipped with a message when its files are
//! absent), each at spokes `B` in {16, 32, 64} (the colon rebuilt with that many spokes), and
//! `model`, a model file written by `lumen import` ([`Options::model`], run at its own rings and
//! spokes, with the import's fidelity it stores), with the kinematic insertion's frames (1 mm
//! per frame, wall deformed, seeded escapes).
//! Precision `x` in {1, 2, 4, 8, 16}. Speed and ratios: [`sweep`]; accuracy against the dense
//! reference: [`metrics`]; output: [`report`].
//!
//! ```no_run
//! let opts = lumen_bench::Options::quick();
//! let report = lumen_bench::run(&opts, true)?;
//! report.write("bench-out")?;
//! # Ok::<(), lumen_bench::Error>(())
//! ```
//!
//! The `gca` scene's results derive from the Edinburgh Gut Cell Atlas colon: "Edinburgh Gut Cell
//! Atlas models (Comparative-Pathology/GCA-Models), CC BY 4.0, doi:10.1186/s12911-023-02111-9";
//! the report carries this credit wherever it shows them.

pub mod baseline;
pub mod cli;
pub mod instructions;
pub mod metrics;
pub mod report;
pub mod scenes;
pub mod sweep;

pub use baseline::{ParryBaseline, ParryContact, ParryShape};
pub use lumen_scene::ColonKind;
pub use report::Report;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// What can stop a sweep, or writing its report: the crate's one error type. Every variant
/// keeps its source where there is one.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A flag's value is not one of those allowed (`--scene liver`, `--methods bullet`).
    #[error("bad options: {flag} {value}: expected {expected}")]
    BadFlag { flag: &'static str, value: String, expected: &'static str },
    /// `--methods` names no method.
    #[error("unknown method {name:?} (default, sections, refined, thesis or parry)")]
    UnknownMethod { name: String },
    /// A list of the sweep is empty.
    #[error("bad options: scenes, methods, precisions and spokes must not be empty")]
    EmptySweep,
    /// A precision does not divide [`metrics::DENSE_PER_SEGMENT`].
    #[error("bad options: precisions must divide 64 (1, 2, 4, 8, 16, 32 or 64)")]
    Precision { x: u32 },
    /// A spoke count out of range.
    #[error("bad options: spokes must be in 3..=256")]
    Spokes { spokes: usize },
    /// No frame would be timed.
    #[error("bad options: frames must exceed warmup")]
    Frames { frames: usize, warmup: usize },
    /// A negative or non-finite contact margin.
    #[error("bad options: margin must be finite and >= 0")]
    Margin { margin: f32 },
    /// The real colon was asked for but not loaded.
    #[error("scene: the GCA colon is not loaded")]
    GcaNotLoaded,
    /// An imported colon's tube (the GCA colon, the insufflated one) could not be built.
    #[error("scene: import: {0}")]
    GcaImport(#[source] lumen_import::ImportError),
    /// The model scene was asked for but no model loaded.
    #[error("scene: the model is not loaded")]
    ModelNotLoaded,
    /// `--model`'s file cannot be read.
    #[error("--model {}: {source}", path.display())]
    ModelRead { path: PathBuf, source: std::io::Error },
    /// `--model`'s file is not a colon model.
    #[error("--model {}: {message}", path.display())]
    Model { path: PathBuf, message: String },
    /// A frame of the insertion is not a valid state of its scene.
    #[error("scene: {scene} frame {frame}: {source}")]
    Frame { scene: &'static str, frame: usize, source: lumen_detect::proto::InputError },
    /// The insertion produced no frame.
    #[error("scene: no frames")]
    NoFrames,
    /// A detector refused the scene's spec.
    #[error("scene: {0}")]
    Spec(#[from] lumen_detect::proto::SpecError),
    /// A detector refused a frame.
    #[error("scene: {0}")]
    Detect(#[source] lumen_detect::proto::InputError),
    /// The parry baseline was given a state of the wrong length.
    #[error("scene: state of {got} floats, the spec needs {expected}")]
    BaselineState { got: usize, expected: usize },
    /// The parry baseline needs a tube...
    #[error("scene: the scene has no tube")]
    NoTube,
    /// ...and a rod...
    #[error("scene: the scene has no rod")]
    NoRod,
    /// ...of one radius.
    #[error("scene: the parry baseline takes a rod with one radius")]
    RodRadii { radii: usize },
    /// parry refused the wall's mesh.
    #[error("scene: parry TriMesh: {0}")]
    TriMesh(#[from] parry3d::shape::TriMeshBuilderError),
    /// Every requested scene was skipped (the messages say why; they are also the report's
    /// [`Report::skipped`]).
    #[error("no scene could run: {}", .0.join("; "))]
    NoScenes(Vec<String>),
    /// Writing a file of the report.
    #[error("writing the report: {}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    /// Reading the `report.json` to replot.
    #[error("reading {}: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    /// A `report.json` that does not parse.
    #[error("reading report.json: {0}")]
    ReportJson(#[from] serde_json::Error),
    /// Counting a method's instructions under callgrind failed.
    #[error("counting the instructions of {method} under callgrind: {detail}")]
    Instructions { method: String, detail: String },
    /// Drawing the plot.
    #[error("drawing the plot: {0}")]
    Plot(#[from] plotters::drawing::DrawingAreaErrorKind<std::io::Error>),
}

/// A compared method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MethodKind {
    Thesis,
    /// The signed method as a spec gets it by default: contacts at the nearest point of the
    /// continuous wall.
    Default,
    /// The signed method reading each sample in its own cross-section (the spec's
    /// `nearest: false`, the `sections` reading; the default before 2026-12-05).
    Sections,
    /// `sections` with one axial re-projection of every reading (the spec's `refine: 1`).
    Refined,
    Parry,
}

impl MethodKind {
    /// All five, in report order.
    pub const ALL: [MethodKind; 5] = [MethodKind::Default, MethodKind::Sections, MethodKind::Refined, MethodKind::Thesis, MethodKind::Parry];

    /// `thesis`, `default`, `sections`, `refined` or `parry`.
    pub fn name(self) -> &'static str {
        match self {
            MethodKind::Thesis => "thesis",
            MethodKind::Default => "default",
            MethodKind::Sections => "sections",
            MethodKind::Refined => "refined",
            MethodKind::Parry => "parry",
        }
    }

    /// The method named `s`.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == s)
    }
}

/// What to sweep. [`Options::full`] is `lumen bench detect`, [`Options::quick`] is
/// `lumen bench detect --quick`; the command line maps onto it as:
///
/// | flag | field |
/// |---|---|
/// | `--quick` | start from [`Options::quick`] instead of [`Options::full`] |
/// | `--scene gca\|generated\|insufflated\|all` (default `all`) | [`Options::scenes`] ([`Options::set_scene`]) |
/// | `--data PATH` (folder with the GCA colon's `colon_20k_mm.obj` and `centerline_mm.csv`) | [`Options::data`] |
/// | `--model FILE` (a model written by `lumen import`; alone unless `--scene` is given too) | [`Options::model`] |
/// | `--out DIR` (default `bench-out`) | not here: `run(...)?.write(DIR)` |
///
/// Every other field has a sensible value in both presets; the standalone binary
/// (`cargo run --release -p lumen-bench -- --help`) exposes a few more.
#[derive(Debug, Clone, Serialize)]
pub struct Options {
    /// The reduced sweep (for the report's title).
    pub quick: bool,
    /// Scenes, in order.
    pub scenes: Vec<ColonKind>,
    /// Folder of the GCA colon; `None`: `../shared/data/colon-gca00090` next to the workspace.
    pub data: Option<PathBuf>,
    /// A model file (what `lumen import` writes, or the text format), run after
    /// [`Options::scenes`] as the scene `model` at its own rings and spokes ([`Options::spokes`]
    /// do not apply; the rings-doubled check runs `longer` only, as a model cannot be rebuilt
    /// denser). A file that cannot be read is an error naming it, not a skipped scene.
    pub model: Option<PathBuf>,
    /// Precisions `x`.
    pub precisions: Vec<u32>,
    /// Spokes `B` (each rebuilds the colon).
    pub spokes: Vec<usize>,
    /// Methods, in timing order.
    pub methods: Vec<MethodKind>,
    /// Frames of the sequence (1 mm per frame).
    pub frames: usize,
    /// Untimed frames at the start of every pass.
    pub warmup: usize,
    /// Passes per method; each frame keeps its fastest time.
    pub repeats: usize,
    /// Judge every `eval_every`-th frame against the reference...
    pub eval_every: usize,
    /// ...and every `eval_escapes_every`-th frame with escaped control points (0: no more).
    pub eval_escapes_every: usize,
    /// Axial subdivisions of the reference per ring segment, generated colon.
    pub reference_steps_generated: usize,
    /// Same, real colon.
    pub reference_steps_gca: usize,
    /// Half-length of the reference's windows along the colon (mm; 0: one reference of the whole
    /// colon). See [`metrics::Truth`].
    pub reference_window_mm: f32,
    /// Threads building the references (judging only; timing is always single-threaded and
    /// never runs alongside).
    pub threads: usize,
    /// Seed of the generated colon and of the insertion's escapes.
    pub seed: u64,
    /// Length of the generated colon (mm).
    pub generated_length_mm: f32,
    /// Ring spacing of the generated colon (mm).
    pub generated_ring_spacing_mm: f32,
    /// Precision of the summary tables and of the rings-doubled check.
    pub default_precision: u32,
    /// Spokes of the summary tables and of the rings-doubled check.
    pub doubled_spokes: usize,
    /// Run the rings-doubled check.
    pub rings_doubled: bool,
    /// How the parry baseline models the endoscope.
    pub parry_shape: ParryShape,
    /// Axial refinements of the default method ([`lumen_detect::Detector::set_refine`]; 0, the
    /// detector's default).
    pub refine: u32,
    /// Contact margin of the detectors = parry's prediction distance (mm).
    pub margin: f32,
    /// Count each method's instructions per frame under callgrind, at the summary's precision
    /// and spokes ([`instructions`]).
    pub instructions: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self::full()
    }
}

impl Options {
    /// The full sweep: both scenes, `x` in {1, 2, 4, 8, 16}, `B` in {16, 32, 64}, 256 frames (16
    /// warm-up), 3 passes, every 32nd frame judged (and every 8th while control points are
    /// pushed through the wall), against references of 32 subdivisions per ring segment.
    pub fn full() -> Self {
        Self {
            quick: false,
            scenes: vec![ColonKind::Generated, ColonKind::Gca],
            data: None,
            model: None,
            precisions: vec![1, 2, 4, 8, 16],
            spokes: vec![16, 32, 64],
            methods: MethodKind::ALL.to_vec(),
            frames: 256,
            warmup: 16,
            repeats: 3,
            eval_every: 32,
            eval_escapes_every: 8,
            reference_steps_generated: 32,
            reference_steps_gca: 32,
            reference_window_mm: 60.0,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            seed: 7,
            generated_length_mm: 1500.0,
            generated_ring_spacing_mm: 1.2,
            default_precision: 4,
            doubled_spokes: 32,
            rings_doubled: true,
            parry_shape: ParryShape::RoundSegments,
            refine: 0,
            margin: 0.0,
            instructions: false,
        }
    }

    /// The reduced sweep (under a minute on a 2-core machine): `B` = 32, `x` in {1, 4, 16},
    /// 48 frames (8 warm-up), 1 pass, frames 0, 24 and every 8th with escapes judged, against a
    /// coarser reference (8 subdivisions: its bound, reported, is near 0.1 mm where the wall is
    /// deformed).
    pub fn quick() -> Self {
        Self {
            quick: true,
            precisions: vec![1, 4, 16],
            spokes: vec![32],
            frames: 48,
            warmup: 8,
            repeats: 1,
            eval_every: 24,
            eval_escapes_every: 8,
            reference_steps_generated: 8,
            reference_steps_gca: 8,
            ..Self::full()
        }
    }

    /// `--scene`: `gca`, `generated`, `insufflated` (a generated surface whose lumen is wider than
    /// its bends, imported: [`lumen_scene::insufflated`], at the bench's seed) or `all` (generated
    /// and gca).
    pub fn set_scene(&mut self, scene: &str) -> Result<(), Error> {
        self.scenes = match scene {
            "gca" => vec![ColonKind::Gca],
            "generated" => vec![ColonKind::Generated],
            "insufflated" => vec![ColonKind::Insufflated],
            "all" => vec![ColonKind::Generated, ColonKind::Gca],
            other => return Err(Error::BadFlag { flag: "--scene", value: other.to_owned(), expected: "gca, generated, insufflated or all" }),
        };
        Ok(())
    }

    /// The options of `lumen bench detect [--quick] [--scene S] [--data PATH]`.
    pub fn from_flags(quick: bool, scene: Option<&str>, data: Option<PathBuf>) -> Result<Self, Error> {
        let mut o = if quick { Self::quick() } else { Self::full() };
        if let Some(s) = scene {
            o.set_scene(s)?;
        }
        o.data = data;
        Ok(o)
    }

    fn check(&self) -> Result<(), Error> {
        if (self.scenes.is_empty() && self.model.is_none()) || self.methods.is_empty() || self.precisions.is_empty() || self.spokes.is_empty() {
            return Err(Error::EmptySweep);
        }
        if let Some(&x) = self.precisions.iter().find(|&&x| !(1..=64).contains(&x) || !metrics::DENSE_PER_SEGMENT.is_multiple_of(x as usize)) {
            return Err(Error::Precision { x });
        }
        if let Some(&spokes) = self.spokes.iter().find(|&&b| !(3..=256).contains(&b)) {
            return Err(Error::Spokes { spokes });
        }
        if self.frames <= self.warmup {
            return Err(Error::Frames { frames: self.frames, warmup: self.warmup });
        }
        if !(self.margin >= 0.0 && self.margin.is_finite()) {
            return Err(Error::Margin { margin: self.margin });
        }
        Ok(())
    }
}

fn notes(opts: &Options) -> Vec<String> {
    vec![
        format!("Frames: the kinematic insertion of lumen-scene (160-point, 13 mm scope, 1 mm per frame, wall deformed where pressed, seeded escapes), seed {}; {} frames per scene, the first {} of each pass untimed.", opts.seed, opts.frames, opts.warmup),
        "Timing: single thread; each frame's state copied into ONE buffer rewritten every frame (as a physics engine writes in place), only the detection call timed. Each method runs the whole sequence in its own pass with a fresh detector.".into(),
        format!("Repeats: {} pass(es) per method, methods interleaved; each frame keeps its fastest time (the machine is shared; this filters other processes out).", opts.repeats),
        "Ratios (time / default, speedup vs thesis, speedup vs parry) are medians of per-frame ratios on the same frames in the same run.".into(),
        "default = Method::Signed through Detector::detect_prevalidated: every frame was validated once (StateLayout::check) when the sequence was built, as the daemon validates frames on receipt. thesis = Method::Thesis, timed the same way.".into(),
        format!("parry = parry3d 0.31: the wall as a TriMesh (tips as vertices, 2 triangles per ring x spoke quad, DEFORMABLE), vertices rewritten and BVH refit in place every frame (TriMesh::update_vertices, no rebuild); the rod sampled x per segment on the same Catmull-Rom, one capsule per pair of samples, {}, query::contact against the mesh with prediction = margin ({} mm); the contact is placed at the capsule's axis point under it and given to the nearer sample (deepest kept).", match opts.parry_shape { ParryShape::Capsules => "queried as a Capsule everywhere", ParryShape::RoundSegments => "queried as its axis Segment with the radius added to the prediction (GJK distance, no EPA), and as a Capsule where the axis comes within r/2 of the wall" }, opts.margin),
        format!("Accuracy: against lumen-oracle's dense reference of each judged frame's deformed wall, {} subdivisions per ring segment on the generated colon and {} on the real one (the global bound and the local bound at judged points are reported); judged frames: every {}th, and every {}th with escaped control points. Only the rod's segments inside the colon are judged.", opts.reference_steps_generated, opts.reference_steps_gca, opts.eval_every, opts.eval_escapes_every),
        format!("Reference windows: each point is judged against a reference of the colon within {:.0} mm of midline of its own place (the insertion's arc length), not the whole colon: where loops overlap (the real colon inflated x2 touches itself), the nearest wall of the whole colon can be another loop's. Points whose nearest wall point is on or within {} mm of a folded cell (neighbouring rings crossing, the wall passing through the lumen) or on a part of the colon more than {} mm of midline from the point's own place are not judged (counted as excluded).", opts.reference_window_mm, metrics::FOLD_MARGIN_MM, metrics::FOREIGN_MM),
        "Depth error: |reported depth - (sd + r)| at the point the method computed (the sample; parry: the capsule axis point), sd = reference signed distance. False contact: reference gap -(sd + r) >= 0.1 mm. Missed: dense rod points (64 per segment) penetrating >= 0.1 mm with no reported contact within one sample spacing; counted as places (runs of consecutive points), dense points in parentheses.".into(),
        "Normal error: angle to the reference normal at the nearest wall point; where two wall points are equally near that normal is ill-defined, so the reference normal at the method's own wall point is also accepted, and on a crease of the wall, where neither face's normal is the wall's, so is the distance's own direction (from the point to its reference wall point, outward, where they lie 0.05 mm apart or more); the smallest angle counts.".into(),
        "Escapes: samples whose centre is outside the reference wall (sd > 0); detected when the method reports a contact there with depth >= r - 0.1 mm and a normal within 90 degrees of the reference's outward normal.".into(),
        "Rings doubled: the default method at the default precision on the same scene rebuilt with half the ring spacing (denser: same insertion and seed, so the same endoscope up to the colon's finer sampling), and on the same frames with the colon extended past its last ring by as many rings again (longer: the very same endoscope and contacts).".into(),
    ]
}

/// Runs the sweep of `opts`, with a progress bar on stderr when `progress`. Scenes whose data
/// is absent are skipped (listed in [`Report::skipped`], and said on stderr); an error if none
/// remains.
pub fn run(opts: &Options, progress: bool) -> Result<Report, Error> {
    opts.check()?;
    let t0 = Instant::now();
    let model = opts.model.as_deref().map(scenes::Model::read).transpose()?;
    let mut skipped = Vec::new();
    let mut gca = None;
    let mut kinds = Vec::new();
    for &k in &opts.scenes {
        if k == ColonKind::Gca {
            match lumen_scene::gca::Source::read(opts.data.as_deref()) {
                Ok(g) => gca = Some(g),
                Err(e) => {
                    let msg = format!("gca scene skipped: {e}");
                    eprintln!("{msg}");
                    skipped.push(msg);
                    continue;
                }
            }
        }
        kinds.push(scenes::SceneKind::Colon(k));
    }
    if model.is_some() {
        kinds.push(scenes::SceneKind::Model);
    }
    if kinds.is_empty() {
        return Err(Error::NoScenes(skipped));
    }
    let per_b = 1 + opts.precisions.len() * opts.methods.len() * opts.repeats.max(1);
    let doubled = usize::from(opts.rings_doubled && opts.spokes.contains(&opts.doubled_spokes) && opts.methods.contains(&MethodKind::Default));
    let doubled_model = usize::from(opts.rings_doubled && opts.methods.contains(&MethodKind::Default));
    let total: usize = kinds.iter().map(|k| if *k == scenes::SceneKind::Model { per_b + doubled_model } else { opts.spokes.len() * per_b + doubled }).sum();
    let pb = if progress { ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::stderr()) } else { ProgressBar::hidden() };
    pb.set_style(ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}").expect("template").progress_chars("=> "));
    let mut report = Report {
        tool: format!("lumen-bench {}", env!("CARGO_PKG_VERSION")),
        git_revision: report::git_revision(),
        machine: report::Machine::this(),
        quick: opts.quick,
        options: serde_json::to_value(opts).unwrap_or_default(),
        method_notes: notes(opts),
        skipped,
        default_precision: opts.default_precision,
        default_spokes: opts.doubled_spokes,
        ..Report::default()
    };
    for k in kinds {
        let r = sweep::scene(k, opts, gca.as_ref(), model.as_ref(), &pb)?;
        report.scenes.extend(r.infos);
        report.runs.extend(r.runs);
        report.rings_doubled.extend(r.doubled);
        if k == scenes::SceneKind::Colon(ColonKind::Gca) {
            report.attribution.push(lumen_scene::gca::attribution().to_owned());
        }
    }
    pb.finish_and_clear();
    report.wall_s = t0.elapsed().as_secs_f64();
    Ok(report)
}
