//! How far the default (section) reading is from `nearest` (the continuous wall), sample by
//! sample, against how steep the wall is along the tube near the contact: the question behind
//! the accurate default (where may a section reading stand in for the wall?).
//!
//! ```sh
//! cargo run --release -p lumen-bench --example slopes -- gca 32 4 40
//! ```
//! Arguments: scene (`generated` | `gca`), spokes, precision x, frames. For each sample both
//! methods hold in contact, the wall's slope `s` is the largest change of a spoke between
//! neighbouring rings per length of midline over the segments within the rod's radius of the
//! contact's ring pair (what `TubeCache::slope_near` bounds); the table gives, per band of `s`,
//! how many such samples there are and the default's depth and normal difference from `nearest`.

use lumen_bench::metrics::Reported;
use lumen_bench::scenes;
use lumen_bench::sweep::pass;
use lumen_bench::{MethodKind, Options};
use lumen_scene::{gca, ColonKind};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = if args.first().map(String::as_str) == Some("gca") { ColonKind::Gca } else { ColonKind::Generated };
    let n: Vec<usize> = args[1..].iter().filter(|a| !a.starts_with("--")).map(|a| a.parse().expect("numbers: spokes x frames")).collect();
    let (spokes, x, frames) = (n[0], n[1] as u32, n[2]);
    // `--radial`: the change of a spoke's length only (the wall's slope against the midline,
    // without the spokes' turn where the midline bends).
    let radial = args.iter().any(|a| a == "--radial");
    let sector = args.iter().any(|a| a == "--sector");
    let opts = Options { frames, warmup: 0, eval_every: 1, eval_escapes_every: 0, ..Options::full() };
    let gca = (kind == ColonKind::Gca).then(|| gca::Source::read(None).expect("the GCA colon"));
    let scene = scenes::build(kind, spokes, 1.0, &opts, gca.as_ref(), true).expect("scene");
    let record = |m: MethodKind| {
        let mut rec = Vec::new();
        pass(&scene, x, m, &opts, &mut Vec::new(), Some(&mut rec)).expect("pass");
        rec
    };
    let (def, near) = (record(MethodKind::Sections), record(MethodKind::Default));
    let radius = scene.spec.bodies.last().map_or(1.0, |b| b.radius(0));
    const BANDS: [f32; 7] = [0.05, 0.1, 0.2, 0.3, 0.5, 1.0, f32::INFINITY];
    let mut bands: Vec<(Vec<f32>, Vec<f32>)> = vec![(Vec::new(), Vec::new()); BANDS.len()];
    let (a, b) = (scene.rings, scene.spokes);
    for (f, (d, nr)) in def.iter().zip(&near).enumerate() {
        let state = scene.state(scene.eval[f].index);
        let point = |i: usize| -> [f32; 3] { std::array::from_fn(|c| state[i * (b + 1) * 3 + c]) };
        let spoke = |i: usize, k: usize| -> [f32; 3] { std::array::from_fn(|c| state[(i * (b + 1) + 1 + k) * 3 + c]) };
        let dist = |p: [f32; 3], q: [f32; 3]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        let len = |v: [f32; 3]| dist(v, [0.0; 3]);
        // Over every spoke of the segment, or (`--sector`) the contact's spoke pair and one
        // spoke either side.
        let seg_slope = |j: usize, near: usize| {
            let chord = dist(point(j), point(j + 1)).max(1e-6);
            let change = |k: usize| if radial { (len(spoke(j + 1, k)) - len(spoke(j, k))).abs() } else { dist(spoke(j, k), spoke(j + 1, k)) };
            let ks: Vec<usize> = if sector { (0..4).map(|i| (near + b - 1 + i) % b).collect() } else { (0..b).collect() };
            ks.into_iter().map(change).fold(0.0f32, f32::max) / chord
        };
        let primary = |list: &[Reported], s: u32| list.iter().find(|c| c.sample == s && c.place.is_some_and(|p| p.flags & 4 == 0)).copied();
        for c in nr.iter().filter(|c| c.place.is_some_and(|p| p.flags & 4 == 0)) {
            let Some(dc) = primary(d, c.sample) else { continue };
            let ring = c.place.expect("placed").ring as usize;
            let chord = dist(point(ring), point((ring + 1).min(a - 1))).max(1e-6);
            let n = (radius / chord).ceil() as usize;
            let near_k = c.place.expect("placed").spoke as usize;
            let s = (ring.saturating_sub(n)..=(ring + n).min(a - 2)).map(|j| seg_slope(j, near_k)).fold(0.0f32, f32::max);
            let band = BANDS.iter().position(|&t| s < t).expect("the last band is open");
            let cos = (0..3).map(|i| c.normal[i] * dc.normal[i]).sum::<f32>().clamp(-1.0, 1.0);
            bands[band].0.push((c.depth - dc.depth).abs());
            bands[band].1.push(cos.acos().to_degrees());
        }
    }
    let total: usize = bands.iter().map(|b| b.0.len()).sum();
    println!("{} B{spokes} x{x}, {frames} frames, rod radius {radius} mm: {total} samples in contact under both methods", kind.name());
    println!("| slope s below | samples | share | depth diff p50 / p99 / max mm | normal diff p50 / p99 deg |");
    println!("|---|---:|---:|---|---|");
    for (t, (dd, nd)) in BANDS.iter().zip(&mut bands) {
        let q = |v: &mut Vec<f32>, q: f64| {
            v.sort_by(f32::total_cmp);
            v.get(((v.len() as f64 * q).ceil() as usize).clamp(1, v.len().max(1)) - 1).copied().unwrap_or(f32::NAN)
        };
        println!(
            "| {t} | {} | {:.1}% | {:.4} / {:.4} / {:.4} | {:.2} / {:.2} |",
            dd.len(),
            100.0 * dd.len() as f64 / total.max(1) as f64,
            q(dd, 0.5),
            q(dd, 0.99),
            q(dd, 1.0),
            q(nd, 0.5),
            q(nd, 0.99)
        );
    }
}
