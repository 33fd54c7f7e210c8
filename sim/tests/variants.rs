//! The scripted colonoscopy on the generated colon's `tight-bend` and `loop` variants: where the
//! script puts the scope (through the places that make them hard), and the loop's run.

use lumen_scene::colon::generate_detailed;
use lumen_scene::ColonKind;
use lumen_sim::setup;

mod common;

/// Where the scripted colonoscopy starts the tip: 20 mm before the sigmoid's sharpest bend
/// whose ring planes do not cross (`World`'s default start).
fn tip_start(kind: ColonKind, seed: u64) -> (f64, lumen_scene::colon::GeneratedColon) {
    let g = generate_detailed(&kind.generated(seed).unwrap());
    ((setup::sigmoid_bend_mm(&g.tube) - 20.0).max(0.0), g)
}

#[test]
fn the_scope_lies_through_both_tight_bends_and_the_whole_loop() {
    for seed in [1u64, 2, 3] {
        let (tip, g) = tip_start(ColonKind::TightBend, seed);
        let valid = setup::valid_bends(&g.tube);
        for b in &g.tight_bends {
            // The arc ends half its length past its middle.
            let arc_end = b.at_mm + 0.5 * b.radius_mm * b.turn_deg.to_radians();
            eprintln!("tight-bend seed {seed}: tip starts {tip:.0} mm in; bend at {:.0} mm ends {arc_end:.0} mm", b.at_mm);
            assert!(tip > arc_end as f64 + 20.0, "seed {seed}: tip at {tip:.0} mm, the bend's arc ends at {arc_end:.0} mm");
        }
        // The sim's own test of crossing ring planes (a chord of a ring's longest spoke either
        // side) sees the sharper bend; the push happens elsewhere.
        let second = &g.tight_bends[1];
        assert!((0..g.tube.rings()).any(|i| !valid[i] && (g.arc[i] - second.at_mm).abs() < 20.0), "seed {seed}: the bend at {:.0} mm reads valid", second.at_mm);

        let (tip, g) = tip_start(ColonKind::Loop, seed);
        let l = g.sigmoid_loop.unwrap();
        eprintln!("loop seed {seed}: tip starts {tip:.0} mm in; the revolution spans {:.0}-{:.0} mm", l.arc_mm[0], l.arc_mm[1]);
        assert!(tip > l.arc_mm[1] as f64, "seed {seed}: tip at {tip:.0} mm, the loop ends at {:.0} mm", l.arc_mm[1]);
    }
}

/// The short colonoscopy in the generated colon `kind` ([`common::short_run`], every frame held
/// to the limits), and the hard push loaded the scope (its limit is 40 N; measured 40 in
/// the loop, 28 in the tight bends, where the scope slides on).
fn short_run(kind: ColonKind) {
    let (_, force) = common::short_run(&setup::colon(kind, 1, None).unwrap(), &kind.to_string());
    assert!(force > 20.0, "the hard push did not push hard: {force:.1} N");
}

#[test]
fn the_scripted_colonoscopy_in_the_loop_stays_inside() {
    // Measured 0.342 mm.
    short_run(ColonKind::Loop);
}

#[test]
fn the_scripted_colonoscopy_in_the_tight_bends_stays_inside() {
    // Before the generator unfolded its bends (Tube::unfold), 2.0 mm: the scope was held by
    // walls that lay inside other sections.
    // Measured 0.414 mm.
    short_run(ColonKind::TightBend);
}
