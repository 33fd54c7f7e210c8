//! The detector: one object per scene, fed one state per frame, returning that frame's contacts.

use crate::bvh::ChainBvh;
use crate::narrow::rods::{self, Best};
use crate::narrow::signed::{self, Counters, SignedParams, TubeBvh, Track};
use crate::narrow::thesis::Thesis;
use crate::narrow::Emit;
use crate::samples::RodSamples;
use crate::section::{Gap, TubeCache};
use crate::view::{RodView, TubeView};
use crate::V3;
use lumen_proto::{Contact, ContactKind, InputError, Method, SceneSpec, Shape, SpecError, StateLayout};

/// Per-frame figures, for benchmarks and diagnostics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Rod samples located by walking from the previous frame or from their neighbour.
    pub walked: u32,
    /// Rod samples that had to re-acquire through the BVH.
    pub reacquired: u32,
    /// Candidate leaf pairs from BVH traversals.
    pub candidates: u32,
    /// Ring planes the default method's walks crossed (from each sample's starting guess).
    pub planes: u32,
    /// Contacts emitted.
    pub contacts: u32,
}

enum BodyState {
    Tube { cache: TubeCache, bvh: TubeBvh },
    Rod { samples: RodSamples, bvh: ChainBvh, sampled: bool, bvh_fresh: bool },
}

#[derive(Default)]
struct PairState {
    tracks: Vec<Track>,
    gaps: Vec<(f32, Gap)>,
    best: Vec<Best>,
}

/// Collision detection for one scene. Create it once, call [`Detector::detect`] every frame.
///
/// Holds the per-sample history that makes the default method coherent, and every buffer the
/// pipeline needs, so a warmed-up detector allocates nothing per frame.
pub struct Detector {
    spec: SceneSpec,
    layout: StateLayout,
    pairs: Vec<(usize, usize, ContactKind)>,
    bodies: Vec<BodyState>,
    pair_state: Vec<PairState>,
    thesis: Thesis,
    contacts: Vec<Contact>,
    stats: FrameStats,
    refine: u32,
    nearest: bool,
}

impl Detector {
    /// A detector for `spec`, or the reason the spec cannot be used.
    pub fn new(spec: &SceneSpec) -> Result<Self, SpecError> {
        let pairs = spec.validate()?;
        let layout = StateLayout::of(spec);
        let bodies = spec
            .bodies
            .iter()
            .map(|b| match b.shape {
                Shape::Tube { .. } => BodyState::Tube { cache: TubeCache::default(), bvh: TubeBvh::default() },
                Shape::Rod { .. } => BodyState::Rod { samples: RodSamples::default(), bvh: ChainBvh::default(), sampled: false, bvh_fresh: false },
            })
            .collect();
        let pair_state = pairs.iter().map(|_| PairState::default()).collect();
        Ok(Self { spec: spec.clone(), layout, pairs, bodies, pair_state, thesis: Thesis::default(), contacts: Vec::new(), stats: FrameStats::default(), refine: spec.refine, nearest: spec.nearest })
    }

    /// The scene this detector serves.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }

    /// Where each body's floats go in the state.
    pub fn layout(&self) -> &StateLayout {
        &self.layout
    }

    /// Switches the method; the next frame starts without history.
    pub fn set_method(&mut self, method: Method) {
        self.spec.method = method;
        self.reset();
    }

    /// Number of axial re-projections of the signed method (the spec's `refine`, default 0),
    /// overriding the spec. Each one moves the
    /// evaluated section to the foot of the last estimate, which helps where the wall slopes
    /// steeply along the tube, at the cost of one more evaluation per sample.
    pub fn set_refine(&mut self, refine: u32) {
        self.refine = refine;
    }

    /// Whether the signed method moves each contact to the nearest point of the continuous
    /// wall ([`crate::nearest`]; the spec's `nearest`, false by default). Off, a contact keeps
    /// the section's own foot and the distance to the wall's tangent plane there: cheaper, and
    /// tenths of a millimetre off where the wall slopes along the tube, millimetres either way
    /// on a steep fold ([`crate::nearest`] says why).
    pub fn set_nearest(&mut self, on: bool) {
        self.nearest = on;
    }

    /// Forgets all history: the next frame locates every sample through the BVH.
    pub fn reset(&mut self) {
        for p in &mut self.pair_state {
            p.tracks.iter_mut().for_each(|t| *t = Track::default());
        }
    }

    /// Figures of the last frame.
    pub fn stats(&self) -> FrameStats {
        self.stats
    }

    /// Contacts of the last successful frame.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Runs the pipeline on one frame's `state` (layout: [`lumen_proto::state`]) and returns its
    /// contacts, ordered by pair, then by rod sample. A state of the wrong length or holding a
    /// non-finite value is rejected with an error naming body and index; the detector's history
    /// is kept, so the next good frame continues.
    pub fn detect(&mut self, state: &[f32]) -> Result<&[Contact], InputError> {
        self.layout.check(&self.spec, state)?;
        Ok(self.run(state))
    }

    /// [`Detector::detect`] for a state the caller has already checked with
    /// [`StateLayout::check`] (the daemon validates every frame on receipt). It skips the scan of
    /// every float, which reads the whole tube and would make the frame cost grow with the
    /// tube's length; only the length is checked. A non-finite value that slips through cannot
    /// panic or loop, but the contacts near it are meaningless.
    pub fn detect_prevalidated(&mut self, state: &[f32]) -> Result<&[Contact], InputError> {
        if state.len() != self.layout.floats {
            return Err(InputError::StateLength { expected: self.layout.floats, got: state.len() });
        }
        Ok(self.run(state))
    }

    fn run(&mut self, state: &[f32]) -> &[Contact] {
        // Local origin: the scene's first control point (see `view`).
        let origin = V3::new(state[0], state[1], state[2]);
        let x = self.spec.precision as usize;
        let alpha = self.spec.alpha;
        for (b, body) in self.bodies.iter_mut().enumerate() {
            match body {
                BodyState::Tube { cache, bvh } => {
                    cache.begin(self.layout.bodies[b].points, alpha);
                    bvh.begin();
                }
                BodyState::Rod { sampled, bvh_fresh, .. } => {
                    *sampled = false;
                    *bvh_fresh = false;
                }
            }
        }
        self.contacts.clear();
        self.stats = FrameStats::default();
        let mut counters = Counters::default();
        let margin = self.spec.margin;
        let params = SignedParams { refine: self.refine, nearest: self.nearest };
        for pi in 0..self.pairs.len() {
            let (a, b, kind) = self.pairs[pi];
            let emit = Emit { pair: pi as u16, kind: kind as u8, body_a: a as u16, body_b: b as u16, origin, margin };
            self.ensure_rod(a, state, origin, x, alpha, kind != ContactKind::Interior || self.spec.method == Method::Thesis);
            if a != b && matches!(self.spec.bodies[b].shape, Shape::Rod { .. }) {
                self.ensure_rod(b, state, origin, x, alpha, true);
            }
            let lb = self.layout.bodies[b];
            let ps = &mut self.pair_state[pi];
            match (kind, &self.spec.bodies[b].shape) {
                (ContactKind::Interior, Shape::Tube { .. }) | (ContactKind::Exterior, Shape::Tube { .. }) => {
                    let (rod_samples, rod_bvh, tube_state) = split_rod_tube(&mut self.bodies, a, b);
                    let BodyState::Tube { cache, bvh } = tube_state else { unreachable!() };
                    let t = TubeView::new(&state[lb.offset..lb.offset + lb.floats()], lb.points, lb.spokes, origin);
                    if kind == ContactKind::Exterior {
                        signed::exterior(&t, cache, bvh, rod_samples, rod_bvh, &mut ps.gaps, params, &emit, &mut self.contacts, &mut counters);
                    } else if self.spec.method == Method::Thesis {
                        counters.candidates += self.thesis.interior(&t, cache, rod_samples, &emit, &mut self.contacts);
                    } else {
                        if ps.tracks.len() != rod_samples.len() {
                            ps.tracks.clear();
                            ps.tracks.resize(rod_samples.len(), Track::default());
                        }
                        signed::interior(&t, cache, bvh, rod_samples, &mut ps.tracks, params, &emit, &mut self.contacts, &mut counters);
                    }
                }
                (_, Shape::Rod { .. }) => {
                    if a == b {
                        let BodyState::Rod { samples, bvh, .. } = &mut self.bodies[a] else { unreachable!() };
                        // `fill` empties the arc lengths each frame; measure them once if needed.
                        if samples.arc.len() != samples.len() {
                            samples.measure_arc();
                        }
                        counters.candidates += rods::rod_rod(samples, bvh, samples, bvh, true, &mut ps.best, &emit, &mut self.contacts);
                    } else {
                        let (BodyState::Rod { samples: sa, bvh: ba, .. }, BodyState::Rod { samples: sb, bvh: bb, .. }) = (&self.bodies[a], &self.bodies[b]) else {
                            unreachable!()
                        };
                        counters.candidates += rods::rod_rod(sa, ba, sb, bb, false, &mut ps.best, &emit, &mut self.contacts);
                    }
                }
                (ContactKind::SelfContact, Shape::Tube { .. }) => unreachable!("validated: self contact is rod-only"),
            }
        }
        self.stats = FrameStats { walked: counters.walked, reacquired: counters.reacquired, candidates: counters.candidates, planes: counters.planes, contacts: self.contacts.len() as u32 };
        &self.contacts
    }

    /// Samples rod `i` once per frame, and builds its BVH when `with_bvh`.
    fn ensure_rod(&mut self, i: usize, state: &[f32], origin: V3, x: usize, alpha: f32, with_bvh: bool) {
        let l = self.layout.bodies[i];
        let spec = &self.spec.bodies[i];
        let margin = self.spec.margin;
        let BodyState::Rod { samples, bvh, sampled, bvh_fresh } = &mut self.bodies[i] else { return };
        if !*sampled {
            let rod = RodView::new(&state[l.offset..l.offset + l.floats()], l.points, origin);
            samples.fill(&rod, |j| spec.radius(j), x, alpha);
            *sampled = true;
        }
        if with_bvh && !*bvh_fresh {
            bvh.build(samples.cubic.len(), |j| samples.leaf(j, margin * 0.5));
            *bvh_fresh = true;
        }
    }
}

/// Borrows rod `a`'s samples and BVH and tube `b`'s state at once (`a != b`).
fn split_rod_tube(bodies: &mut [BodyState], a: usize, b: usize) -> (&RodSamples, &ChainBvh, &mut BodyState) {
    let (ra, tb) = if a < b {
        let (lo, hi) = bodies.split_at_mut(b);
        (&lo[a], &mut hi[0])
    } else {
        let (lo, hi) = bodies.split_at_mut(a);
        (&hi[0], &mut lo[b])
    };
    let BodyState::Rod { samples, bvh, .. } = ra else { unreachable!("validated: body a is a rod") };
    (samples, bvh, tb)
}
