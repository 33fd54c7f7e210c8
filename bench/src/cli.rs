//! The command line of the sweep, shared by `lumen bench detect` and the standalone
//! `lumen-bench` binary: [`DetectArgs`] maps onto [`Options`], [`DetectArgs::run`] runs and
//! writes the report.

use crate::{Error, MethodKind, Options, ParryShape, Report};
use clap::Args;
use std::path::PathBuf;

/// `lumen bench detect [--quick] [--scene gca|generated|insufflated|all] [--model FILE] [--out DIR] [--data PATH] [more]`.
#[derive(Debug, Clone, Args)]
pub struct DetectArgs {
    /// The reduced sweep (under a minute on 2 cores): B = 32, x in {1, 4, 16}, 48 frames.
    #[arg(long)]
    pub quick: bool,
    /// Scenes: gca, generated, insufflated (an imported generated surface whose lumen is wider than its bends) or all (generated and gca; the default, or none beside --model).
    #[arg(long)]
    pub scene: Option<String>,
    /// A colon model written by `lumen import` (native, or the text format when it ends in
    /// `.txt`), run as the scene `model` at its own rings and spokes; the report gives the import
    /// fidelity it stores beside the detection errors. Alone unless --scene is given too.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Where report.md, report.json and speed_vs_error.svg go.
    #[arg(long, default_value = "bench-out")]
    pub out: PathBuf,
    /// Folder with the GCA colon (colon_20k_mm.obj, centerline_mm.csv); default
    /// ../shared/data/colon-gca00090 next to the workspace.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Precisions x (samples per rod segment), comma-separated.
    #[arg(long, value_delimiter = ',')]
    pub x: Option<Vec<u32>>,
    /// Spoke counts B, comma-separated.
    #[arg(long, value_delimiter = ',')]
    pub spokes: Option<Vec<usize>>,
    /// Methods, comma-separated: default (contacts at the nearest point of the continuous wall),
    /// sections (each sample read in its own cross-section), refined (sections with one axial
    /// re-projection), thesis, parry.
    #[arg(long, value_delimiter = ',', value_parser = parse_method)]
    pub methods: Option<Vec<MethodKind>>,
    /// Frames per scene (1 mm of insertion each).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Untimed frames at the start of every pass.
    #[arg(long)]
    pub warmup: Option<usize>,
    /// Passes per method (each frame keeps its fastest time).
    #[arg(long)]
    pub repeats: Option<usize>,
    /// Judge every N-th frame against the reference.
    #[arg(long)]
    pub eval_every: Option<usize>,
    /// And every N-th frame with escaped points (0: no more).
    #[arg(long)]
    pub eval_escapes_every: Option<usize>,
    /// Reference subdivisions per ring segment, generated colon.
    #[arg(long)]
    pub ref_steps_generated: Option<usize>,
    /// Reference subdivisions per ring segment, real colon.
    #[arg(long)]
    pub ref_steps_gca: Option<usize>,
    /// Seed of the generated colon and of the escapes.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Skip the rings-doubled check.
    #[arg(long)]
    pub no_doubled: bool,
    /// Axial refinements of the default method (Detector::set_refine).
    #[arg(long)]
    pub refine: Option<u32>,
    /// parry: query capsules everywhere (default: round segments, capsules only where the axis
    /// nears the wall).
    #[arg(long)]
    pub parry_capsules: bool,
    /// No progress bar.
    #[arg(long)]
    pub no_progress: bool,
    /// Also count each method's instructions per frame under callgrind (valgrind must be on
    /// PATH), at the summary's precision and spokes: a figure the machine's load does not move.
    #[arg(long)]
    pub instructions: bool,
    /// Run the frames of this file under callgrind's count (the bench's own child process).
    #[arg(long, hide = true, value_name = "FILE")]
    pub count_file: Option<PathBuf>,
    /// Only rewrite DIR/report.md and speed_vs_error.svg from DIR/report.json.
    #[arg(long, value_name = "DIR", conflicts_with = "quick")]
    pub replot: Option<PathBuf>,
}

fn parse_method(s: &str) -> Result<MethodKind, Error> {
    MethodKind::parse(s.trim()).ok_or_else(|| Error::UnknownMethod { name: s.to_owned() })
}

impl DetectArgs {
    /// The sweep these flags ask for.
    pub fn options(&self) -> Result<Options, Error> {
        let mut o = Options::from_flags(self.quick, self.scene.as_deref(), self.data.clone())?;
        if let Some(m) = &self.model {
            if self.scene.is_none() {
                o.scenes.clear();
            }
            o.model = Some(m.clone());
        }
        let set = |field: &mut usize, v: Option<usize>| {
            if let Some(v) = v {
                *field = v;
            }
        };
        if let Some(x) = &self.x {
            o.precisions = x.clone();
        }
        if let Some(b) = &self.spokes {
            o.spokes = b.clone();
        }
        if let Some(m) = &self.methods {
            o.methods = m.clone();
        }
        o.instructions = self.instructions;
        set(&mut o.frames, self.frames);
        set(&mut o.warmup, self.warmup);
        set(&mut o.repeats, self.repeats);
        set(&mut o.eval_every, self.eval_every);
        set(&mut o.eval_escapes_every, self.eval_escapes_every);
        set(&mut o.reference_steps_generated, self.ref_steps_generated);
        set(&mut o.reference_steps_gca, self.ref_steps_gca);
        if let Some(s) = self.seed {
            o.seed = s;
        }
        if let Some(r) = self.refine {
            o.refine = r;
        }
        o.rings_doubled &= !self.no_doubled;
        if self.parry_capsules {
            o.parry_shape = ParryShape::Capsules;
        }
        Ok(o)
    }

    /// Runs the sweep (or the replot), writes the report into `--out` and prints the summary
    /// rows at the default precision and spokes on stderr.
    pub fn run(&self) -> Result<Report, Error> {
        if let Some(file) = &self.count_file {
            crate::instructions::run_file(file, &self.options()?)?;
            return Ok(Report::default());
        }
        if self.instructions && !crate::instructions::available() {
            return Err(Error::BadFlag { flag: "--instructions", value: "given".into(), expected: "valgrind on PATH (apt install valgrind)" });
        }
        if let Some(dir) = &self.replot {
            let text = std::fs::read_to_string(dir.join("report.json")).map_err(|source| Error::Read { path: dir.join("report.json"), source })?;
            let report = Report::from_json(&text)?;
            report.write(dir)?;
            eprintln!("rewrote {}/report.md and speed_vs_error.svg", dir.display());
            return Ok(report);
        }
        let report = crate::run(&self.options()?, !self.no_progress)?;
        report.write(&self.out)?;
        let x = report.default_precision;
        for scene in report.scene_names() {
            let b = report.summary_spokes(&scene);
            for r in report.runs_at(&scene, b, x) {
                eprintln!(
                    "{scene:9} B{b} x{x} {:7}: median {:9.1} us  p99 {:9.1} us  missed {:3}  false {:3}  depth p99 {:>8} mm  normal p99 {:>7} deg  escapes {}/{}",
                    r.method,
                    r.median_us,
                    r.p99_us,
                    r.metrics.missed,
                    r.metrics.false_contacts,
                    r.metrics.depth_err_p99_mm.map_or("-".into(), |v| format!("{v:.4}")),
                    r.metrics.normal_err_p99_deg.map_or("-".into(), |v| format!("{v:.2}")),
                    r.metrics.escaped_detected,
                    r.metrics.escaped_total
                );
            }
            // A bad import scores well against its own tube: its distance to the source surface
            // beside the detection errors says so.
            if let Some(note) = report.fidelity_note(&scene) {
                eprintln!("{scene:9} B{b} import: {note}");
            }
        }
        eprintln!("wrote {}/report.md, report.json, speed_vs_error.svg", self.out.display());
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cmd {
        #[command(flatten)]
        args: DetectArgs,
    }

    fn opts(line: &[&str]) -> Result<Options, String> {
        let cmd = Cmd::try_parse_from(std::iter::once("lumen-bench").chain(line.iter().copied())).map_err(|e| e.to_string())?;
        cmd.args.options().map_err(|e| e.to_string())
    }

    #[test]
    fn flags_map_onto_the_options() {
        let o = opts(&["--quick", "--scene", "generated", "--x", "2,8", "--methods", "default,parry", "--frames", "20", "--no-doubled"]).unwrap();
        assert!(o.quick);
        assert_eq!(o.precisions, vec![2, 8]);
        assert_eq!(o.methods, vec![MethodKind::Default, MethodKind::Parry]);
        assert_eq!(o.frames, 20);
        assert!(!o.rings_doubled);
        assert_eq!(o.spokes, Options::quick().spokes);
        let full = opts(&[]).unwrap();
        assert_eq!(full.precisions, Options::full().precisions);
        assert_eq!((full.scenes.len(), full.model), (2, None));
        // --model alone, or beside the scenes --scene names.
        let m = opts(&["--quick", "--model", "m.lumen"]).unwrap();
        assert!(m.scenes.is_empty() && m.model == Some(PathBuf::from("m.lumen")));
        let m = opts(&["--model", "m.lumen", "--scene", "gca"]).unwrap();
        assert!(m.scenes == vec![crate::ColonKind::Gca] && m.model.is_some());
        assert_eq!(opts(&["--scene", "insufflated"]).unwrap().scenes, vec![crate::ColonKind::Insufflated]);
    }

    #[test]
    fn bad_flags_name_what_was_wrong() {
        assert!(opts(&["--methods", "default,bullet"]).unwrap_err().contains("bullet"));
        assert!(opts(&["--scene", "liver"]).unwrap_err().contains("liver"));
        assert!(opts(&["--x", "two"]).unwrap_err().contains("two"));
    }
}
