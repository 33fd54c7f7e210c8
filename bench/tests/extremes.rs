//! Extreme but finite inputs ("no non-finite output, ever"): whatever finite values a
//! frame holds, every contact the detector returns is finite, or the frame is refused with an
//! error naming the body and index (values beyond `MAX_COORDINATE`, or a contact that came out
//! non-finite), and the detector goes on with the next good frame.

use lumen_detect::Detector;
use lumen_proto::limits::MAX_COORDINATE;
use lumen_proto::{Contact, InputError, SceneSpec};
use proptest::prelude::*;

const RINGS: usize = 6;
const SPOKES: usize = 8;
const POINTS: usize = 5;
const FLOATS: usize = RINGS * (SPOKES + 1) * 3 + POINTS * 3;

fn detector(nearest: bool) -> Detector {
    let spec: SceneSpec = serde_json::from_value(serde_json::json!({
        "bodies": [
            {"name": "colon", "shape": {"tube": {"rings": RINGS, "spokes": SPOKES}}},
            {"name": "scope", "shape": {"rod": {"points": POINTS, "radius": [1.0]}}}],
        "pairs": [{"a": "scope", "b": "colon", "kind": "interior"}],
        "nearest": nearest,
    }))
    .expect("the spec parses");
    Detector::new(&spec.validate().expect("the spec validates"))
}

/// A straight tube of radius 5 along x and the rod inside it, shifted `dy` along y.
fn state(dy: f32) -> Vec<f32> {
    let mut s = Vec::with_capacity(FLOATS);
    for i in 0..RINGS {
        s.extend([i as f32 * 10.0, 0.0, 0.0]);
        for k in 0..SPOKES {
            let a = std::f32::consts::TAU * (k as f32 + 0.5) / SPOKES as f32;
            s.extend([0.0, 5.0 * a.cos(), 5.0 * a.sin()]);
        }
    }
    for j in 0..POINTS {
        s.extend([5.0 + j as f32 * 10.0, dy, 0.0]);
    }
    s
}

fn all_finite(c: &Contact) -> bool {
    [c.param_a, c.param_b, c.depth].iter().chain(&c.weights_b).chain(&c.point_a).chain(&c.point_b).chain(&c.normal).all(|v| v.is_finite())
}

/// Finite values from the harmless to the largest an `f32` holds.
fn extreme() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::MAX),
        Just(-f32::MAX),
        Just(1e38f32),
        Just(1e30f32),
        Just(MAX_COORDINATE),
        Just(-MAX_COORDINATE),
        Just(1e8f32),
        Just(f32::MIN_POSITIVE),
        Just(1e-30f32),
        Just(0.0f32),
        -MAX_COORDINATE..MAX_COORDINATE,
        -100.0f32..100.0,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    #[test]
    fn extreme_finite_values_never_give_a_non_finite_contact(
        edits in prop::collection::vec((0..FLOATS, extreme()), 1..8),
        dy in -6.0f32..6.0,
        nearest in any::<bool>(),
    ) {
        let mut d = detector(nearest);
        d.detect(&state(dy)).expect("a good frame first");
        let mut s = state(dy);
        for &(i, v) in &edits {
            s[i] = v;
        }
        match d.detect(&s) {
            Ok(contacts) => {
                for c in contacts {
                    prop_assert!(all_finite(c), "a non-finite contact: {c:?}");
                }
            }
            Err(InputError::OutOfRangePoint { .. } | InputError::OutOfRangeSpoke { .. } | InputError::NonFiniteResult { .. } | InputError::NotStarShaped { .. }) => {}
            Err(e) => prop_assert!(false, "unexpected refusal: {e}"),
        }
        // The detector goes on: the next good frame is answered, finitely.
        let after = d.detect(&state(dy)).expect("a good frame after");
        prop_assert!(after.iter().all(all_finite));
    }
}

#[test]
fn a_frame_of_1e38_is_refused_naming_the_first_value() {
    let mut d = detector(false);
    let err = d.detect(&[1e38; FLOATS]).unwrap_err();
    assert_eq!(err, InputError::OutOfRangePoint { body: "colon".into(), point: 0, value: 1e38 });
    assert!(err.to_string().contains("beyond the 1e9"), "{err}");
}

#[test]
fn a_scope_point_1e30_away_is_refused_naming_the_scope_and_its_point() {
    let mut d = detector(true);
    let mut s = state(0.0);
    s[RINGS * (SPOKES + 1) * 3 + 3 * 2 + 1] = 1e30; // point 2, y
    assert_eq!(d.detect(&s).unwrap_err(), InputError::OutOfRangePoint { body: "scope".into(), point: 2, value: 1e30 });
    // The largest value allowed is allowed: the frame is answered, every contact finite.
    s[RINGS * (SPOKES + 1) * 3 + 3 * 2 + 1] = MAX_COORDINATE;
    let contacts = d.detect(&s).expect("MAX_COORDINATE is within range");
    assert!(contacts.iter().all(all_finite));
}

#[test]
fn a_spoke_out_of_range_is_named_by_ring_and_spoke() {
    let mut d = detector(false);
    let mut s = state(0.0);
    s[2 * (SPOKES + 1) * 3 + 3 * (1 + 4)] = -2e9; // ring 2, spoke 4, x
    assert_eq!(d.detect(&s).unwrap_err(), InputError::OutOfRangeSpoke { body: "colon".into(), ring: 2, spoke: 4, value: -2e9 });
}
