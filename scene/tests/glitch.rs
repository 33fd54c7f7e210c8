//! A frame never outlives itself: whatever one legal frame holds (a tube of zeros or of
//! denormals, collapsed rings, a teleported or scaled scope, the bodies' floats swapped, random
//! values in range), the frames after it in the same session get what a fresh session gives
//! them, bit for bit. A physics engine that sends its state before it wrote the colon, or resets
//! its scope, does exactly this.

use lumen_detect::proto::{Contact, StateLayout};
use lumen_detect::Detector;
use proptest::prelude::*;
use std::sync::OnceLock;

/// The generated colon's spec and its colonoscopies: 48 frames of insertion from 600 mm, and
/// stretches of 12 frames with the tip starting at 40, 200, ... 1,400 mm along the colon (from the
/// anal canal to the caecum, through the sigmoid's loop, where ring planes cross).
fn colonoscopies() -> &'static (lumen_detect::proto::ValidScene, Vec<Vec<Vec<f32>>>) {
    static FRAMES: OnceLock<(lumen_detect::proto::ValidScene, Vec<Vec<Vec<f32>>>)> = OnceLock::new();
    FRAMES.get_or_init(|| {
        let colon = lumen_scene::generate(&lumen_scene::ColonParams::seeded(1));
        let insertion = lumen_scene::Insertion { escapes: false, ..Default::default() };
        let mut spec = None;
        let mut run = |start: f32, n: usize| -> Vec<Vec<f32>> {
            insertion
                .frames(&colon, n, start, 1.0, 1)
                .map(|f| {
                    let scene = lumen_detect::Scene::new().tube("colon", f.colon).rod("scope", f.scope).pair("scope", "colon", lumen_detect::ContactKind::Interior);
                    spec.get_or_insert_with(|| scene.spec());
                    scene.state()
                })
                .collect()
        };
        let mut runs = vec![run(600.0, 48)];
        runs.extend([40.0, 200.0, 400.0, 800.0, 1000.0, 1200.0, 1400.0].map(|start| run(start, 12)));
        (spec.expect("frames").validate().unwrap(), runs)
    })
}

/// One kind of legal glitch frame, made from genuine frame `base`.
#[derive(Debug, Clone)]
enum Glitch {
    /// Every tube float 0 (the colon not written yet).
    TubeZeros,
    /// Every tube float times this (1e-42: denormals; 1e6: a colon a thousand times too big).
    TubeScaled(f32),
    /// Rings `from .. from + n` collapsed onto their control points.
    Collapsed { from: usize, n: usize },
    /// The scope moved by this offset (mm): another place of the colon, or out of it.
    ScopeMoved([f32; 3]),
    /// The first floats of the state are the scope's (the bodies written in the wrong order).
    Swapped,
    /// Every float drawn in [-1000, 1000] mm.
    Noise(u64),
}

fn glitch(kind: &Glitch, layout: &StateLayout, base: &[f32]) -> Vec<f32> {
    let mut s = base.to_vec();
    let (tube, rod) = (layout.bodies[0], layout.bodies[1]);
    let tube_floats = tube.offset..tube.offset + tube.floats();
    let rod_floats = rod.offset..rod.offset + rod.floats();
    match *kind {
        Glitch::TubeZeros => s[tube_floats].fill(0.0),
        Glitch::TubeScaled(f) => s[tube_floats].iter_mut().for_each(|v| *v *= f),
        Glitch::Collapsed { from, n } => {
            let per_ring = (tube.spokes + 1) * 3;
            for i in from.min(tube.points - 1)..(from + n).min(tube.points) {
                s[tube.offset + i * per_ring + 3..tube.offset + (i + 1) * per_ring].fill(0.0);
            }
        }
        Glitch::ScopeMoved(d) => s[rod_floats].chunks_exact_mut(3).for_each(|p| (0..3).for_each(|c| p[c] += d[c])),
        Glitch::Swapped => {
            let scope: Vec<f32> = s[rod_floats].to_vec();
            s[..scope.len()].copy_from_slice(&scope);
        }
        Glitch::Noise(seed) => {
            let mut x = seed | 1;
            for v in s.iter_mut() {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                *v = (x % 2_000_001) as f32 / 1000.0 - 1000.0;
            }
        }
    }
    s
}

fn any_glitch() -> impl Strategy<Value = Glitch> {
    prop_oneof![
        Just(Glitch::TubeZeros),
        prop_oneof![Just(1e-42f32), Just(1e-20), Just(1e6), Just(-1.0), Just(0.5)].prop_map(Glitch::TubeScaled),
        (0usize..1250, 1usize..400).prop_map(|(from, n)| Glitch::Collapsed { from, n }),
        (-800.0f32..800.0, -800.0f32..800.0, -800.0f32..800.0).prop_map(|(x, y, z)| Glitch::ScopeMoved([x, y, z])),
        Just(Glitch::Swapped),
        any::<u64>().prop_map(Glitch::Noise),
    ]
}

/// Whether `carried` is `fresh`'s answer, bit for bit (every field of every contact; a float's
/// `Debug` form is the shortest that reads back to the same bits).
fn same_answer(carried: &[Contact], fresh: &[Contact]) -> Result<(), String> {
    if carried.len() != fresh.len() {
        return Err(format!("{} contacts, a fresh session has {}", carried.len(), fresh.len()));
    }
    match carried.iter().zip(fresh).find(|(a, b)| format!("{a:?}") != format!("{b:?}")) {
        Some((a, b)) => Err(format!("sample {}: carried {a:?}\nfresh {b:?}", a.sample)),
        None => Ok(()),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn after_any_glitch_frame_the_next_frames_are_a_fresh_sessions(kinds in proptest::collection::vec(any_glitch(), 1..3), which in 0usize..8, at in 2usize..8) {
        let (scene, runs) = colonoscopies();
        let frames = &runs[which];
        let mut session = Detector::new(scene);
        for state in &frames[..at] {
            session.detect(state).unwrap();
        }
        for kind in &kinds {
            // Legal: finite and in range, so answered (whatever its contacts are).
            let g = glitch(kind, scene.layout(), &frames[at]);
            let _ = session.detect(&g);
        }
        for (k, state) in frames.iter().enumerate().skip(at).take(4) {
            let carried = session.detect(state).unwrap().to_vec();
            let fresh = Detector::new(scene).detect(state).unwrap().to_vec();
            if let Err(e) = same_answer(&carried, &fresh) {
                prop_assert!(false, "run {which}, frame {k}, after {kinds:?} at {at}: {e}");
            }
        }
    }

    /// Unrelated placements in one session, as a physics engine that starts trial after trial
    /// sends them: every frame is a frame of any stretch of the colonoscopy, so the scope jumps
    /// anywhere along the colon (the anal canal to the caecum) from one frame to the next.
    #[test]
    fn placements_anywhere_in_any_order_get_a_fresh_sessions_answers(picks in proptest::collection::vec((0usize..8, 0usize..12), 4..24)) {
        let (scene, runs) = colonoscopies();
        let mut session = Detector::new(scene);
        for (i, &(which, k)) in picks.iter().enumerate() {
            let state = &runs[which][k % runs[which].len()];
            let carried = session.detect(state).unwrap().to_vec();
            let fresh = Detector::new(scene).detect(state).unwrap().to_vec();
            if let Err(e) = same_answer(&carried, &fresh) {
                prop_assert!(false, "placement {i} (run {which}, frame {k}) after {:?}: {e}", &picks[..i]);
            }
        }
    }
}
