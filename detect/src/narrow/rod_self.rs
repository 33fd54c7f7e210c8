//! A rod against its own non-adjacent part: the rod-rod test ([`rod_rod`]) of the rod against
//! itself, skipping sample pairs closer along the rod than `pi * (ra + rb) / 2` (a rod of
//! radius `r` cannot bend tighter than a half circle of radius `r` before its surface meets
//! itself).

use super::rod_rod::{rod_rod, Best};
use super::Emit;
use crate::broad::bvh::ChainBvh;
use crate::broad::RodFrame;
use crate::samples::RodSamples;
use lumen_proto::Contact;

/// The job of one self-contact pair: the rod's slot, and each sample's best contact so far.
#[derive(Debug, Clone, Default)]
pub struct RodSelf {
    pub rod: usize,
    best: Vec<Best>,
}

impl RodSelf {
    /// The job for rod slot `rod` against itself.
    pub fn new(rod: usize) -> Self {
        Self { rod, best: Vec::new() }
    }

    /// This frame's self contacts of `rod` (its arc lengths measured here when missing),
    /// appended to `out`; returns the candidate leaf pairs.
    #[inline]
    pub fn run(&mut self, samples: &mut RodSamples, bvh: &ChainBvh, emit: &Emit, out: &mut Vec<Contact>) -> u32 {
        // `fill` empties the arc lengths each frame; measure them once if needed.
        if samples.arc.len() != samples.len() {
            samples.measure_arc();
        }
        let rod = RodFrame { samples, bvh };
        rod_rod(rod, rod, true, &mut self.best, emit, out)
    }
}
