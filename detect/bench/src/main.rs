//! Standalone `lumen bench detect`:
//!
//! ```sh
//! cargo run --release -p lumen-bench -- --quick --out bench-out
//! cargo run --release -p lumen-bench -- --scene generated --out bench-out
//! ```

use lumen_bench::{MethodKind, Options, ParryShape};
use std::path::PathBuf;
use std::process::ExitCode;

const HELP: &str = "lumen-bench: speed against error of Lumen's collision methods (thesis, default, parry)

USAGE: lumen-bench [--quick] [--scene gca|generated|all] [--out DIR] [--data PATH] [more]

  --quick              reduced sweep (under a minute on 2 cores)
  --scene S            gca, generated or all (default all)
  --out DIR            where report.md, report.json and speed_vs_error.svg go (default bench-out)
  --data PATH          folder with the GCA colon (colon_20k_mm.obj, centerline_mm.csv);
                       default ../shared/data/colon-gca00090 next to the workspace
  --x 1,4,16           precisions
  --spokes 16,32       spoke counts
  --methods default,thesis,parry
  --frames N           frames per scene
  --warmup N           untimed frames per pass
  --repeats N          passes per method (fastest time per frame kept)
  --eval-every N       judge every N-th frame against the reference
  --eval-escapes-every N   and every N-th frame with escaped points (0: no more)
  --ref-steps-generated N / --ref-steps-gca N   reference subdivisions per ring segment
  --seed N             seed of the generated colon and the escapes
  --no-doubled         skip the rings-doubled check
  --refine N           axial refinements of the default method (Detector::set_refine)
  --parry-capsules     parry: query capsules everywhere (default: round segments,
                       capsules only where the axis nears the wall)
  --no-progress        no progress bar
  --replot DIR         rewrite DIR/report.md and speed_vs_error.svg from DIR/report.json
";

fn list<T: std::str::FromStr>(v: &str, what: &str) -> Result<Vec<T>, String> {
    v.split(',').map(|s| s.trim().parse::<T>().map_err(|_| format!("{what}: cannot read {s:?}"))).collect()
}

fn parse(args: &[String]) -> Result<(Options, PathBuf, bool), String> {
    let quick = args.iter().any(|a| a == "--quick");
    let mut o = if quick { Options::quick() } else { Options::full() };
    let mut out = PathBuf::from("bench-out");
    let mut progress = true;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut val = || it.next().cloned().ok_or_else(|| format!("{a} needs a value"));
        match a.as_str() {
            "--quick" => {}
            "-h" | "--help" => return Err(String::new()),
            "--scene" => o.set_scene(&val()?).map_err(|e| e.to_string())?,
            "--out" => out = PathBuf::from(val()?),
            "--data" => o.data = Some(PathBuf::from(val()?)),
            "--x" => o.precisions = list(&val()?, "--x")?,
            "--spokes" => o.spokes = list(&val()?, "--spokes")?,
            "--methods" => {
                o.methods = val()?.split(',').map(|m| MethodKind::parse(m.trim()).ok_or_else(|| format!("--methods: unknown {m:?}"))).collect::<Result<_, _>>()?
            }
            "--frames" => o.frames = val()?.parse().map_err(|_| "--frames: a number")?,
            "--warmup" => o.warmup = val()?.parse().map_err(|_| "--warmup: a number")?,
            "--repeats" => o.repeats = val()?.parse().map_err(|_| "--repeats: a number")?,
            "--eval-every" => o.eval_every = val()?.parse().map_err(|_| "--eval-every: a number")?,
            "--eval-escapes-every" => o.eval_escapes_every = val()?.parse().map_err(|_| "--eval-escapes-every: a number")?,
            "--ref-steps-generated" => o.reference_steps_generated = val()?.parse().map_err(|_| "--ref-steps-generated: a number")?,
            "--ref-steps-gca" => o.reference_steps_gca = val()?.parse().map_err(|_| "--ref-steps-gca: a number")?,
            "--seed" => o.seed = val()?.parse().map_err(|_| "--seed: a number")?,
            "--no-doubled" => o.rings_doubled = false,
            "--refine" => o.refine = val()?.parse().map_err(|_| "--refine: a number")?,
            "--parry-capsules" => o.parry_shape = ParryShape::Capsules,
            "--no-progress" => progress = false,
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    Ok((o, out, progress))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    // `--replot DIR`: rewrite DIR's report.md and speed_vs_error.svg from its report.json.
    if let [flag, dir] = args.as_slice() {
        if flag == "--replot" {
            let dir = PathBuf::from(dir);
            let done = std::fs::read_to_string(dir.join("report.json"))
                .map_err(|e| lumen_bench::Error::Io(e.to_string()))
                .and_then(|t| lumen_bench::Report::from_json(&t))
                .and_then(|r| r.write(&dir));
            return match done {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("lumen-bench: {e}");
                    ExitCode::FAILURE
                }
            };
        }
    }
    let (opts, out, progress) = match parse(&args) {
        Ok(p) => p,
        Err(e) if e.is_empty() => {
            print!("{HELP}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("{e}\n\n{HELP}");
            return ExitCode::from(2);
        }
    };
    let report = match lumen_bench::run(&opts, progress) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("lumen-bench: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = report.write(&out) {
        eprintln!("lumen-bench: {e}");
        return ExitCode::FAILURE;
    }
    let x = report.default_precision;
    let b = report.default_spokes;
    for scene in ["generated", "gca"] {
        for r in report.runs_at(scene, b, x) {
            eprintln!(
                "{scene:9} B{b} x{x} {:7}: median {:9.1} us  p99 {:9.1} us  missed {:3}  false {:3}  depth p99 {:>8} mm  normal p99 {:>7} deg  escapes {}/{}",
                r.method,
                r.median_us,
                r.p99_us,
                r.missed,
                r.false_contacts,
                r.depth_err_p99_mm.map_or("-".into(), |v| format!("{v:.4}")),
                r.normal_err_p99_deg.map_or("-".into(), |v| format!("{v:.2}")),
                r.escaped_detected,
                r.escaped_total
            );
        }
    }
    eprintln!("wrote {}/report.md, report.json, speed_vs_error.svg", out.display());
    ExitCode::SUCCESS
}
