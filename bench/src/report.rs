//! What the sweep found: [`Report`], written as `report.md` (tables), `report.json` (every
//! figure) and `speed_vs_error.svg` (time per frame against p99 depth error).

use crate::metrics::{Finding, Metrics};
use crate::Error;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// One configuration: scene, spokes, precision, method. Times in microseconds per frame;
/// speedups are medians of per-frame ratios (the other method's time over this one's, same
/// frame, same run); errors in mm and degrees. `None` (JSON `null`) where there is nothing to
/// measure (no contact judged, or the other method not run).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Run {
    pub scene: String,
    /// `thesis`, `default` or `parry`.
    pub method: String,
    pub x: u32,
    pub spokes: usize,
    pub rings: usize,
    pub median_us: f64,
    pub p99_us: f64,
    pub mean_us: f64,
    /// Median over frames of thesis time / this method's time.
    pub speedup_vs_thesis: Option<f64>,
    /// Median over frames of parry time / this method's time.
    pub speedup_vs_parry: Option<f64>,
    /// Median over frames of this method's time / the default's.
    pub time_vs_default: Option<f64>,
    pub frames_timed: usize,
    pub contacts_per_frame: f64,
    /// Default method: rod samples re-acquired through the BVH per frame.
    pub reacquired_per_frame: Option<f64>,
    /// Instructions per frame counted by callgrind (`--instructions`; at the summary's precision
    /// and spokes only).
    pub instructions_per_frame: Option<f64>,
    /// The accuracy figures (flattened: the JSON keeps one level).
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Located failures (at most a few per kind).
    pub findings: Vec<Finding>,
}

/// One scene at one spoke count.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct SceneInfo {
    pub scene: String,
    pub spokes: usize,
    pub rings: usize,
    pub frames: usize,
    pub warmup: usize,
    pub escaping_frames: usize,
    /// Tip depth at the first and last frame (mm of colon midline).
    pub tip_depth_mm: [f32; 2],
    /// Frames judged against the reference.
    pub eval_frames: Vec<usize>,
    pub reference_steps: usize,
    /// Half-length of the reference's windows (mm of midline; 0: whole colon).
    pub reference_window_mm: f32,
    /// Folded wall cells (neighbouring rings crossing) of the judged frames' colon, at most.
    pub folded_cells: usize,
    /// Largest global bound of the references (mm).
    pub reference_bound_mm: f64,
    /// Seconds to build the colon and its frames, and to build the references and judge.
    pub build_s: f64,
    pub judge_s: f64,
    pub import_report: Option<String>,
    /// The imported wall (before inflation) against the source surface: p50, p99, max (mm).
    /// An import that lost the wall cannot score well against its own tube unnoticed.
    pub import_fidelity_mm: Option<[f64; 3]>,
    /// The same p99 over the wall points drawn between kept spokes only (mm).
    pub import_kept_p99_mm: Option<f64>,
    /// The model file of the `model` scene.
    pub model: Option<String>,
    pub attribution: Option<String>,
}

/// The default method on a colon with twice the rings, same endoscope.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct RingsDoubled {
    pub scene: String,
    /// `denser` (half the ring spacing) or `longer` (the colon extended past its end).
    pub how: String,
    pub method: String,
    pub x: u32,
    pub spokes: usize,
    pub rings: usize,
    pub rings_doubled: usize,
    pub median_us: f64,
    pub p99_us: f64,
    pub median_us_doubled: f64,
    pub p99_us_doubled: f64,
    /// Doubled median over normal median.
    pub ratio_of_medians: f64,
    /// Median over frames of doubled time / normal time.
    pub pairwise_ratio: Option<f64>,
    pub contacts_per_frame: f64,
    pub contacts_per_frame_doubled: f64,
}

/// Where it ran.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Machine {
    pub cpu: String,
    pub cores: usize,
    pub os: String,
}

impl Machine {
    /// This machine: the CPU model from `/proc/cpuinfo` (or "unknown"), the cores the process
    /// may use.
    pub fn this() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| s.lines().find(|l| l.starts_with("model name")).and_then(|l| l.split_once(':')).map(|(_, v)| v.trim().to_owned()))
            .unwrap_or_else(|| "unknown".into());
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        Self { cpu, cores, os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH) }
    }
}

/// The git revision (`git rev-parse --short HEAD`), with `-dirty` when the working tree has
/// uncommitted changes under the paths that decide the results (`detect`, `sim`, `proto`,
/// `Cargo.lock`), or "unknown" without git.
pub fn git_revision() -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git").args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().ok().filter(|o| o.status.success()).and_then(|o| String::from_utf8(o.stdout).ok())
    };
    let Some(rev) = git(&["rev-parse", "--short", "HEAD"]).map(|s| s.trim().to_owned()).filter(|s| !s.is_empty()) else {
        return "unknown".into();
    };
    let top = git(&["rev-parse", "--show-toplevel"]).map(|s| s.trim().to_owned()).unwrap_or_default();
    let paths = ["detect", "sim", "proto", "Cargo.lock"].map(|p| format!("{top}/{p}"));
    let mut args = vec!["status", "--porcelain", "--"];
    args.extend(paths.iter().map(String::as_str));
    match git(&args) {
        Some(s) if !s.trim().is_empty() => format!("{rev}-dirty"),
        _ => rev,
    }
}

/// Everything one sweep measured.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Report {
    pub tool: String,
    pub git_revision: String,
    pub machine: Machine,
    pub quick: bool,
    /// The options, as run.
    pub options: serde_json::Value,
    /// How things were measured, in words.
    pub method_notes: Vec<String>,
    pub scenes: Vec<SceneInfo>,
    pub runs: Vec<Run>,
    pub rings_doubled: Vec<RingsDoubled>,
    /// Scenes that could not run, and why.
    pub skipped: Vec<String>,
    /// Data credits (CC BY 4.0 for the GCA colon).
    pub attribution: Vec<String>,
    /// The precision of the summary tables and of the rings-doubled check.
    pub default_precision: u32,
    /// The spoke count of the summary tables.
    pub default_spokes: usize,
    pub wall_s: f64,
}

fn f(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        _ => "-".into(),
    }
}

/// A number for an axis label: two significant digits, no exponent between 1e-4 and 1e7.
fn short(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    if !(1e-4..1e7).contains(&a) {
        return format!("{v:.1e}");
    }
    let mag = a.log10().floor() as i32;
    let step = 10f64.powi(mag - 1);
    let r = (v / step).round() * step;
    if mag >= 1 {
        format!("{r:.0}")
    } else {
        format!("{r:.*}", (1 - mag) as usize)
    }
}

fn method_rank(m: &str) -> usize {
    match m {
        "default" => 0,
        "sections" => 1,
        "refined" => 2,
        "thesis" => 3,
        "parry" => 4,
        _ => 5,
    }
}

impl Report {
    /// The runs of `scene` at spokes `b` and precision `x`, default first.
    pub fn runs_at(&self, scene: &str, b: usize, x: u32) -> Vec<&Run> {
        let mut v: Vec<&Run> = self.runs.iter().filter(|r| r.scene == scene && r.spokes == b && r.x == x).collect();
        v.sort_by_key(|r| method_rank(&r.method));
        v
    }

    /// The run of `method` at `scene`, `b`, `x`.
    pub fn run(&self, scene: &str, method: &str, b: usize, x: u32) -> Option<&Run> {
        self.runs.iter().find(|r| r.scene == scene && r.method == method && r.spokes == b && r.x == x)
    }

    /// The spoke count a scene is summarised at: the report's default, or a model's own when it
    /// was run at another.
    pub fn summary_spokes(&self, scene: &str) -> usize {
        let b = self.default_spokes;
        if self.runs.iter().any(|r| r.scene == scene && r.spokes == b) {
            return b;
        }
        self.runs.iter().find(|r| r.scene == scene).map_or(b, |r| r.spokes)
    }

    /// What a scene's import measured, for the summaries: `wall to surface p50 / p99 / max`, or
    /// that a model file does not store it; `None` for a generated colon.
    pub fn fidelity_note(&self, scene: &str) -> Option<String> {
        let i = self.scenes.iter().find(|i| i.scene == scene)?;
        match i.import_fidelity_mm {
            Some([a, b, c]) => Some(format!("wall to surface p50 / p99 / max {a:.3} / {b:.3} / {c:.2} mm")),
            None if i.model.is_some() => Some("wall to surface not stored in the model file".into()),
            None => None,
        }
    }

    /// The scenes run, in order.
    pub fn scene_names(&self) -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for r in &self.runs {
            if !v.contains(&r.scene) {
                v.push(r.scene.clone());
            }
        }
        v
    }

    fn table_header() -> &'static str {
        "| scene | B | rings | x | method | median us | p99 us | instructions / frame | time / default | speedup vs thesis | speedup vs parry | contacts/frame | missed (dense pts) | false | depth err mean / p99 / max mm | normal err p50 / p99 deg | escapes detected |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    }

    fn table_row(r: &Run) -> String {
        format!(
            "| {} | {} | {} | {} | {} | {:.1} | {:.1} | {} | {} | {} | {} | {:.1} | {} ({}) | {} | {} / {} / {} | {} / {} | {} / {} |\n",
            r.scene,
            r.spokes,
            r.rings,
            r.x,
            r.method,
            r.median_us,
            r.p99_us,
            r.instructions_per_frame.map_or("-".into(), |n| format!("{:.3} M", n / 1e6)),
            f(r.time_vs_default, 2),
            f(r.speedup_vs_thesis, 1),
            f(r.speedup_vs_parry, 1),
            r.contacts_per_frame,
            r.metrics.missed,
            r.metrics.missed_dense,
            r.metrics.false_contacts,
            f(r.metrics.depth_err_mean_mm, 4),
            f(r.metrics.depth_err_p99_mm, 4),
            f(r.metrics.depth_err_max_mm, 3),
            f(r.metrics.normal_err_p50_deg, 2),
            f(r.metrics.normal_err_p99_deg, 2),
            r.metrics.escaped_detected,
            r.metrics.escaped_total
        )
    }

    /// `report.md`.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# lumen bench detect{}\n", if self.quick { " (quick)" } else { "" });
        let _ = writeln!(s, "Revision `{}`; {} ({} cores usable, single thread used); {:.0} s in all.\n", self.git_revision, self.machine.cpu, self.machine.cores, self.wall_s);
        let (x, b) = (self.default_precision, self.default_spokes);
        let _ = writeln!(s, "## At the default precision (x = {x}, B = {b}; a model at its own B)\n");
        s.push_str(Self::table_header());
        for scene in self.scene_names() {
            for r in self.runs_at(&scene, self.summary_spokes(&scene), x) {
                s.push_str(&Self::table_row(r));
            }
        }
        s.push('\n');
        for i in self.scenes.iter().filter(|i| i.model.is_some()) {
            let _ = writeln!(s, "`{}` is the model file `{}`: {}.\n", i.scene, i.model.as_deref().unwrap_or(""), self.fidelity_note(&i.scene).unwrap_or_default());
        }
        s.push_str(&self.targets());
        if !self.rings_doubled.is_empty() {
            s.push_str("## Rings doubled (same endoscope)\n\n`denser`: twice the rings at half the spacing (same insertion and seed); `longer`: the same frames with the colon extended past its last ring by as many rings again (the very same endoscope and contacts). Passes alternated in the same run.\n\n| scene | how | method | x | B | rings | median us | p99 us | rings doubled | median us | p99 us | ratio of medians | per-frame ratio (median) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
            for d in &self.rings_doubled {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {:.1} | {:.1} | {} | {:.1} | {:.1} | {:.3} | {} |",
                    d.scene,
                    d.how,
                    d.method,
                    d.x,
                    d.spokes,
                    d.rings,
                    d.median_us,
                    d.p99_us,
                    d.rings_doubled,
                    d.median_us_doubled,
                    d.p99_us_doubled,
                    d.ratio_of_medians,
                    f(d.pairwise_ratio, 3)
                );
            }
            s.push('\n');
        }
        s.push_str("## Every configuration\n\n");
        s.push_str(Self::table_header());
        let mut all: Vec<&Run> = self.runs.iter().collect();
        all.sort_by(|a, b| (&a.scene, a.spokes, a.x, method_rank(&a.method)).cmp(&(&b.scene, b.spokes, b.x, method_rank(&b.method))));
        for r in all {
            s.push_str(&Self::table_row(r));
        }
        s.push('\n');
        s.push_str("## Scenes and references\n\n| scene | B | rings | frames (warm-up) | tip depth mm | frames with escapes | judged frames | reference steps | reference bound mm (global, max) | local bound at judged contacts, p99 / max mm (default, x) | build s | judge s |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for i in &self.scenes {
            let d = self.run(&i.scene, "default", i.spokes, x);
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} ({}) | {:.0}-{:.0} | {} | {} ({}) | {} | {:.4} | {} / {} | {:.1} | {:.1} |",
                i.scene,
                i.spokes,
                i.rings,
                i.frames,
                i.warmup,
                i.tip_depth_mm[0],
                i.tip_depth_mm[1],
                i.escaping_frames,
                i.eval_frames.len(),
                i.eval_frames.iter().map(|f| f.to_string()).collect::<Vec<_>>().join(","),
                i.reference_steps,
                i.reference_bound_mm,
                f(d.and_then(|d| d.metrics.reference_local_bound_p99_mm), 4),
                f(d.and_then(|d| d.metrics.reference_local_bound_max_mm), 4),
                i.build_s,
                i.judge_s
            );
        }
        s.push('\n');
        for i in self.scenes.iter().filter(|i| i.import_report.is_some()) {
            let _ = writeln!(s, "Import, {} B = {}: {}\n", i.scene, i.spokes, i.import_report.as_deref().unwrap_or(""));
        }
        let imported: Vec<&SceneInfo> = self.scenes.iter().filter(|i| i.import_fidelity_mm.is_some() || i.model.is_some()).collect();
        if !imported.is_empty() {
            s.push_str("## Import fidelity\n\nThe detection errors are judged against the imported tube's own wall; this is how far that wall (before inflation) lies from the source surface, so a bad import cannot look good.\n\n| scene | B | wall to surface p50 / p99 / max mm | p99 between kept spokes only mm |\n|---|---|---|---|\n");
            for i in imported {
                match i.import_fidelity_mm {
                    Some([a, b, c]) => {
                        let _ = writeln!(s, "| {} | {} | {a:.3} / {b:.3} / {c:.2} | {} |", i.scene, i.spokes, f(i.import_kept_p99_mm, 3));
                    }
                    None => {
                        let _ = writeln!(s, "| {} | {} | not stored in the model file (not written by `lumen import`, or the text format) | - |", i.scene, i.spokes);
                    }
                }
            }
            s.push('\n');
        }
        let findings: Vec<(&Run, &Finding)> = self.runs.iter().filter(|r| r.method == "default").flat_map(|r| r.findings.iter().map(move |f| (r, f))).collect();
        s.push_str("## Where the default method disagrees with the reference\n\n");
        if findings.is_empty() {
            s.push_str("Nowhere beyond the tolerances (depth 0.05 mm, normal 3 degrees, gap / penetration 0.1 mm).\n\n");
        } else {
            s.push_str("At most a few per kind and configuration; `sample` counts at the run's precision (`segment * x + step`, tip first).\n\n| scene | B | x | kind | frame | sample | point mm | reported depth | reference depth | normal err deg | reference sd at the method's wall point (* on a fold or another loop) | ring, spoke, param, flags | local ref bound |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
            for (r, g) in findings {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | ({:.2}, {:.2}, {:.2}) | {} | {:.4} | {} | {}{} | {} | {:.4} |",
                    r.scene,
                    r.spokes,
                    r.x,
                    g.kind,
                    g.frame,
                    g.sample,
                    g.point[0],
                    g.point[1],
                    g.point[2],
                    f(g.reported_depth.map(f64::from), 4),
                    g.reference_depth,
                    f(g.normal_err_deg.map(f64::from), 2),
                    f(g.reported_wall_sd.map(f64::from), 3),
                    if g.reported_wall_excluded == Some(true) { " *" } else { "" },
                    g.place.map_or("-".into(), |p| format!("{}, {}, {:.3}, {}", p.ring, p.spoke, p.param, p.flags)),
                    g.reference_local_bound_mm
                );
            }
            s.push('\n');
        }
        s.push_str("## How it was measured\n\n");
        for n in &self.method_notes {
            let _ = writeln!(s, "- {n}");
        }
        s.push('\n');
        if !self.skipped.is_empty() {
            s.push_str("## Skipped\n\n");
            for k in &self.skipped {
                let _ = writeln!(s, "- {k}");
            }
            s.push('\n');
        }
        if !self.attribution.is_empty() {
            s.push_str("## Data\n\n");
            for a in &self.attribution {
                let _ = writeln!(s, "Results on the `gca` scene derive from: {a}.");
            }
            s.push('\n');
        }
        s
    }

    /// The targets (stated for the real colon, 32 spokes, default precision), checked
    /// on every scene.
    pub fn targets(&self) -> String {
        let (x, b) = (self.default_precision, self.default_spokes);
        let scenes: Vec<String> = self.scene_names().into_iter().filter(|sc| self.run(sc, "default", self.summary_spokes(sc), x).is_some()).collect();
        if scenes.is_empty() {
            return String::new();
        }
        let mut s = format!("## Against the issue's targets (x = {x}, B = {b}, a model at its own; the issue states them for `gca`)\n\n| target |");
        for sc in &scenes {
            let _ = write!(s, " {sc} |");
        }
        s.push_str("\n|---|");
        s.push_str(&"---|".repeat(scenes.len()));
        s.push('\n');
        let mark = |ok: bool| if ok { "met" } else { "**not met**" };
        let p99 = |r: Option<&Run>| r.and_then(|r| r.metrics.depth_err_p99_mm);
        let mut row = |name: &str, cell: &dyn Fn(&str) -> String| {
            let _ = write!(s, "| {name} |");
            for sc in &scenes {
                let _ = write!(s, " {} |", cell(sc));
            }
            s.push('\n');
        };
        row("default: median <= 20 us per frame", &|sc| {
            let d = self.run(sc, "default", self.summary_spokes(sc), x).unwrap();
            format!("{:.1} us, {}", d.median_us, mark(d.median_us <= 20.0))
        });
        for (other, want) in [("thesis", 10.0), ("parry", 50.0)] {
            row(&format!(">= {want:.0}x faster than {other}, at equal or lower p99 depth error"), &|sc| {
                let d = self.run(sc, "default", self.summary_spokes(sc), x).unwrap();
                let o = self.run(sc, other, self.summary_spokes(sc), x);
                let speed = if other == "thesis" { d.speedup_vs_thesis } else { d.speedup_vs_parry };
                match (speed, p99(Some(d)), p99(o)) {
                    (Some(v), Some(ed), Some(eo)) => format!("{v:.1}x, p99 {ed:.3} vs {eo:.3} mm, {}", mark(v >= want && ed <= eo)),
                    (Some(v), _, _) => format!("{v:.1}x, p99 not comparable"),
                    _ => "not run".into(),
                }
            });
        }
        row("zero missed contacts", &|sc| {
            let d = self.run(sc, "default", self.summary_spokes(sc), x).unwrap();
            format!("{} ({} dense points), {}", d.metrics.missed, d.metrics.missed_dense, mark(d.metrics.missed == 0))
        });
        row("p99 depth error <= 0.05 mm", &|sc| {
            let d = self.run(sc, "default", self.summary_spokes(sc), x).unwrap();
            match d.metrics.depth_err_p99_mm {
                Some(e) => format!("{e:.4} mm, {}", mark(e <= 0.05)),
                None => "no contact judged".into(),
            }
        });
        row("p99 normal error <= 3 degrees", &|sc| {
            let d = self.run(sc, "default", self.summary_spokes(sc), x).unwrap();
            match d.metrics.normal_err_p99_deg {
                Some(e) => format!("{e:.2} deg, {}", mark(e <= 3.0)),
                None => "no contact judged".into(),
            }
        });
        row("all escaped samples detected", &|sc| {
            let d = self.run(sc, "default", self.summary_spokes(sc), x).unwrap();
            format!("{} / {}, {}", d.metrics.escaped_detected, d.metrics.escaped_total, mark(d.metrics.escaped_detected == d.metrics.escaped_total))
        });
        for how in ["denser", "longer"] {
            row(&format!("doubling the rings ({how}) changes the time by < 10%"), &|sc| match self.rings_doubled.iter().find(|r| r.scene == *sc && r.how == how) {
                Some(r) => format!("{:+.1}% (medians), {}", 100.0 * (r.ratio_of_medians - 1.0), mark((r.ratio_of_medians - 1.0).abs() < 0.10)),
                None if how == "denser" && self.scenes.iter().any(|i| i.scene == *sc && i.model.is_some()) => "not run (a model file is not rebuilt denser)".into(),
                None => "not run".into(),
            });
        }
        s.push('\n');
        s
    }

    /// `speed_vs_error.svg`: per scene, time per frame (median, log) against p99 depth error
    /// (log), one series per method; lines join a method's precisions at the default spoke
    /// count, every point is labelled `x, B`.
    pub fn svg(&self) -> Result<String, Error> {
        let scenes = self.scene_names();
        let panels = scenes.len().max(1);
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, (620 * panels as u32, 600)).into_drawing_area();
            root.fill(&WHITE)?;
            let title = format!("Lumen collision methods: speed against error ({}, rev {}, {})", if self.quick { "quick sweep" } else { "full sweep" }, self.git_revision, self.machine.cpu);
            let (top, rest) = root.split_vertically(40);
            top.draw(&Text::new(title, (12, 12), ("sans-serif", 18).into_font()))?;
            let (body, foot) = rest.split_vertically(540);
            if self.attribution.is_empty() {
                foot.draw(&Text::new("Lower left is better; the Pareto front is the lower-left envelope.".to_string(), (12, 2), ("sans-serif", 13).into_font()))?;
            } else {
                foot.draw(&Text::new(format!("Lower left is better. gca: {}", self.attribution.join("; ")), (12, 2), ("sans-serif", 12).into_font()))?;
            }
            let areas = body.split_evenly((1, panels));
            const FLOOR: f64 = 1e-4;
            let colour = |m: &str| match m {
                "default" => RGBColor(0, 114, 178),
                "sections" => RGBColor(204, 121, 167),
                "refined" => RGBColor(86, 180, 233),
                "thesis" => RGBColor(213, 94, 0),
                "parry" => RGBColor(0, 158, 115),
                _ => RGBColor(80, 80, 80),
            };
            for (area, scene) in areas.iter().zip(&scenes) {
                // Both axes in log10, labelled with the values themselves.
                let pts: Vec<(&Run, f64, f64)> =
                    self.runs.iter().filter(|r| &r.scene == scene && r.median_us > 0.0).map(|r| (r, r.median_us.log10(), r.metrics.depth_err_p99_mm.unwrap_or(FLOOR).max(FLOOR).log10())).collect();
                if pts.is_empty() {
                    continue;
                }
                let line_b = self.summary_spokes(scene);
                let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, 0.0f64, f64::MAX, 0.0f64);
                for &(_, t, e) in &pts {
                    x0 = x0.min(t);
                    x1 = x1.max(t);
                    y0 = y0.min(e);
                    y1 = y1.max(e);
                }
                let (x0, x1) = (x0 - 0.2, x1 + 0.2);
                let (y0, y1) = (y0 - 0.3, y1 + 0.3);
                let mut chart =
                    ChartBuilder::on(area).caption(format!("scene: {scene}"), ("sans-serif", 16)).margin(12).x_label_area_size(40).y_label_area_size(64).build_cartesian_2d(x0..x1, y0..y1)?;
                chart
                    .configure_mesh()
                    .x_desc("time per frame, median (us, log)")
                    .y_desc("p99 depth error (mm, log)")
                    .x_labels(10)
                    .y_labels(12)
                    .x_label_formatter(&|v| short(10f64.powf(*v)))
                    .y_label_formatter(&|v| short(10f64.powf(*v)))
                    .draw()?;
                // The 0.05 mm target.
                let target = 0.05f64.log10();
                if target > y0 && target < y1 {
                    chart
                        .draw_series(LineSeries::new(vec![(x0, target), (x1, target)], RGBColor(150, 150, 150).stroke_width(1)))?
                        .label("0.05 mm target")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], RGBColor(150, 150, 150)));
                }
                let mut methods: Vec<&str> = pts.iter().map(|p| p.0.method.as_str()).collect();
                methods.sort_by_key(|m| method_rank(m));
                methods.dedup();
                for m in methods {
                    let c = colour(m);
                    let mine: Vec<&(&Run, f64, f64)> = pts.iter().filter(|p| p.0.method == m).collect();
                    let mut line: Vec<(f64, f64)> = mine.iter().filter(|p| p.0.spokes == line_b).map(|p| (p.1, p.2)).collect();
                    line.sort_by(|a, b| a.0.total_cmp(&b.0));
                    chart
                        .draw_series(LineSeries::new(line, c.stroke_width(2)))?
                        .label(format!("{m} (line: B = {line_b})"))
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
                    chart.draw_series(mine.iter().map(|p| {
                        let filled = p.0.spokes == line_b;
                        Circle::new((p.1, p.2), 4, if filled { c.filled() } else { c.stroke_width(1) })
                    }))?;
                    chart.draw_series(mine.iter().map(|p| Text::new(format!("x{} B{}", p.0.x, p.0.spokes), (p.1, p.2), ("sans-serif", 10).into_font().color(&c))))?;
                }
                // Pareto front over every configuration of the scene.
                let mut sorted: Vec<(f64, f64)> = pts.iter().map(|p| (p.1, p.2)).collect();
                sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
                let mut front = Vec::new();
                let mut best = f64::INFINITY;
                for (t, e) in sorted {
                    if e < best {
                        best = e;
                        front.push((t, e));
                    }
                }
                chart.draw_series(DashedLineSeries::new(front, 6, 4, BLACK.stroke_width(1)))?.label("Pareto front").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
                chart.configure_series_labels().position(SeriesLabelPosition::LowerRight).background_style(WHITE.mix(0.85)).border_style(BLACK).label_font(("sans-serif", 12)).draw()?;
            }
            root.present()?;
        }
        Ok(out)
    }

    /// A report read back from its `report.json`.
    pub fn from_json(text: &str) -> Result<Self, Error> {
        Ok(serde_json::from_str(text)?)
    }

    /// `report.json`.
    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report serialises")
    }

    /// Writes `dir/report.md`, `dir/report.json` and `dir/speed_vs_error.svg`, creating `dir`.
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<(), Error> {
        let dir = dir.as_ref();
        let io = |p: &Path, source: std::io::Error| Error::Io { path: p.to_owned(), source };
        std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
        for (name, text) in [("report.md", self.markdown()), ("report.json", self.json()), ("speed_vs_error.svg", self.svg()?)] {
            let p = dir.join(name);
            std::fs::write(&p, text).map_err(|e| io(&p, e))?;
        }
        Ok(())
    }
}
