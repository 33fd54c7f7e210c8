//! One simulation: the scope, the wall, the operator and the contacts, frame by frame.
//!
//! **Units**: millimetres, seconds, kilograms; reported forces in newtons.
//!
//! **Time.** A frame is a fixed [`SimParams::dt_s`] of simulated time (default 1 ms: the 1 kHz
//! of a haptic loop), solved in [`SimParams::substeps`] XPBD substeps (default 16, `h` =
//! 62.5 us); the operator's script is written in simulated seconds.
//!
//! **One frame** ([`World::step`]):
//! 1. the operator gives the frame's drive (handle target, force limit, roll, angulation, tip
//!    hold);
//! 2. the contacts detected at the end of the previous frame (that is, on the positions this
//!    frame starts from), with the crease faces beside those of the scope's end segments
//!    ([`crate::crease`]), become constraints: the wall nodes under them are activated, the
//!    wall settles (spreads, releases, links its nodes), each contact is linearised about the
//!    current positions, and a sample's contact of the frame before is carried along where
//!    its normal turned (see [`crate::contact`]);
//! 3. `substeps` times: predict rod and wall; the hand (a spring of stiffness `k_hand` towards
//!    the target, force capped), the tip hold and the anus guide (scope points behind the
//!    first ring's plane are held on the insertion axis); bend and stretch; the wall's springs,
//!    membrane and range; the contacts (twice); velocities, then the separating velocity of
//!    every violated contact removed (inelastic contacts), and speeds above
//!    [`SimParams::max_speed_mm_s`] cut to it (a scope point's substep displacement too);
//! 4. the NaN check; the state is written (rod points, the wall tips around active nodes;
//!    the whole colon when the source's buffer does not keep the last frame) and the contacts
//!    are detected once on it. Those contacts give this frame's figures (penetration, escapes: measured by the
//!    detector *after* the solve, on the final state of the frame) and are the next frame's
//!    constraints, so each frame costs exactly one detection.
//!
//! **The scope in the state** is listed handle first (rod point `N - 1 - j` is state point
//! `j`): the detector locates each sample from its neighbour, so it then follows the scope in
//! from the anus, which keeps every sample in its own loop where loops of a colon touch or
//! overlap (the inflated GCA colon's sigmoid does). Contacts are mapped back in
//! [`crate::contact`]; sample numbers in reports are the state's.
//!
//! **Before the first frame** the scope is fitted into the colon ([`World::fit_iterations`]):
//! where the starting pose overlaps the wall, contacts are projected on positions alone until
//! it does not, so no penetration is turned into velocity.
//!
//! **Detection is pluggable** through [`ContactSource`]: [`InProcess`] runs a
//! [`lumen_detect::Detector`] here; [`FnSource`] wraps any closure; a daemon client implements
//! the trait by handing out its shared-memory frame (`frame()` returns it with `kept = false`:
//! iceoryx2 loans hold stale data, so the whole state is written) and, in `detect`,
//! submitting it and copying the reply's contacts.

use crate::config::SimConfig;
#[cfg(doc)]
use crate::config::SimParams;
use crate::contact::ContactSet;
use crate::operator::{Drive, Operator};
use crate::rod::Rod;
use crate::setup;
use crate::wall::Wall;
use lumen_detect::V3d;
use lumen_detect::{Detector, Tube};
use lumen_proto::contact::FLAG_OUTSIDE;
use lumen_proto::{Contact, ContactKind, SceneSpec, SpecError, ValidScene};
use std::fmt;
use std::time::Instant;

/// Any error a contact source reports.
pub type SourceError = Box<dyn std::error::Error + Send + Sync>;

/// Where contacts come from: a buffer to write the frame's state into, and the contacts of
/// what was written.
pub trait ContactSource {
    /// The buffer for this frame's state (`layout.floats` values) and whether it still holds
    /// exactly what was written into it last frame (then only what changed is rewritten).
    fn frame(&mut self) -> Result<(&mut [f32], bool), SourceError>;
    /// Detects on the frame just written; replaces `out` with its contacts.
    fn detect(&mut self, out: &mut Vec<Contact>) -> Result<(), SourceError>;
    /// After `error` from [`ContactSource::frame`] or [`ContactSource::detect`]: how long to
    /// wait before writing the frame again and retrying (a daemon that went away and may come
    /// back), or `None` to give up with the error. The default gives up.
    fn retry_after(&mut self, error: &SourceError) -> Option<std::time::Duration> {
        let _ = error;
        None
    }
}

/// Detection in this process, with Lumen's default method.
pub struct InProcess {
    detector: Detector,
    state: Vec<f32>,
    written: bool,
}

impl InProcess {
    /// A detector for `scene`.
    pub fn new(scene: &ValidScene) -> Self {
        let detector = Detector::new(scene);
        let state = vec![0.0; detector.layout().floats];
        Self { detector, state, written: false }
    }

    /// The detector (for its statistics).
    pub fn detector(&self) -> &Detector {
        &self.detector
    }

    /// The last state written.
    pub fn state(&self) -> &[f32] {
        &self.state
    }
}

impl ContactSource for InProcess {
    fn frame(&mut self) -> Result<(&mut [f32], bool), SourceError> {
        let kept = self.written;
        self.written = true;
        Ok((&mut self.state, kept))
    }

    fn detect(&mut self, out: &mut Vec<Contact>) -> Result<(), SourceError> {
        // The physics checks its own positions for NaN before writing (see `World::step`), so
        // the O(colon) scan of every float is skipped.
        let c = self.detector.detect_prevalidated(&self.state)?;
        out.clear();
        out.extend_from_slice(c);
        Ok(())
    }
}

/// Any closure `f(state, contacts)` as a contact source (it keeps its own state buffer).
pub struct FnSource<F> {
    state: Vec<f32>,
    written: bool,
    f: F,
}

impl<F: FnMut(&[f32], &mut Vec<Contact>) -> Result<(), SourceError>> FnSource<F> {
    /// A source of `floats` values per frame calling `f`.
    pub fn new(floats: usize, f: F) -> Self {
        Self { state: vec![0.0; floats], written: false, f }
    }
}

impl<F: FnMut(&[f32], &mut Vec<Contact>) -> Result<(), SourceError>> ContactSource for FnSource<F> {
    fn frame(&mut self) -> Result<(&mut [f32], bool), SourceError> {
        let kept = self.written;
        self.written = true;
        Ok((&mut self.state, kept))
    }

    fn detect(&mut self, out: &mut Vec<Contact>) -> Result<(), SourceError> {
        (self.f)(&self.state, out)
    }
}

/// What went wrong in a step.
#[derive(Debug)]
pub enum SimError {
    /// The scene spec was refused.
    Spec(SpecError),
    /// The contact source failed.
    Source(SourceError),
    /// The source's frame buffer has the wrong size.
    FrameSize { expected: usize, got: usize },
    /// A position or velocity became NaN or infinite in this frame.
    NonFinite { frame: u64 },
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::Spec(e) => write!(f, "scene spec refused: {e}"),
            SimError::Source(e) => write!(f, "contact source: {e}"),
            SimError::FrameSize { expected, got } => write!(f, "frame buffer of {got} floats; the scene needs {expected}"),
            SimError::NonFinite { frame } => write!(f, "frame {frame}: the simulation produced a non-finite value"),
        }
    }
}

impl std::error::Error for SimError {}

/// The figures of one frame, measured at its end (after the solve).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameReport {
    /// Frames completed (1 for the first step; 0 for the initial state).
    pub frame: u64,
    /// Simulated time at the end of the frame, s.
    pub time_s: f64,
    /// Operator phase index and name.
    pub phase: usize,
    pub phase_name: &'static str,
    /// Contacts reported by the detector on the final state (including those within the
    /// margin), all pairs.
    pub contacts: u32,
    /// Scope-colon contacts with positive depth.
    pub touching: u32,
    /// Largest scope-colon penetration, mm (0 if none).
    pub max_penetration_mm: f32,
    /// Scope samples inside the body and outside the wall (contacts flagged `FLAG_OUTSIDE`
    /// whose sample is past the anus plane).
    pub escaped: u32,
    /// Contacts flagged `FLAG_OUTSIDE` for samples behind the anus plane, outside the patient
    /// (a detector artefact where the first rings tilt; not escapes, not answered).
    pub outside_body_flagged: u32,
    /// Self contacts with positive depth, and the deepest, mm.
    pub self_touching: u32,
    pub max_self_penetration_mm: f32,
    /// Whether a non-finite value appeared (the step then fails with [`SimError::NonFinite`]).
    pub nan: bool,
    /// Active wall nodes and the largest wall displacement, mm.
    pub active_nodes: u32,
    pub max_wall_mm: f32,
    /// Mean hand force over the frame, N (positive pushing in).
    pub hand_force_n: f64,
    /// Handle position along the insertion axis, mm.
    pub handle_mm: f64,
    /// Relative length error of the scope, `L / L0 - 1`.
    pub length_error: f64,
    /// Fastest scope control point, mm/s.
    pub max_speed_mm_s: f64,
    /// Point-substeps whose speed [`SimParams::max_speed_mm_s`] limited in the frame.
    pub speed_limited: u32,
    /// Crease faces ([`crate::crease`]) among the frame's constraints.
    pub crease_faces: u32,
    /// Rod sample of the deepest scope-colon contact, numbered as in the state (from the
    /// handle; `u32::MAX` if none).
    pub deepest_sample: u32,
    /// Wall time of the physics (everything but detection) and of the detection, s.
    pub physics_s: f64,
    pub detect_s: f64,
}

/// One running simulation.
pub struct World<S: ContactSource> {
    config: SimConfig,
    rod: Rod,
    wall: Wall,
    operator: Operator,
    contacts: ContactSet,
    raw: Vec<Contact>,
    /// `raw` and the crease faces of the scope's end segments ([`crate::crease`]): what the frame's
    /// constraints are built from.
    answered: Vec<Contact>,
    crease_faces: u32,
    source: S,
    scene: ValidScene,
    rest_colon: Vec<f32>,
    axis_origin: V3d,
    axis_dir: V3d,
    axis_ref: V3d,
    hold: Option<V3d>,
    normals: Vec<V3d>,
    /// The curvature vectors of the initial shape (released over `relax_s`).
    initial_bend: Vec<V3d>,
    fit_iterations: u32,
    speed_limited: u32,
    frame: u64,
    report: FrameReport,
}

const TUBE: u16 = 0;
const SCOPE: u16 = 1;

/// The initial fit stops once no scope sample overlaps the wall by more than this, mm.
pub const FIT_TOLERANCE_MM: f32 = 0.05;
/// The initial fit stops after this many detections.
pub const FIT_ITERATIONS: u32 = 500;

impl World<InProcess> {
    /// A simulation of `tube` with in-process detection, the scope placed by
    /// [`setup::insertion_pose`].
    pub fn in_process(tube: &Tube, config: SimConfig) -> Result<Self, SimError> {
        let scene = setup::scene_spec(tube, &config.rod, &config.sim).validate().map_err(SimError::Spec)?;
        let source = InProcess::new(&scene);
        let points = start_pose(tube, &config);
        Self::build(tube, config, source, points, scene)
    }
}

/// The scope's starting control points: laid by [`setup::insertion_pose`] with its tip at
/// `config.start_depth_mm`, or 20 mm before the sigmoid's sharpest bend.
fn start_pose(tube: &Tube, config: &SimConfig) -> Vec<V3d> {
    let depth = config.start_depth_mm.unwrap_or_else(|| setup::start_depth_mm(tube));
    setup::insertion_pose(tube, &config.rod, depth)
}

impl<S: ContactSource> World<S> {
    /// A simulation of `tube` with contacts from `source` (which must serve
    /// [`setup::scene_spec`]`(tube, &config.rod, &config.sim)`), the scope placed by
    /// [`setup::insertion_pose`]. Detects once on the initial state.
    pub fn new(tube: &Tube, config: SimConfig, source: S) -> Result<Self, SimError> {
        let points = start_pose(tube, &config);
        Self::with_rod(tube, config, source, points)
    }

    /// As [`World::new`] with the scope's initial control points given (tip first).
    pub fn with_rod(tube: &Tube, config: SimConfig, source: S, points: Vec<V3d>) -> Result<Self, SimError> {
        let scene = setup::scene_spec(tube, &config.rod, &config.sim).validate().map_err(SimError::Spec)?;
        Self::build(tube, config, source, points, scene)
    }

    /// The simulation of `tube` for its validated `scene` (the spec of [`setup::scene_spec`]).
    fn build(tube: &Tube, config: SimConfig, source: S, points: Vec<V3d>, scene: ValidScene) -> Result<Self, SimError> {
        let mut rest_colon = Vec::with_capacity(scene.layout().bodies[0].floats());
        tube.write_state(&mut rest_colon);
        let (axis_origin, axis_dir) = setup::insertion_axis(tube);
        let up = if axis_dir.y.abs() < 0.9 { V3d::y() } else { V3d::x() };
        let axis_ref = (up - axis_dir * up.dot(&axis_dir)).normalize();
        let initial_bend = (0..points.len()).map(|i| if i == 0 || i + 1 == points.len() { V3d::zeros() } else { points[i - 1] - points[i] * 2.0 + points[i + 1] }).collect();
        let rod = Rod::new(config.rod.clone(), points);
        let wall = Wall::new(tube, config.wall.clone());
        let operator = Operator::new(config.script.clone());
        let mut contacts = ContactSet::default();
        contacts.set_body_entry(axis_origin, axis_dir, config.rod.radius_mm);
        let mut w = Self {
            config,
            rod,
            wall,
            operator,
            contacts,
            raw: Vec::new(),
            answered: Vec::new(),
            crease_faces: 0,
            source,
            scene,
            rest_colon,
            axis_origin,
            axis_dir,
            axis_ref,
            hold: None,
            normals: Vec::new(),
            initial_bend,
            fit_iterations: 0,
            speed_limited: 0,
            frame: 0,
            report: FrameReport::default(),
        };
        let t0 = Instant::now();
        w.write_and_detect()?;
        w.fit()?;
        let detect_s = t0.elapsed().as_secs_f64();
        w.report = w.measure(0.0, detect_s, 0.0, 0);
        Ok(w)
    }

    /// Fits the scope into the colon before the first frame: where the starting pose overlaps
    /// the wall (a real lumen narrower than the scope, a bend tighter than its control points
    /// can follow), contacts are projected on positions alone, with every velocity kept at zero,
    /// the wall giving as it does in a frame, until the detector sees no overlap deeper than
    /// [`FIT_TOLERANCE_MM`] (at most [`FIT_ITERATIONS`] detections). The fitted shape becomes
    /// the scope's initial rest shape (released over [`SimParams::relax_s`]). Returns the
    /// number of detections it took.
    fn fit(&mut self) -> Result<u32, SimError> {
        let n = self.config.sim.substeps.max(1);
        let h = self.config.sim.dt_s / n as f64;
        let mut it = 0;
        while it < FIT_ITERATIONS && self.deepest_interior() > FIT_TOLERANCE_MM {
            self.rod.rest_bend.clone_from(&self.initial_bend);
            self.constrain(self.config.sim.dt_s);
            for _ in 0..n {
                self.rod.predict(h, V3d::zeros());
                self.wall.predict(h);
                self.rod.solve_bend(h);
                self.rod.solve_stretch(h, false);
                self.guide();
                self.wall.solve(h);
                self.contacts.begin_substep();
                for _ in 0..self.config.sim.contact_passes {
                    self.contacts.project(&mut self.rod, &mut self.wall);
                }
                self.rod.v.iter_mut().for_each(|v| *v = V3d::zeros());
                self.wall.update_velocity(h);
                self.wall.zero_velocities();
            }
            if !(self.rod.is_finite() && self.wall.is_finite()) {
                return Err(SimError::NonFinite { frame: 0 });
            }
            self.write_and_detect()?;
            it += 1;
        }
        if it > 0 {
            let x = &self.rod.x;
            for i in 1..x.len() - 1 {
                self.initial_bend[i] = x[i - 1] - x[i] * 2.0 + x[i + 1];
            }
            self.contacts = ContactSet::default();
            self.contacts.set_body_entry(self.axis_origin, self.axis_dir, self.config.rod.radius_mm);
        }
        self.fit_iterations = it;
        Ok(it)
    }

    /// Detections the initial fit took (0: the starting pose did not overlap the wall).
    pub fn fit_iterations(&self) -> u32 {
        self.fit_iterations
    }

    fn deepest_interior(&self) -> f32 {
        self.raw.iter().filter(|c| c.kind == ContactKind::Interior as u8 && self.contacts.in_body(c, &self.rod)).map(|c| c.depth).fold(0.0, f32::max)
    }

    /// The anus guide: scope points behind the first ring's plane lie on the insertion axis.
    fn guide(&mut self) {
        let (o, a) = (self.axis_origin, self.axis_dir);
        for i in (0..self.rod.len()).rev() {
            let s = a.dot(&(self.rod.x[i] - o));
            if s >= 0.0 {
                break;
            }
            self.rod.x[i] = o + a * s;
        }
    }

    /// The scene spec the source serves.
    pub fn spec(&self) -> &SceneSpec {
        self.scene.spec()
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The scope.
    pub fn rod(&self) -> &Rod {
        &self.rod
    }

    /// The wall.
    pub fn wall(&self) -> &Wall {
        &self.wall
    }

    /// The contact source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// The contacts detected at the end of the last frame.
    pub fn contacts(&self) -> &[Contact] {
        &self.raw
    }

    /// The figures of the last frame (of the initial state before the first step).
    pub fn report(&self) -> &FrameReport {
        &self.report
    }

    /// Frames completed.
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// The handle's position along the insertion axis, mm.
    pub fn handle_mm(&self) -> f64 {
        self.axis_dir.dot(&(self.rod.x[self.rod.len() - 1] - self.axis_origin))
    }

    /// Advances one frame; returns its figures.
    pub fn step(&mut self) -> Result<&FrameReport, SimError> {
        let t0 = Instant::now();
        let dt = self.config.sim.dt_s;
        let drive = self.operator.advance(dt, self.handle_mm());
        self.apply_pose_commands(&drive);
        self.constrain(dt);
        let force = self.substeps(&drive);
        self.frame += 1;
        if !(self.rod.is_finite() && self.wall.is_finite()) {
            self.report.nan = true;
            return Err(SimError::NonFinite { frame: self.frame });
        }
        let t1 = Instant::now();
        self.write_and_detect()?;
        let t2 = Instant::now();
        let physics_s = (t1 - t0).as_secs_f64();
        self.report = self.measure(physics_s, (t2 - t1).as_secs_f64(), force, drive.phase);
        self.report.physics_s += t2.elapsed().as_secs_f64();
        Ok(&self.report)
    }

    /// The contacts of the frame's start, with the crease faces of the scope's end segments, become
    /// constraints: the wall nodes under them are touched, the wall settles, and each contact is
    /// linearised about the current positions.
    fn constrain(&mut self, dt: f64) {
        self.answered.clear();
        self.answered.extend_from_slice(&self.raw);
        self.crease_faces = 0;
        if self.config.sim.crease_faces {
            // The samples of the scope's first and last segments.
            let x = self.config.sim.precision.max(1);
            let last = (self.rod.len() - 1) as u32 * x;
            let ends = crate::crease::Ends { body: SCOPE, samples: [0..=x, last.saturating_sub(x)..=last], radius_mm: self.config.rod.radius_mm };
            self.crease_faces = crate::crease::add_faces(&self.raw, &ends, TUBE, &self.wall, self.config.sim.margin_mm as f64, &mut self.answered) as u32;
        }
        self.wall.begin_frame();
        self.contacts.touch(&self.answered, SCOPE, TUBE, &self.rod, &mut self.wall);
        self.wall.settle(dt);
        self.contacts.build(&self.answered, SCOPE, TUBE, &self.rod, &self.wall);
    }

    /// Rest curvature (the initial shape being released, the angulation turned by the roll)
    /// and the tip hold, once per frame.
    fn apply_pose_commands(&mut self, drive: &Drive) {
        if drive.tip_bend != 0.0 {
            let a = self.axis_dir;
            let r = self.axis_ref * drive.roll.cos() + a.cross(&self.axis_ref) * drive.roll.sin();
            self.rod.transported_normals(r, &mut self.normals);
            self.rod.set_tip_bend(drive.tip_bend, self.config.sim.bending_section_points, &self.normals);
        } else {
            self.rod.set_tip_bend(0.0, 0, &[]);
        }
        let relax = self.config.sim.relax_s;
        let t = self.frame as f64 * self.config.sim.dt_s;
        if relax > 0.0 && t < relax {
            let f = 1.0 - t / relax;
            for (d, b) in self.rod.rest_bend.iter_mut().zip(&self.initial_bend) {
                *d += b * f;
            }
        }
        match (drive.hold_tip, self.hold) {
            (true, None) => self.hold = Some(self.rod.x[0]),
            (false, Some(_)) => self.hold = None,
            _ => {}
        }
    }

    /// The frame's substeps; returns the mean hand force, N.
    fn substeps(&mut self, drive: &Drive) -> f64 {
        let p = self.config.sim.clone();
        let n = p.substeps.max(1);
        let h = p.dt_s / n as f64;
        let g = V3d::from(p.gravity_mm_s2);
        let (o, a) = (self.axis_origin, self.axis_dir);
        let last = self.rod.len() - 1;
        let a_hand = 1.0 / (p.hand_stiffness_n_per_m * h * h);
        let a_hold = 1.0 / (p.hold_stiffness_n_per_m * h * h);
        // Force limit in the solver's units: kg mm / s^2 = mN.
        let cap = drive.force_n * 1e3 * h * h;
        let mut impulse = 0.0;
        let mut limited = 0u32;
        for sub in 0..n {
            let f = (sub + 1) as f64 / n as f64;
            let target = drive.target_mm[0] + (drive.target_mm[1] - drive.target_mm[0]) * f;
            self.rod.predict(h, g);
            self.wall.predict(h);
            // The operator's constraints first, so the rod's own constraints carry their
            // corrections along it within the substep (applied last, a capped push would
            // show as a velocity of the handle alone).
            // The hand: a capped spring from the handle to the target along the axis.
            let w = self.rod.inv_mass[last];
            if w > 0.0 {
                let c = a.dot(&(self.rod.x[last] - o)) - target;
                let dl = (-c / (w + a_hand)).clamp(-cap, cap);
                self.rod.x[last] += a * (w * dl);
                impulse += dl;
            }
            // The tip hold.
            if let Some(q) = self.hold {
                let w0 = self.rod.inv_mass[0];
                if w0 > 0.0 {
                    let d = q - self.rod.x[0];
                    self.rod.x[0] += d * (w0 / (w0 + a_hold));
                }
            }
            self.guide();
            self.rod.solve_bend(h);
            for pass in 0..p.stretch_passes.max(1) {
                self.rod.solve_stretch(h, (sub + pass) % 2 == 1);
            }
            self.wall.solve(h);
            self.contacts.begin_substep();
            for _ in 0..p.contact_passes {
                self.contacts.project(&mut self.rod, &mut self.wall);
            }
            self.rod.update_velocity(h);
            self.wall.update_velocity(h);
            self.contacts.stop_separation(&mut self.rod, &mut self.wall);
            if p.max_speed_mm_s > 0.0 {
                limited += self.rod.limit_speed(p.max_speed_mm_s, h);
                limited += self.wall.limit_speed(p.max_speed_mm_s, h);
            }
        }
        self.speed_limited = limited;
        // Mean force: the impulse over the frame is sum(dl) / h (kg mm / s), divided by dt.
        impulse / h / p.dt_s * 1e-3
    }

    /// Writes the frame's state into the source's buffer and detects, writing it again as long
    /// as the source asks to retry (see [`ContactSource::retry_after`]).
    fn write_and_detect(&mut self) -> Result<(), SimError> {
        loop {
            match self.try_write_and_detect() {
                Err(SimError::Source(e)) => match self.source.retry_after(&e) {
                    Some(pause) => std::thread::sleep(pause),
                    None => return Err(SimError::Source(e)),
                },
                done => return done,
            }
        }
    }

    /// Writes the frame's state into the source's buffer and detects, once.
    fn try_write_and_detect(&mut self) -> Result<(), SimError> {
        let (buf, kept) = self.source.frame().map_err(SimError::Source)?;
        if buf.len() != self.scene.layout().floats {
            return Err(SimError::FrameSize { expected: self.scene.layout().floats, got: buf.len() });
        }
        let tube = self.scene.layout().bodies[0];
        let stride = tube.stride();
        let spokes = tube.spokes;
        let at = move |tip: u32| {
            let (i, k) = (tip as usize / spokes, tip as usize % spokes);
            tube.offset + i * stride + 3 * (1 + k)
        };
        if !kept {
            buf[tube.offset..tube.offset + tube.floats()].copy_from_slice(&self.rest_colon);
        }
        self.wall.write_spokes(!kept, |tip, s| buf[at(tip)..at(tip) + 3].copy_from_slice(&s));
        let rod = self.scene.layout().bodies[1];
        for (j, p) in self.rod.x.iter().rev().enumerate() {
            let o = rod.offset + 3 * j;
            buf[o] = p.x as f32;
            buf[o + 1] = p.y as f32;
            buf[o + 2] = p.z as f32;
        }
        self.source.detect(&mut self.raw).map_err(SimError::Source)
    }

    fn measure(&self, physics_s: f64, detect_s: f64, force: f64, phase: usize) -> FrameReport {
        let mut r = FrameReport {
            frame: self.frame,
            time_s: self.frame as f64 * self.config.sim.dt_s,
            phase,
            phase_name: self.operator.script().phases[phase].name,
            contacts: self.raw.len() as u32,
            active_nodes: self.wall.active().len() as u32,
            max_wall_mm: self.wall.max_displacement() as f32,
            hand_force_n: force,
            handle_mm: self.handle_mm(),
            length_error: self.rod.length() / self.rod.rest_length() - 1.0,
            max_speed_mm_s: self.rod.v.iter().map(|v| v.norm()).fold(0.0, f64::max),
            speed_limited: self.speed_limited,
            crease_faces: self.crease_faces,
            deepest_sample: u32::MAX,
            physics_s,
            detect_s,
            ..FrameReport::default()
        };
        for c in &self.raw {
            if c.kind == ContactKind::Interior as u8 {
                if !self.contacts.in_body(c, &self.rod) {
                    if c.flags & FLAG_OUTSIDE != 0 {
                        r.outside_body_flagged += 1;
                    }
                    continue;
                }
                if c.depth > 0.0 {
                    r.touching += 1;
                    if c.depth > r.max_penetration_mm {
                        r.max_penetration_mm = c.depth;
                        r.deepest_sample = c.sample;
                    }
                }
                if c.flags & FLAG_OUTSIDE != 0 {
                    r.escaped += 1;
                }
            } else if c.kind == ContactKind::SelfContact as u8 && c.depth > 0.0 {
                r.self_touching += 1;
                r.max_self_penetration_mm = r.max_self_penetration_mm.max(c.depth);
            }
        }
        r
    }
}
