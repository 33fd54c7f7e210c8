//! A sample whose own descents to the wall end in a local minimum of the distance that its
//! neighbours' do not: in a lumen wider than its bends, a fold's flank and the wall beyond it
//! are two basins, and a sample between them may fall into the farther one. Checked against the
//! dense reference (`lumen-oracle`) on a generated insufflated colon, so no data is needed.

use lumen_bench::metrics::{evaluate, plan, Tally, Truth, TruthParams};
use lumen_bench::scenes::{build_model, Model};
use lumen_bench::sweep::pass;
use lumen_bench::{MethodKind, Options};

/// The generated insufflated colon of seed 3 (`lumen generate --seed 3`, imported), the bench's
/// kinematic insertion, frame 24 at four samples per control point: sample 165 lies 0.635 mm
/// into a fold's flank, and its own descents ended on the wall beyond it (0.03 mm, the sample's
/// section and its ring seeds all in that basin) while its neighbours' ended on the flank.
#[test]
fn hard_a_sample_in_another_basin_of_the_distance_than_its_neighbours() {
    let (tube, _) = lumen_scene::insufflated::load(3).expect("the generated colon imports");
    let model = Model { path: "insufflated seed 3".into(), tube, import: None };
    let (frame, x) = (24, 4);
    let opts = Options { frames: frame + 1, warmup: 0, eval_every: 1, eval_escapes_every: 0, ..Options::full() };
    let scene = build_model(&model, &opts, true).expect("the scene");
    let (mut rec, mut buf) = (Vec::new(), Vec::new());
    pass(&scene, x as u32, MethodKind::Default, &opts, &mut buf, Some(&mut rec)).expect("the pass");
    let (ef, reported) = (&scene.eval[frame], &rec[frame]);
    let extra = plan(reported, x, &ef.arc_mm);
    let truth = Truth::new(&ef.colon, &ef.scope, ef.inserted, &ef.arc_mm, scene.spec.alpha, TruthParams { steps: 32, window_mm: 60.0, threads: 1 }, &extra);
    let mut tally = Tally::default();
    evaluate(&truth, x, frame, reported, truth.extra(), &mut tally);
    assert!(tally.contacts > 50, "{} contacts judged", tally.contacts);
    let worst = tally.depth_err.iter().copied().fold(0.0f32, f32::max);
    // The reference at 32 steps is itself within about 0.03 mm here (its local bound).
    assert!(worst < 0.1, "depth error up to {worst} mm: {:?}", tally.findings);
    assert_eq!((tally.missed, tally.false_contacts), (0, 0), "{:?}", tally.findings);
}
