//! The detector: one object per scene, fed one state per frame, returning that frame's contacts.

use crate::broad::bvh::ChainBvh;
use crate::broad::tube_bvh::TubeBvh;
use crate::broad::{Counters, RodFrame, TubeFrame};
use crate::narrow::rod_in_tube::RodInTube;
use crate::narrow::rod_on_tube::RodOnTube;
use crate::narrow::rod_rod::RodRod;
use crate::narrow::rod_self::RodSelf;
use crate::narrow::thesis::Thesis;
use crate::narrow::{Emit, Job, SignedParams};
use crate::samples::RodSamples;
use crate::section::TubeCache;
use crate::view::{RodView, TubeView};
use crate::V3;
use lumen_proto::state::all_finite;
use lumen_proto::{BodySpec, Contact, ContactKind, InputError, Method, PairIndex, SceneSpec, Shape, StateLayout, ValidScene};

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

/// A tube's per-frame buffers.
struct TubeState {
    /// Its index among the scene's bodies.
    body: usize,
    cache: TubeCache,
    bvh: TubeBvh,
}

/// A rod's samples and BVH, each computed at most once a frame.
struct RodState {
    /// Its index among the scene's bodies.
    body: usize,
    samples: RodSamples,
    bvh: ChainBvh,
    sampled: bool,
    bvh_fresh: bool,
}

/// What a frame reads everywhere: the state, where each body lies in it, and the settings.
#[derive(Clone, Copy)]
struct FrameCtx<'a> {
    state: &'a [f32],
    layout: &'a StateLayout,
    bodies: &'a [BodySpec],
    /// Local origin: the scene's first control point (see `view`).
    origin: V3,
    x: usize,
    alpha: f32,
    margin: f32,
}

impl TubeState {
    /// The tube as this frame sees it.
    #[inline]
    fn frame<'a>(&'a mut self, f: &FrameCtx<'a>) -> TubeFrame<'a> {
        let l = f.layout.bodies[self.body];
        let view = TubeView::new(&f.state[l.offset..l.offset + l.floats()], l.points, l.spokes, f.origin);
        TubeFrame { view, cache: &mut self.cache, bvh: &mut self.bvh }
    }
}

impl RodState {
    /// Samples the rod once per frame, and builds its BVH when `with_bvh`.
    fn ensure(&mut self, f: &FrameCtx, with_bvh: bool) {
        let l = f.layout.bodies[self.body];
        let spec = &f.bodies[self.body];
        if !self.sampled {
            let rod = RodView::new(&f.state[l.offset..l.offset + l.floats()], l.points, f.origin);
            self.samples.fill(&rod, |j| spec.radius(j), f.x, f.alpha);
            self.sampled = true;
        }
        if with_bvh && !self.bvh_fresh {
            let samples = &self.samples;
            self.bvh.build(samples.cubic.len(), |j| samples.leaf(j, f.margin * 0.5));
            self.bvh_fresh = true;
        }
    }

    /// The rod as this frame sees it.
    #[inline]
    fn frame(&self) -> RodFrame<'_> {
        RodFrame { samples: &self.samples, bvh: &self.bvh }
    }
}

/// Each pair's job, for `method`; `slot[body]` is the body's index among the tubes or the rods.
fn jobs(spec: &SceneSpec, pairs: &[PairIndex], slot: &[usize], method: Method) -> Vec<Job> {
    pairs
        .iter()
        .map(|p| {
            let (a, b) = (slot[p.a], slot[p.b]);
            match (p.kind, &spec.bodies[p.b].shape) {
                (ContactKind::SelfContact, _) => Job::RodSelf(RodSelf::new(a)),
                (_, Shape::Rod { .. }) => Job::RodRod(RodRod::new(a, b)),
                (ContactKind::Exterior, Shape::Tube { .. }) => Job::RodOnTube(RodOnTube::new(a, b)),
                (ContactKind::Interior, Shape::Tube { .. }) if method == Method::Thesis => Job::Thesis(Box::new(Thesis::new(a, b))),
                (ContactKind::Interior, Shape::Tube { .. }) => Job::RodInTube(RodInTube::new(a, b)),
            }
        })
        .collect()
}

/// Collision detection for one scene. Create it once, call [`Detector::detect`] every frame.
///
/// Holds the per-sample history that makes the default method coherent, and every buffer the
/// pipeline needs, so a warmed-up detector allocates nothing per frame.
pub struct Detector {
    spec: SceneSpec,
    layout: StateLayout,
    pairs: Vec<PairIndex>,
    /// Each body's index among the tubes or the rods.
    slot: Vec<usize>,
    tubes: Vec<TubeState>,
    rods: Vec<RodState>,
    /// One per pair, in the pairs' order.
    jobs: Vec<Job>,
    contacts: Vec<Contact>,
    stats: FrameStats,
    refine: u32,
    nearest: bool,
}

impl Detector {
    /// A detector for a validated scene ([`SceneSpec::validate`]).
    pub fn new(scene: &ValidScene) -> Self {
        let spec = scene.spec();
        let (mut tubes, mut rods, mut slot) = (Vec::new(), Vec::new(), Vec::with_capacity(spec.bodies.len()));
        for (body, b) in spec.bodies.iter().enumerate() {
            match b.shape {
                Shape::Tube { .. } => {
                    slot.push(tubes.len());
                    tubes.push(TubeState { body, cache: TubeCache::default(), bvh: TubeBvh::default() });
                }
                Shape::Rod { .. } => {
                    slot.push(rods.len());
                    rods.push(RodState { body, samples: RodSamples::default(), bvh: ChainBvh::default(), sampled: false, bvh_fresh: false });
                }
            }
        }
        let jobs = jobs(spec, scene.pairs(), &slot, spec.method);
        Self {
            spec: spec.clone(),
            layout: scene.layout().clone(),
            pairs: scene.pairs().to_vec(),
            slot,
            tubes,
            rods,
            jobs,
            contacts: Vec::new(),
            stats: FrameStats::default(),
            refine: spec.refine,
            nearest: spec.nearest,
        }
    }

    /// The scene this detector serves.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }

    /// Where each body's floats go in the state.
    pub fn layout(&self) -> &StateLayout {
        &self.layout
    }

    /// Switches the method (the interior pairs' jobs are made again); the next frame starts
    /// without history.
    pub fn set_method(&mut self, method: Method) {
        self.spec.method = method;
        self.jobs = jobs(&self.spec, &self.pairs, &self.slot, method);
    }

    /// Number of axial re-projections of the signed method (the spec's `refine`, default 0),
    /// overriding the spec. Each one moves the
    /// evaluated section to the foot of the last estimate, which helps where the wall slopes
    /// steeply along the tube, at the cost of one more evaluation per sample.
    pub fn set_refine(&mut self, refine: u32) {
        self.refine = refine;
    }

    /// Whether the signed method puts each contact at the nearest point of the continuous wall
    /// ([`crate::nearest`]; the spec's `nearest`, true by default). Off (the `sections`
    /// reading), a contact keeps the section's own foot and the distance to the wall's tangent
    /// plane there: cheaper, and tenths of a millimetre off where the wall slopes along the
    /// tube, millimetres either way on a steep fold ([`crate::nearest`] says why).
    pub fn set_nearest(&mut self, on: bool) {
        self.nearest = on;
    }

    /// Forgets all history: the next frame locates every sample through the BVH.
    pub fn reset(&mut self) {
        for job in &mut self.jobs {
            if let Job::RodInTube(j) = job {
                j.reset();
            }
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
        self.layout.check(&self.spec.bodies, state)?;
        self.run(state)
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
        self.run(state)
    }

    fn run(&mut self, state: &[f32]) -> Result<&[Contact], InputError> {
        let Self { spec, layout, pairs, tubes, rods, jobs, contacts, .. } = self;
        let f = FrameCtx { state, layout, bodies: &spec.bodies, origin: V3::new(state[0], state[1], state[2]), x: spec.precision as usize, alpha: spec.alpha, margin: spec.margin };
        for t in tubes.iter_mut() {
            t.cache.begin(layout.bodies[t.body].points, f.alpha);
            t.bvh.begin();
        }
        for r in rods.iter_mut() {
            r.sampled = false;
            r.bvh_fresh = false;
        }
        contacts.clear();
        let mut counters = Counters::default();
        let params = SignedParams { refine: self.refine, nearest: self.nearest };
        for (pi, (job, p)) in jobs.iter_mut().zip(pairs.iter()).enumerate() {
            let emit = Emit { pair: pi as u16, kind: p.kind as u8, body_a: p.a as u16, body_b: p.b as u16, origin: f.origin, margin: f.margin };
            match job {
                Job::RodInTube(j) => {
                    rods[j.rod].ensure(&f, false);
                    j.run(tubes[j.tube].frame(&f), &rods[j.rod].samples, params, &emit, contacts, &mut counters);
                }
                Job::Thesis(j) => {
                    rods[j.rod].ensure(&f, true);
                    let TubeFrame { view, cache, .. } = tubes[j.tube].frame(&f);
                    counters.candidates += j.run(&view, cache, &rods[j.rod].samples, &emit, contacts);
                }
                Job::RodOnTube(j) => {
                    rods[j.rod].ensure(&f, true);
                    j.run(tubes[j.tube].frame(&f), rods[j.rod].frame(), params, &emit, contacts, &mut counters);
                }
                Job::RodRod(j) => {
                    rods[j.a].ensure(&f, true);
                    rods[j.b].ensure(&f, true);
                    counters.candidates += j.run(rods[j.a].frame(), rods[j.b].frame(), &emit, contacts);
                }
                Job::RodSelf(j) => {
                    let rod = &mut rods[j.rod];
                    rod.ensure(&f, true);
                    counters.candidates += j.run(&mut rod.samples, &rod.bvh, &emit, contacts);
                }
            }
        }
        self.stats = FrameStats { walked: counters.walked, reacquired: counters.reacquired, candidates: counters.candidates, planes: counters.planes, contacts: self.contacts.len() as u32 };
        // Nothing non-finite leaves the detector: a contact that came out so refuses the frame.
        if let Some(c) = self.contacts.iter().find(|c| !finite(c)) {
            return Err(InputError::NonFiniteResult { body: self.spec.bodies[c.body_a as usize].name.clone(), sample: c.sample as usize });
        }
        Ok(&self.contacts)
    }
}

/// Whether every float of a contact is finite.
fn finite(c: &Contact) -> bool {
    let [w0, w1, w2, w3] = c.weights_b;
    let ([a0, a1, a2], [b0, b1, b2], [n0, n1, n2]) = (c.point_a, c.point_b, c.normal);
    all_finite(&[c.param_a, c.param_b, w0, w1, w2, w3, a0, a1, a2, b0, b1, b2, n0, n1, n2, c.depth])
}

#[cfg(test)]
mod tests {
    use super::finite;
    use lumen_proto::Contact;

    #[test]
    fn a_contact_with_any_non_finite_float_is_caught() {
        let good = Contact { normal: [0.0, 1.0, 0.0], depth: 0.5, ..Contact::default() };
        assert!(finite(&good));
        let spoil: [fn(&mut Contact); 6] =
            [|c| c.depth = f32::INFINITY, |c| c.normal[2] = f32::NAN, |c| c.point_a[0] = f32::NEG_INFINITY, |c| c.point_b[1] = f32::NAN, |c| c.weights_b[3] = f32::NAN, |c| c.param_b = f32::INFINITY];
        for s in spoil {
            let mut c = good;
            s(&mut c);
            assert!(!finite(&c), "{c:?}");
        }
    }
}
