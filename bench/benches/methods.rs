//! Criterion benchmark of both methods on a colonoscopy-sized scene: the generated colon
//! (1.5 m, ~1,250 rings x 32 spokes) with a 160-point endoscope inserted 1 m and advancing 1 mm
//! per frame, the wall deformed where it presses. Each iteration detects the next frame of the
//! sequence, so the default method's coherence is exercised as in a simulation.
//!
//! `cargo bench -p lumen-bench --bench methods`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use lumen_detect::{ContactKind, Detector, Method, Scene};
use lumen_scene::colon::{generate, ColonParams};
use lumen_scene::endoscope::Insertion;
use std::time::{Duration, Instant};

const FRAMES: usize = 64;

fn states(method: Method, x: u32) -> (lumen_detect::SceneSpec, Vec<Vec<f32>>) {
    let colon = generate(&ColonParams::seeded(7));
    let mut spec = None;
    let states = Insertion { escapes: true, ..Insertion::default() }
        .frames(&colon, FRAMES, 1000.0, 1.0, 7)
        .map(|f| {
            let scene = Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", ContactKind::Interior).precision(x).method(method);
            spec.get_or_insert_with(|| scene.spec());
            scene.state()
        })
        .collect();
    (spec.unwrap(), states)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("frame");
    g.sample_size(40).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    for x in [1u32, 2, 4] {
        // `signed`: the default, contacts at the nearest point of the continuous wall;
        // `signed+sections`: each sample read in its own cross-section.
        for (name, method, prevalidated, nearest) in
            [("signed", Method::Signed, true, true), ("signed+sections", Method::Signed, true, false), ("signed+check", Method::Signed, false, true), ("thesis", Method::Thesis, false, false)]
        {
            let (spec, states) = states(method, x);
            let mut d = Detector::new(&spec.validate().unwrap());
            d.set_nearest(nearest);
            let mut f = 0;
            // One buffer rewritten every frame, as a physics engine writes its state in place
            // (64 separate buffers would measure cold memory instead); only detection is timed.
            let mut buf = states[0].clone();
            g.bench_function(BenchmarkId::new(name, format!("x{x}")), |b| {
                b.iter_custom(|iters| {
                    let mut total = Duration::ZERO;
                    for _ in 0..iters {
                        f = (f + 1) % FRAMES;
                        buf.copy_from_slice(&states[f]);
                        let t0 = Instant::now();
                        let n = if prevalidated { d.detect_prevalidated(&buf) } else { d.detect(&buf) }.unwrap().len();
                        total += t0.elapsed();
                        std::hint::black_box(n);
                    }
                    total
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
