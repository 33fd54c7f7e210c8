//! Where a lumen is narrower than the scope that goes through it.
//!
//! A colon narrower than the scope is normal (a collapsed or spastic segment, the anal canal):
//! the scope pushes the wall open. A simulator wants to know where that happens before it runs,
//! so the detection and the contact response there are no surprise.

use crate::quality::ranges;
use lumen_detect::Tube;
use std::ops::RangeInclusive;

/// A run of rings whose smallest radial vector is shorter than the scope's radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Narrowing {
    pub rings: RangeInclusive<usize>,
    /// The smallest radial vector in the run, in the tube's unit.
    pub smallest: f64,
}

/// The runs of rings of `tube` where some radial vector is shorter than `radius` (the scope's),
/// in order along the tube.
pub fn narrowings(tube: &Tube, radius: f64) -> Vec<Narrowing> {
    let smallest: Vec<f64> = (0..tube.rings()).map(|i| (0..tube.spokes).map(|k| tube.spoke(i, k).iter().map(|c| (*c as f64).powi(2)).sum::<f64>().sqrt()).fold(f64::INFINITY, f64::min)).collect();
    ranges((0..tube.rings()).filter(|&i| smallest[i] < radius))
        .into_iter()
        .map(|r| {
            let s = smallest[r.clone()].iter().copied().fold(f64::INFINITY, f64::min);
            Narrowing { rings: r, smallest: s }
        })
        .collect()
}
