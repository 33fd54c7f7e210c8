//! The simulation's soundness: a rod at rest, a rod pushed into a straight tube, the scripted
//! colonoscopy with the hard push on the generated colon, determinism, and the frame rate.

use lumen_detect::Tube;
use lumen_proto::Contact;
use lumen_sim::{setup, Action, FnSource, InProcess, Phase, Rod, RodParams, Script, SimConfig, SourceError, V3d, World};
use std::time::Instant;

mod common;

/// A straight tube along +x: `rings` rings 1.2 mm apart, 32 spokes of `radius` mm.
fn straight_tube(rings: usize, radius: f32) -> Tube {
    let b = 32;
    let ring = move |_: usize| {
        (0..b).map(move |k| {
            let a = k as f32 * std::f32::consts::TAU / b as f32;
            [0.0, radius * a.cos(), radius * a.sin()]
        })
    };
    Tube::new((0..rings).map(|i| [i as f32 * 1.2, 0.0, 0.0]).collect(), (0..rings).flat_map(ring).collect(), b).unwrap()
}

fn short_rod(length_mm: f64) -> RodParams {
    RodParams { length_mm, points: (length_mm / 10.0).round() as usize + 1, ..RodParams::default() }
}

/// Points of a straight rod from `tip` towards -x, `rod.points` of them.
fn rod_points(rod: &RodParams, tip: V3d) -> Vec<V3d> {
    (0..rod.points).map(|i| tip - V3d::x() * (rod.segment_mm() * i as f64)).collect()
}

fn hold_script(seconds: f64) -> Script {
    Script { phases: vec![Phase { name: "hold", duration_s: seconds, action: Action::Hold }], repeat_from: 0, force_n: 15.0 }
}

#[test]
fn a_straight_rod_at_rest_stays_straight_and_keeps_its_length() {
    // Free: falling under gravity for one second, no contacts.
    let mut rod = Rod::straight(RodParams::default(), V3d::new(0.0, 0.0, 0.0), V3d::x());
    let l0 = rod.rest_length();
    let h = 1e-3 / 16.0;
    for step in 0..16_000 {
        rod.predict(h, V3d::new(0.0, -9810.0, 0.0));
        rod.solve_bend(h);
        rod.solve_stretch(h, step % 2 == 1);
        rod.update_velocity(h);
    }
    let (len, dev) = (rod.length(), rod.max_deviation_from_chord());
    eprintln!("free fall 1 s: fell {:.0} mm, length error {:.2e}, deviation from straight {dev:.2e} mm", -rod.x[0].y, len / l0 - 1.0);
    assert!((len / l0 - 1.0).abs() < 1e-3);
    assert!(dev < 1e-6, "{dev}");

    // Lying on the bottom of a straight colon under gravity, the operator holding the handle.
    let tube = straight_tube(400, 20.0);
    let params = short_rod(300.0);
    let pts = rod_points(&params, V3d::new(380.0, -13.5, 0.0));
    let config = SimConfig { rod: params, script: hold_script(1.0), ..SimConfig::default() };
    let spec = setup::scene_spec(&tube, &config.rod, &config.sim);
    let mut world = World::with_rod(&tube, config, InProcess::new(&spec.validate().unwrap()), pts).unwrap();
    for _ in 0..500 {
        let r = world.step().unwrap();
        assert_eq!(r.escaped, 0);
        assert!(r.max_penetration_mm <= 1.0, "{r:?}");
    }
    let rod = world.rod();
    let (err, dev) = (rod.length() / rod.rest_length() - 1.0, rod.max_deviation_from_chord());
    eprintln!("resting in a straight tube 0.5 s: length error {err:.2e}, deviation from straight {dev:.3} mm, wall {:.3} mm", world.report().max_wall_mm);
    assert!(err.abs() < 1e-3, "{err}");
    assert!(dev < 0.5, "{dev}");
}

#[test]
fn a_rod_pushed_into_a_straight_tube_is_held_inside() {
    // 480 mm of tube of radius 20 mm; a 500 mm scope inserted 250 mm, pushed in at 250 mm/s
    // with up to 40 N while its tip is held: it buckles against the wall.
    let tube = straight_tube(400, 20.0);
    let params = short_rod(500.0);
    let pts = rod_points(&params, V3d::new(250.0, 0.0, 0.0));
    let script = Script {
        phases: vec![
            Phase { name: "settle", duration_s: 0.05, action: Action::Hold },
            Phase { name: "hard push", duration_s: 0.6, action: Action::Push { mm_per_s: 250.0, force_n: 40.0, hold_tip: true } },
        ],
        repeat_from: 1,
        force_n: 15.0,
    };
    let config = SimConfig { rod: params, script, ..SimConfig::default() };
    let spec = setup::scene_spec(&tube, &config.rod, &config.sim);
    let mut world = World::with_rod(&tube, config, InProcess::new(&spec.validate().unwrap()), pts).unwrap();
    let (mut pen, mut wall, mut force, mut touching) = (0.0f32, 0.0f32, 0.0f64, 0u32);
    for _ in 0..650 {
        let r = world.step().unwrap();
        assert_eq!(r.escaped, 0, "{r:?}");
        assert!(r.max_penetration_mm <= 1.0, "{r:?}");
        pen = pen.max(r.max_penetration_mm);
        wall = wall.max(r.max_wall_mm);
        force = force.max(r.hand_force_n);
        touching = touching.max(r.touching);
    }
    let r = world.report();
    eprintln!(
        "straight tube push: max penetration {pen:.3} mm, wall displaced up to {wall:.2} mm, hand force up to {force:.1} N, up to {touching} samples touching; handle moved to {:.1} mm",
        r.handle_mm
    );
    // The push was hard: the hand reached its limit and the wall gave.
    assert!(force > 30.0 && wall > 2.0 && touching > 10);
}

#[test]
fn the_scripted_hard_push_on_the_generated_colon_stays_inside_and_is_deterministic() {
    let colon = setup::generated_colon(1, 1500.0);
    let config = SimConfig { script: Script::short_colonoscopy(), sim: lumen_sim::SimParams { relax_s: 0.05, ..Default::default() }, ..SimConfig::default() };
    let run = |frames: usize| {
        let mut world = World::in_process(&colon, config.clone()).unwrap();
        let mut worst = (0.0f32, 0u64);
        let mut force = 0.0f64;
        let mut creased = 0u32;
        for _ in 0..frames {
            let r = world.step().unwrap_or_else(|e| panic!("{e}"));
            assert!(!r.nan);
            assert_eq!(r.escaped, 0, "frame {} ({}): {r:?}", r.frame, r.phase_name);
            assert!(r.max_penetration_mm <= 1.0, "frame {} ({}): {r:?}", r.frame, r.phase_name);
            if r.max_penetration_mm > worst.0 {
                worst = (r.max_penetration_mm, r.frame);
            }
            force = force.max(r.hand_force_n);
            creased += (r.crease_faces > 0) as u32;
        }
        eprintln!("{frames} frames: max penetration {:.3} mm (frame {}), hand force up to {force:.1} N, crease faces in {creased} frames", worst.0, worst.1);
        // The accuracy limit for the colonoscopy (0.136 mm measured; 0.256 mm without the
        // crease faces of the scope's end segments).
        assert!(worst.0 <= 0.5, "max penetration {:.3} mm (frame {})", worst.0, worst.1);
        assert!(creased > 0, "no crease face was ever added");
        (world.rod().x.clone(), world.report().clone(), force)
    };
    let (a, ra, force) = run(600);
    assert!(force > 30.0, "the hard push pushed hard: {force:.1} N");
    let (b, rb, _) = run(600);
    let bits = |x: &[V3d]| x.iter().flat_map(|p| p.iter().map(|c| c.to_bits()).collect::<Vec<_>>()).collect::<Vec<u64>>();
    assert_eq!(bits(&a), bits(&b), "two runs differ");
    assert_eq!((ra.contacts, ra.max_penetration_mm.to_bits(), ra.active_nodes), (rb.contacts, rb.max_penetration_mm.to_bits(), rb.active_nodes));
}

#[test]
fn a_closure_source_gives_the_same_run_as_in_process_detection() {
    // The seam the daemon client plugs into: a closure that detects on the state it is given.
    let colon = setup::generated_colon(2, 1500.0);
    let config = SimConfig { script: Script::short_colonoscopy(), ..SimConfig::default() };
    let spec = setup::scene_spec(&colon, &config.rod, &config.sim);
    let mut detector = lumen_detect::Detector::new(&spec.validate().unwrap());
    let floats = detector.layout().floats;
    let calls = std::rc::Rc::new(std::cell::Cell::new(0u32));
    let counted = calls.clone();
    let source = FnSource::new(floats, move |state: &[f32], out: &mut Vec<Contact>| -> Result<(), SourceError> {
        counted.set(counted.get() + 1);
        out.clear();
        out.extend_from_slice(detector.detect(state)?);
        Ok(())
    });
    let mut a = World::in_process(&colon, config.clone()).unwrap();
    let mut b = World::new(&colon, config, source).unwrap();
    let start = calls.get();
    for _ in 0..200 {
        let (ra, rb) = (a.step().unwrap().clone(), b.step().unwrap().clone());
        assert_eq!((ra.contacts, ra.max_penetration_mm.to_bits(), ra.escaped), (rb.contacts, rb.max_penetration_mm.to_bits(), rb.escaped));
    }
    assert_eq!(calls.get() - start, 200, "one detection per frame");
    let bits = |w: &[V3d]| w.iter().flat_map(|p| p.iter().map(|c| c.to_bits()).collect::<Vec<_>>()).collect::<Vec<u64>>();
    assert_eq!(bits(&a.rod().x), bits(&b.rod().x));
}

#[test]
fn frame_rate_on_the_full_generated_colon() {
    // Measured, not asserted (CI machines vary); the target is 500+ frames/s in release.
    let colon = setup::generated_colon(1, 1500.0);
    let mut world = World::in_process(&colon, SimConfig::default()).unwrap();
    let frames = 1000;
    let t = Instant::now();
    let (mut physics, mut detect) = (0.0, 0.0);
    for _ in 0..frames {
        let r = world.step().unwrap();
        physics += r.physics_s;
        detect += r.detect_s;
    }
    let s = t.elapsed().as_secs_f64();
    eprintln!(
        "full generated colon, {frames} frames: {:.0} frames/s ({:.0} us/frame: physics {:.0} us, detection {:.0} us){}",
        frames as f64 / s,
        s / frames as f64 * 1e6,
        physics / frames as f64 * 1e6,
        detect / frames as f64 * 1e6,
        if cfg!(debug_assertions) { " [debug assertions on]" } else { "" }
    );
}

#[test]
fn the_scripted_colonoscopy_in_the_real_colon_never_escapes() {
    // The real colon bends tighter than its lumen is wide at its flexures; with ring planes that
    // crossed there (tangents smoothed over 4 mm instead of 24) this run let up to 188 samples
    // escape and penetrated 120 mm. Skipped, saying so, where the data is absent.
    let colon = match setup::gca_colon(None) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("skipped: {e}");
            return;
        }
    };
    // Every frame within the soundness limit (1 mm), as on the generated colon; a crossing of
    // ring planes once cost tens of millimetres, the sections' readings alone 3.4 mm.
    let (worst, force) = common::short_run(&colon, "the real colon");
    assert!(force > 30.0, "the hard push pushed hard: {force:.1} N");
    // The accuracy limit, over the scatter of the trajectory: this run from start depths 0 to 7
    // um deeper (`lumen-sim-run --scene gca --frames 600 --script short --relax 0.05 --ensemble
    // 8`, 2026-12-07) went 0.18 to 0.81 mm deep (mean 0.53), and 0.876 mm at worst before the
    // wall's spring-back was speed-limited; one run's figure moves by tenths of a millimetre with
    // any change to what a frame carries. docs/decisions/sim.md.
    assert!(worst <= 0.9, "max penetration {worst:.3} mm");
}
