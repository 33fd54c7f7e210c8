//! Where each body's floats live in the flat per-frame state.
//!
//! Bodies follow one another in the order the spec declares them, with no padding:
//! - a tube of `A` rings and `B` spokes: for each ring, its control point `x y z` then its `B`
//!   radial vectors `x y z` (relative to the control point): `A * (B + 1) * 3` floats, so one
//!   ring's data is contiguous;
//! - a rod of `A` points: `A * 3` floats.

use crate::error::InputError;
use crate::limits::MAX_COORDINATE;
use crate::scene::{BodySpec, SceneSpec, Shape};

/// Offsets of one body in the state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BodyLayout {
    /// First float of the body.
    pub offset: usize,
    /// Control points (rings).
    pub points: usize,
    /// Spokes per ring; 0 for a rod.
    pub spokes: usize,
}

impl BodyLayout {
    /// Floats between consecutive control points.
    pub fn stride(&self) -> usize {
        (self.spokes + 1) * 3
    }
    /// Total floats of the body.
    pub fn floats(&self) -> usize {
        self.points * self.stride()
    }
}

/// The layout of a whole scene's state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StateLayout {
    pub bodies: Vec<BodyLayout>,
    /// Total floats per frame.
    pub floats: usize,
}

impl StateLayout {
    /// Layout of `spec` (assumed validated).
    pub fn of(spec: &SceneSpec) -> Self {
        let mut offset = 0;
        let bodies = spec
            .bodies
            .iter()
            .map(|b| {
                let spokes = match b.shape {
                    Shape::Tube { spokes, .. } => spokes,
                    Shape::Rod { .. } => 0,
                };
                let l = BodyLayout { offset, points: b.points(), spokes };
                offset += l.floats();
                l
            })
            .collect();
        Self { bodies, floats: offset }
    }

    /// Checks the length and that every value is finite and within
    /// [`crate::limits::MAX_COORDINATE`]; the error names body, ring and spoke (`bodies`: the
    /// spec's bodies this layout was derived from, for their names).
    pub fn check(&self, bodies: &[BodySpec], state: &[f32]) -> Result<(), InputError> {
        if state.len() != self.floats {
            return Err(InputError::StateLength { expected: self.floats, got: state.len() });
        }
        // Fast path: a branch-free pass the compiler vectorises (an early-exit `all` does
        // not); the slow path below only runs to name the culprit.
        if all_in_range(state) {
            return Ok(());
        }
        // The first non-finite value anywhere, else the first one out of range.
        for finite_only in [true, false] {
            for (b, l) in self.bodies.iter().enumerate() {
                let data = &state[l.offset..l.offset + l.floats()];
                let bad = |v: &f32| if finite_only { !v.is_finite() } else { v.abs() > MAX_COORDINATE };
                if let Some(i) = data.iter().position(bad) {
                    let (point, within) = (i / l.stride(), i % l.stride() / 3);
                    let (body, value) = (bodies[b].name.clone(), data[i]);
                    return Err(match (finite_only, within) {
                        (true, 0) => InputError::NonFinitePoint { body, point, value },
                        (true, _) => InputError::NonFiniteSpoke { body, ring: point, spoke: within - 1, value },
                        (false, 0) => InputError::OutOfRangePoint { body, point, value },
                        (false, _) => InputError::OutOfRangeSpoke { body, ring: point, spoke: within - 1, value },
                    });
                }
            }
        }
        unreachable!("a value out of range was seen in the state")
    }
}

/// True when every value is finite with a magnitude of at most [`MAX_COORDINATE`].
///
/// For a non-negative `f32` (the sign bit cleared) the order of the bit patterns is the order
/// of the values, and NaN and infinities sort above every finite value, so one branch-free
/// maximum over the patterns (which vectorises) answers both questions.
pub fn all_in_range(values: &[f32]) -> bool {
    let largest = values.iter().fold(0u32, |m, v| m.max(v.to_bits() & 0x7fff_ffff));
    largest <= MAX_COORDINATE.to_bits()
}

/// True when no value is NaN or infinite.
///
/// A finite `f32` has exponent bits `e = bits & 0x7f80_0000` below `0x7f80_0000`, so
/// `e + 0x0080_0000` reaches bit 31 exactly for NaN and infinities. OR-ing those sums is a
/// plain integer and/add/or reduction, which vectorises on every x86-64 (an early-exit `all` or
/// a `bool` fold does not).
pub fn all_finite(values: &[f32]) -> bool {
    const EXP: u32 = 0x7f80_0000;
    let acc = values.iter().fold(0u32, |acc, v| acc | (v.to_bits() & EXP).wrapping_add(0x0080_0000));
    acc & 0x8000_0000 == 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneSpec;

    #[test]
    fn all_finite_sees_every_position() {
        for n in [0, 1, 255, 256, 257, 600] {
            let mut v = vec![1.5f32; n];
            assert!(all_finite(&v));
            for i in 0..n {
                for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    v[i] = bad;
                    assert!(!all_finite(&v), "n {n} i {i}");
                    v[i] = -3.0e38;
                }
            }
        }
    }

    #[test]
    fn offsets_and_nan_location() {
        let spec =
            SceneSpec::new(vec![BodySpec { name: "t".into(), shape: Shape::Tube { rings: 3, spokes: 4 } }, BodySpec { name: "r".into(), shape: Shape::Rod { points: 2, radius: vec![1.0] } }], vec![]);
        let l = StateLayout::of(&spec);
        assert_eq!(l.bodies[1].offset, 3 * 5 * 3);
        assert_eq!(l.floats, 45 + 6);
        let mut s = vec![0.0; l.floats];
        assert_eq!(l.check(&spec.bodies, &s[1..]), Err(InputError::StateLength { expected: 51, got: 50 }));
        s[15 + 3 * 3 + 1] = f32::NAN; // ring 1, spoke 2, y
        assert!(matches!(l.check(&spec.bodies, &s), Err(InputError::NonFiniteSpoke { ring: 1, spoke: 2, .. })));
        s[15 + 10] = 0.0;
        s[45 + 4] = f32::INFINITY; // rod point 1
        assert!(matches!(l.check(&spec.bodies, &s), Err(InputError::NonFinitePoint { point: 1, .. })));
    }
}
