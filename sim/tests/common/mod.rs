//! What the sim's test files share.

use lumen_detect::Tube;
use lumen_sim::{Script, SimConfig, SimParams, World};

/// The short colonoscopy (600 frames, the scope's shape released over 50 ms) in `colon`, every
/// frame held to the limits (no NaN, no escaped sample, penetration at most 1 mm);
/// the deepest penetration (mm) and the largest hand force (N).
pub fn short_run(colon: &Tube, name: &str) -> (f32, f64) {
    let config = SimConfig { script: Script::short_colonoscopy(), sim: SimParams { relax_s: 0.05, ..Default::default() }, ..SimConfig::default() };
    let mut world = World::in_process(colon, config).unwrap();
    let (mut worst, mut force) = (0.0f32, 0.0f64);
    for _ in 0..600 {
        let r = world.step().unwrap_or_else(|e| panic!("{e}"));
        assert!(!r.nan);
        assert_eq!(r.escaped, 0, "{name} frame {} ({}): {r:?}", r.frame, r.phase_name);
        assert!(r.max_penetration_mm <= 1.0, "{name} frame {} ({}): {r:?}", r.frame, r.phase_name);
        worst = worst.max(r.max_penetration_mm);
        force = force.max(r.hand_force_n);
    }
    eprintln!("600 frames of {name}: max penetration {worst:.3} mm, hand force up to {force:.1} N");
    (worst, force)
}
