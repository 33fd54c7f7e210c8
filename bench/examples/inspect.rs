//! Reproduces one finding of the report: runs a method through a scene's frames up to `frame`
//! (so the default method's coherence is as in the sweep) and prints its contacts at the given
//! samples next to the dense reference's answers there.
//!
//! ```sh
//! cargo run --release -p lumen-bench --example inspect -- gca 32 4 0 360
//! cargo run --release -p lumen-bench --example inspect -- generated 32 4 24 311 --method thesis
//! cargo run --release -p lumen-bench --example inspect -- ins3.lumen 48 4 24 105
//! ```
//! Arguments: scene (`generated` | `gca` | a model file written by `lumen import`, at its own
//! spokes), spokes, precision x, frame, samples...;
//! `--method default|thesis|parry` (default `default`), `--steps N` (reference, default 32),
//! `--refine N` (the default method's axial refinements).

use lumen_bench::metrics::{arc_at, QueryPoint, Reported, Truth, TruthParams};
use lumen_bench::scenes;
use lumen_bench::sweep::pass;
use lumen_bench::{MethodKind, Options};
use lumen_scene::{gca, ColonKind};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut method = MethodKind::Default;
    let mut steps = 32;
    let mut refine = 0;
    while let Some(i) = args.iter().position(|a| a.starts_with("--")) {
        let v = args.remove(i + 1);
        match args.remove(i).as_str() {
            "--method" => method = MethodKind::parse(&v).expect("default, thesis or parry"),
            "--steps" => steps = v.parse().expect("a number"),
            "--refine" => refine = v.parse().expect("a number"),
            other => panic!("unknown {other}"),
        }
    }
    let model = args[0].ends_with(".lumen").then(|| scenes::Model::read(std::path::Path::new(&args[0])).expect("the model"));
    let kind = match args[0].as_str() {
        "gca" => ColonKind::Gca,
        _ => ColonKind::Generated,
    };
    let n: Vec<usize> = args[1..].iter().map(|a| a.parse().expect("numbers")).collect();
    let (spokes, x, frame, samples) = (n[0], n[1], n[2], &n[3..]);
    let opts = Options { frames: frame + 1, warmup: 0, eval_every: 1, eval_escapes_every: 0, refine, ..Options::full() };
    let gca = (kind == ColonKind::Gca).then(|| gca::Source::read(None).expect("the GCA colon"));
    let scene = match &model {
        Some(m) => scenes::build_model(m, &opts, true).expect("scene"),
        None => scenes::build(kind, spokes, 1.0, &opts, gca.as_ref(), true).expect("scene"),
    };
    let mut rec = Vec::new();
    let mut buf = Vec::new();
    pass(&scene, x as u32, method, &opts, &mut buf, Some(&mut rec)).expect("pass");
    let contacts: &Vec<Reported> = &rec[frame];
    let ef = &scene.eval[frame];
    let pts = lumen_oracle::dense_rod(&ef.scope, scene.spec.alpha, x);
    let mut extra = Vec::new();
    for &s in samples {
        let arc = arc_at(&ef.arc_mm, s / x, (s % x) as f32 / x as f32);
        extra.push(QueryPoint { p: pts[s].0, arc });
        if let Some(c) = contacts.iter().find(|c| c.sample as usize == s) {
            extra.push(QueryPoint { p: c.at.unwrap_or(pts[s].0), arc });
            extra.push(QueryPoint { p: c.wall, arc });
        }
    }
    let t = Truth::new(&ef.colon, &ef.scope, ef.inserted, &ef.arc_mm, scene.spec.alpha, TruthParams { steps, window_mm: 60.0, threads: opts.threads }, &extra);
    println!(
        "{} B{spokes} x{x} frame {frame} ({} rings; control points inside {}, escaped {:?}); method {}; reference steps {steps}, bound {:.4} mm",
        if model.is_some() { args[0].as_str() } else { kind.name() },
        scene.rings,
        ef.inserted,
        ef.escaped,
        method.name(),
        t.bound()
    );
    let mut e = t.extra().iter();
    for &s in samples {
        let a = e.next().unwrap();
        let r = pts[s].1;
        println!("sample {s} (control point {:.2}) at {:?}, colon arc {:.1} mm", s as f32 / x as f32, pts[s].0, extra.iter().find(|q| q.p == pts[s].0).map_or(0.0, |q| q.arc));
        println!(
            "  reference: sd {:.4} (depth {:.4}), normal {:?}, wall {:?} (arc {:.1}), local bound {:.4}{}",
            a.q.sd,
            a.q.sd + r,
            a.q.normal,
            a.q.point,
            a.wall_arc,
            a.local_bound,
            if a.folded { ", NOT JUDGED (fold / other loop)" } else { "" }
        );
        match contacts.iter().find(|c| c.sample as usize == s) {
            Some(c) => {
                let at = e.next().unwrap();
                let w = e.next().unwrap();
                println!(
                    "  {}: depth {:.4}, normal {:?} ({:.2} deg from the reference's), wall {:?} (reference sd there {:.4}{}), place {:?}",
                    method.name(),
                    c.depth,
                    c.normal,
                    lumen_bench::metrics::angle_deg(c.normal, at.q.normal),
                    c.wall,
                    w.q.sd,
                    if w.folded { ", on a fold / other loop" } else { "" },
                    c.place
                );
                if let Some(p) = c.at {
                    println!("  (computed at {p:?}: reference depth there {:.4})", at.q.sd + r);
                }
            }
            None => println!("  {}: no contact", method.name()),
        }
    }
}
