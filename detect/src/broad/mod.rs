//! Broad phase: where along a tube each rod sample is, and which leaf pairs may touch.
//!
//! - [`aabb`], [`bvh`]: boxes and the bottom-up chain BVH;
//! - [`tube_bvh`]: the tube's BVH with conservative leaves, refit at most once a frame;
//! - [`track`]: each sample's memory of last frame's segment and sector, the walk of ring
//!   planes from there, re-acquisition through the BVH, and the second look across folded
//!   planes.
//!
//! The narrow phase ([`crate::narrow`]) turns the places found here into contacts.

pub mod aabb;
pub mod bvh;
pub mod track;
pub mod tube_bvh;

use crate::section::TubeCache;
use crate::view::TubeView;
use tube_bvh::TubeBvh;

/// Counters of one frame, for benchmarks and diagnostics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Samples located by walking from last frame or from their neighbour.
    pub walked: u32,
    /// Samples that re-acquired through the BVH.
    pub reacquired: u32,
    /// Candidate leaf pairs from BVH traversals.
    pub candidates: u32,
    /// Ring planes the walks crossed, from each sample's starting guess to its segment.
    pub planes: u32,
}

/// One tube as a frame sees it: its view of the state, its per-frame cache of rings and
/// midline cubics, and its BVH. What travels together through the broad and narrow phases.
pub struct TubeFrame<'a> {
    pub view: TubeView<'a>,
    pub cache: &'a mut TubeCache,
    pub bvh: &'a mut TubeBvh,
}

/// One rod as a frame sees it: its samples and the BVH over its segments.
#[derive(Clone, Copy)]
pub struct RodFrame<'a> {
    pub samples: &'a crate::samples::RodSamples,
    pub bvh: &'a bvh::ChainBvh,
}
