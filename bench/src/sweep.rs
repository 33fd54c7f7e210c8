//! The sweep: every scene x spokes `B` x precision `x` x method, timed on the same frames in the
//! same run, then judged against the reference on a subset of frames.
//!
//! **Timing.** Each method runs the whole sequence in its own pass, with a fresh detector (so the
//! default method's coherence starts from nothing, as in a new session). Frame `f`'s state is
//! copied into ONE buffer (as a physics engine rewrites its state in place) and only the
//! detection call is timed (`Instant` around it). The first [`crate::Options::warmup`] frames of
//! a pass are not counted. With [`crate::Options::repeats`] > 1 the passes are repeated,
//! methods interleaved, and each frame keeps its fastest time (this 2-core machine is shared;
//! the minimum filters out other processes' interference, not the method's own variation, which
//! is the same every repeat). Single thread throughout.
//!
//! Ratios are pair by pair: for each timed frame, one method's time over another's on that
//! frame, and the median of those ratios.

use crate::baseline::ParryBaseline;
use crate::metrics::{evaluate, plan, Reported, Tally, Truth, TruthParams};
use crate::report::{RingsDoubled, Run, SceneInfo};
use crate::scenes::{self, Model, SceneData, SceneKind};
use crate::{Error, MethodKind, Options};
use indicatif::ProgressBar;
use lumen_detect::{Detector, Method, SceneSpec};
use lumen_scene::gca::Source;
use std::time::Instant;

/// The timed figures of one pass (or the per-frame minimum of several).
#[derive(Debug, Clone, Default)]
pub struct Timing {
    /// Per timed frame, nanoseconds.
    pub ns: Vec<u64>,
    /// Contacts per frame, averaged over timed frames.
    pub contacts: f64,
    /// Default method: samples that re-acquired through the BVH, averaged.
    pub reacquired: f64,
}

/// The method's detector, or the parry baseline.
pub(crate) enum Runner {
    Detector(Detector),
    Parry(ParryBaseline),
}

impl Runner {
    /// A fresh runner of `method` for `spec` (`state` builds parry's mesh).
    pub(crate) fn new(spec: &SceneSpec, state: &[f32], method: MethodKind, opts: &Options) -> Result<Self, Error> {
        Ok(match method {
            MethodKind::Parry => Runner::Parry(ParryBaseline::new(spec, state, opts.parry_shape)?),
            _ => {
                let mut d = Detector::new(&spec.validate()?);
                if matches!(method, MethodKind::Default | MethodKind::Sections) {
                    d.set_refine(opts.refine);
                }
                Runner::Detector(d)
            }
        })
    }

    /// Detects one frame; the number of contacts.
    pub(crate) fn detect(&mut self, state: &[f32]) -> Result<usize, Error> {
        match self {
            Runner::Detector(d) => d.detect_prevalidated(state).map(|c| c.len()).map_err(Error::Detect),
            Runner::Parry(p) => Ok(p.detect(state).len()),
        }
    }
}

/// Spec of `scene` at precision `x` for `method`.
pub fn spec_for(scene: &SceneData, x: u32, method: MethodKind) -> SceneSpec {
    let mut s = scene.spec.clone();
    s.precision = x;
    s.method = match method {
        MethodKind::Thesis => Method::Thesis,
        _ => Method::Signed,
    };
    s.nearest = !matches!(method, MethodKind::Sections | MethodKind::Refined);
    s.refine = u32::from(method == MethodKind::Refined);
    s
}

/// One pass of `method` over every frame of `scene`. With `record`, the contacts of the judged
/// frames (`scene.eval`, in order) are appended there, one entry per judged frame.
pub fn pass(scene: &SceneData, x: u32, method: MethodKind, opts: &Options, buf: &mut Vec<f32>, mut record: Option<&mut Vec<Vec<Reported>>>) -> Result<Timing, Error> {
    let spec = spec_for(scene, x, method);
    let mut runner = Runner::new(&spec, scene.state(0), method, opts)?;
    buf.clear();
    buf.extend_from_slice(scene.state(0));
    let mut t = Timing { ns: Vec::with_capacity(scene.frames), ..Timing::default() };
    let mut next_eval = 0;
    let (mut contacts, mut reacquired) = (0u64, 0u64);
    for f in 0..scene.frames {
        buf.copy_from_slice(scene.state(f));
        let t0 = Instant::now();
        let n = runner.detect(buf)?;
        let dt = t0.elapsed();
        std::hint::black_box(n);
        if f >= opts.warmup {
            t.ns.push(dt.as_nanos() as u64);
            contacts += n as u64;
            if let Runner::Detector(d) = &runner {
                reacquired += d.stats().reacquired as u64;
            }
        }
        if let Some(rec) = record.as_deref_mut() {
            if scene.eval.get(next_eval).is_some_and(|e| e.index == f) {
                next_eval += 1;
                rec.push(match &runner {
                    Runner::Detector(d) => d.contacts().iter().map(Reported::of_contact).collect(),
                    Runner::Parry(p) => p.contacts().iter().map(Reported::of_parry).collect(),
                });
            }
        }
    }
    let timed = t.ns.len().max(1) as f64;
    t.contacts = contacts as f64 / timed;
    t.reacquired = reacquired as f64 / timed;
    Ok(t)
}

/// Median and p99 (nearest rank) of nanoseconds, in microseconds.
pub fn median_p99_us(ns: &[u64]) -> (f64, f64) {
    let mut v: Vec<f32> = ns.iter().map(|&n| n as f32 / 1000.0).collect();
    let mut w = v.clone();
    (crate::metrics::percentile(&mut v, 50.0).unwrap_or(0.0), crate::metrics::percentile(&mut w, 99.0).unwrap_or(0.0))
}

/// Median over frames of `a[f] / b[f]`.
pub fn pairwise_ratio(a: &[u64], b: &[u64]) -> Option<f64> {
    if a.is_empty() || a.len() != b.len() {
        return None;
    }
    let mut r: Vec<f32> = a.iter().zip(b).map(|(&x, &y)| x as f32 / (y.max(1)) as f32).collect();
    crate::metrics::percentile(&mut r, 50.0)
}

/// Everything the sweep produced for one scene.
pub struct SceneResult {
    pub infos: Vec<SceneInfo>,
    pub runs: Vec<Run>,
    pub doubled: Vec<RingsDoubled>,
}

/// Per configuration (precision, method): its contacts at each judged frame.
type Records = Vec<((u32, MethodKind), Vec<Vec<Reported>>)>;

fn timed_runs(scene: &SceneData, opts: &Options, pb: &ProgressBar, records: &mut Records) -> Result<Vec<Run>, Error> {
    let mut runs = Vec::new();
    let mut buf = Vec::with_capacity(scene.floats);
    for &x in &opts.precisions {
        let mut best: Vec<Option<Timing>> = vec![None; opts.methods.len()];
        for rep in 0..opts.repeats.max(1) {
            for (mi, &m) in opts.methods.iter().enumerate() {
                pb.set_message(format!("{} B{} x{} {} (pass {}/{})", scene.kind.name(), scene.spokes, x, m.name(), rep + 1, opts.repeats.max(1)));
                let mut rec = Vec::new();
                let t = pass(scene, x, m, opts, &mut buf, (rep == 0).then_some(&mut rec))?;
                if rep == 0 {
                    records.push(((x, m), rec));
                }
                best[mi] = Some(match best[mi].take() {
                    None => t,
                    Some(mut b) => {
                        b.ns.iter_mut().zip(&t.ns).for_each(|(a, &n)| *a = (*a).min(n));
                        b
                    }
                });
                pb.inc(1);
            }
        }
        let best: Vec<Timing> = best.into_iter().map(|t| t.unwrap_or_default()).collect();
        let of = |k: MethodKind| opts.methods.iter().position(|&m| m == k).map(|i| &best[i].ns);
        for (mi, &m) in opts.methods.iter().enumerate() {
            let t = &best[mi];
            let (median_us, p99_us) = median_p99_us(&t.ns);
            let mean_us = t.ns.iter().map(|&n| n as f64).sum::<f64>() / t.ns.len().max(1) as f64 / 1000.0;
            runs.push(Run {
                scene: scene.kind.name().into(),
                method: m.name().into(),
                x,
                spokes: scene.spokes,
                rings: scene.rings,
                median_us,
                p99_us,
                mean_us,
                speedup_vs_thesis: of(MethodKind::Thesis).and_then(|o| pairwise_ratio(o, &t.ns)),
                speedup_vs_parry: of(MethodKind::Parry).and_then(|o| pairwise_ratio(o, &t.ns)),
                time_vs_default: of(MethodKind::Default).and_then(|o| pairwise_ratio(&t.ns, o)),
                frames_timed: t.ns.len(),
                contacts_per_frame: t.contacts,
                reacquired_per_frame: (m == MethodKind::Default).then_some(t.reacquired),
                ..Run::default()
            });
        }
        // Instructions at the summary's point only: each method's count runs under callgrind.
        let summary = x == opts.default_precision && (scene.spokes == opts.doubled_spokes || scene.kind == SceneKind::Model);
        if opts.instructions && summary {
            let dir = std::env::temp_dir().join(format!("lumen-bench-count-{}", std::process::id()));
            for (run, &m) in runs.iter_mut().rev().zip(opts.methods.iter().rev()) {
                pb.set_message(format!("{} B{} x{x} {}: instructions under callgrind", scene.kind.name(), scene.spokes, m.name()));
                run.instructions_per_frame = Some(crate::instructions::per_frame(scene, x, m, &dir)?);
            }
            let _ = std::fs::remove_dir(&dir);
        }
    }
    Ok(runs)
}

/// The scene of `kind` at `spokes` (a model at its own), rings `ring_factor` times denser; `None`
/// for a model asked for denser rings (it cannot be rebuilt).
fn build(kind: SceneKind, spokes: usize, ring_factor: f32, opts: &Options, gca: Option<&Source>, model: Option<&Model>, keep_eval: bool) -> Result<Option<SceneData>, Error> {
    match kind {
        SceneKind::Colon(k) => scenes::build(k, spokes, ring_factor, opts, gca, keep_eval).map(Some),
        SceneKind::Model if ring_factor == 1.0 => scenes::build_model(model.ok_or(Error::ModelNotLoaded)?, opts, keep_eval).map(Some),
        SceneKind::Model => Ok(None),
    }
}

/// Runs the sweep for one scene kind at every spoke count (a model at its own).
pub fn scene(kind: SceneKind, opts: &Options, gca: Option<&Source>, model: Option<&Model>, pb: &ProgressBar) -> Result<SceneResult, Error> {
    let mut out = SceneResult { infos: Vec::new(), runs: Vec::new(), doubled: Vec::new() };
    let steps = if kind.real() { opts.reference_steps_gca } else { opts.reference_steps_generated };
    let spokes = match (kind, model) {
        (SceneKind::Model, Some(m)) => vec![m.tube.spokes],
        _ => opts.spokes.clone(),
    };
    for &b in &spokes {
        pb.set_message(format!("{} B{b}: building frames", kind.name()));
        let t0 = Instant::now();
        let scene = build(kind, b, 1.0, opts, gca, model, true)?.ok_or(Error::NoFrames)?;
        let build_s = t0.elapsed().as_secs_f64();
        pb.inc_length(scene.eval.len() as u64);
        pb.inc(1);
        let mut records = Vec::new();
        let mut runs = timed_runs(&scene, opts, pb, &mut records)?;

        // Judge: one reference per judged frame, shared by every method and precision.
        let mut tallies: Vec<Tally> = records.iter().map(|_| Tally::default()).collect();
        let mut bounds = Vec::new();
        let mut folded = 0;
        let params = TruthParams { steps, window_mm: opts.reference_window_mm, threads: opts.threads.max(1) };
        let t0 = Instant::now();
        for (ei, ef) in scene.eval.iter().enumerate() {
            pb.set_message(format!("{} B{b}: reference of frame {} ({}/{})", kind.name(), ef.index, ei + 1, scene.eval.len()));
            let mut extra = Vec::new();
            let mut ranges = Vec::with_capacity(records.len());
            for ((x, _), rec) in &records {
                let start = extra.len();
                if let Some(contacts) = rec.get(ei) {
                    extra.extend(plan(contacts, *x as usize, &ef.arc_mm));
                }
                ranges.push(start..extra.len());
            }
            let truth = Truth::new(&ef.colon, &ef.scope, ef.inserted, &ef.arc_mm, scene.spec.alpha, params, &extra);
            bounds.push(truth.bound());
            folded = folded.max(truth.folded_cells());
            for ((((x, _), rec), tally), range) in records.iter().zip(tallies.iter_mut()).zip(ranges) {
                if let Some(contacts) = rec.get(ei) {
                    evaluate(&truth, *x as usize, ef.index, contacts, &truth.extra()[range], tally);
                }
            }
            pb.inc(1);
        }
        let judge_s = t0.elapsed().as_secs_f64();
        for (((x, m), _), tally) in records.iter().zip(&tallies) {
            if let Some(run) = runs.iter_mut().find(|r| r.x == *x && r.method == m.name()) {
                run.metrics = tally.metrics();
                run.findings = tally.findings.clone();
            }
        }
        out.infos.push(SceneInfo {
            scene: kind.name().into(),
            spokes: b,
            rings: scene.rings,
            frames: scene.frames,
            warmup: opts.warmup,
            escaping_frames: scene.escaping_frames,
            tip_depth_mm: scene.depth_mm,
            eval_frames: scene.eval.iter().map(|e| e.index).collect(),
            reference_steps: steps,
            reference_window_mm: opts.reference_window_mm,
            folded_cells: folded,
            reference_bound_mm: bounds.iter().copied().fold(0.0, f32::max) as f64,
            build_s,
            judge_s,
            import_report: scene.import.as_ref().map(|r| r.report.clone()),
            import_fidelity_mm: scene.import.as_ref().map(|r| r.fidelity_mm),
            import_kept_p99_mm: scene.import.as_ref().map(|r| r.kept_p99_mm),
            model: (kind == SceneKind::Model).then(|| model.map(|m| m.path.display().to_string())).flatten(),
            attribution: scene.attribution.map(str::to_owned),
        });
        out.runs.append(&mut runs);

        if opts.rings_doubled && (b == opts.doubled_spokes || kind == SceneKind::Model) && opts.methods.contains(&MethodKind::Default) {
            drop(scene);
            out.doubled = rings_doubled(kind, b, opts, gca, model, pb)?;
        }
    }
    Ok(out)
}

/// The default method at the default precision on the scene, on the same scene with twice the
/// rings at half the spacing (`denser`: same insertion and seed, so the same endoscope up to the
/// colon's finer sampling), and on the same frames with the colon extended past its last ring
/// by as many rings again (`longer`: the very same endoscope and contacts): per-frame times,
/// passes alternated. A model has no `denser`.
pub fn rings_doubled(kind: SceneKind, spokes: usize, opts: &Options, gca: Option<&Source>, model: Option<&Model>, pb: &ProgressBar) -> Result<Vec<RingsDoubled>, Error> {
    pb.set_message(format!("{} B{spokes}: rings doubled", kind.name()));
    let base = build(kind, spokes, 1.0, opts, gca, model, false)?.ok_or(Error::NoFrames)?;
    let denser = build(kind, spokes, 2.0, opts, gca, model, false)?;
    let longer = scenes::extended(&base, base.rings);
    let x = opts.default_precision;
    let mut buf = Vec::new();
    let mut times: [Option<Vec<u64>>; 3] = [None, None, None];
    let mut contacts = [0.0; 3];
    for _ in 0..opts.repeats.max(1) {
        for (i, sc) in [Some(&base), denser.as_ref(), Some(&longer)].into_iter().enumerate() {
            let Some(sc) = sc else { continue };
            let t = pass(sc, x, MethodKind::Default, opts, &mut buf, None)?;
            contacts[i] = t.contacts;
            match &mut times[i] {
                None => times[i] = Some(t.ns),
                Some(a) => a.iter_mut().zip(&t.ns).for_each(|(a, &n)| *a = (*a).min(n)),
            }
        }
    }
    pb.inc(1);
    let [tb, td, tl] = times.map(Option::unwrap_or_default);
    let (mb, pb99) = median_p99_us(&tb);
    let out = [("denser", denser.as_ref(), &td, contacts[1]), ("longer", Some(&longer), &tl, contacts[2])]
        .into_iter()
        .filter_map(|(how, sc, t, c)| sc.map(|sc| (how, sc, t, c)))
        .map(|(how, sc, t, c)| {
            let (m, p) = median_p99_us(t);
            RingsDoubled {
                scene: kind.name().into(),
                how: how.into(),
                method: MethodKind::Default.name().into(),
                x,
                spokes,
                rings: base.rings,
                rings_doubled: sc.rings,
                median_us: mb,
                p99_us: pb99,
                median_us_doubled: m,
                p99_us_doubled: p,
                ratio_of_medians: if mb > 0.0 { m / mb } else { 0.0 },
                pairwise_ratio: pairwise_ratio(t, &tb),
                contacts_per_frame: contacts[0],
                contacts_per_frame_doubled: c,
            }
        })
        .collect();
    Ok(out)
}
