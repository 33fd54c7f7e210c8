//! The simulation's parameters: numerics, detection settings, and everything a run is made
//! of besides the colon.

use crate::operator::Script;
use crate::rod::RodParams;
use crate::wall::WallParams;

/// Numerical and scene parameters of the simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimParams {
    /// Frame length, s (default 0.001).
    pub dt_s: f64,
    /// XPBD substeps per frame (default 16).
    pub substeps: u32,
    /// Gravity, mm/s^2 (default 9810 towards -y: the patient supine, `y` anterior).
    pub gravity_mm_s2: [f64; 3],
    /// Samples per rod segment for detection (default 4).
    pub precision: u32,
    /// Contacts are reported while the surfaces are closer than this, mm (default 2): the
    /// frame's constraints then include surfaces about to touch.
    pub margin_mm: f32,
    /// Whether the scope's contacts with itself are detected and answered (default true).
    pub self_contact: bool,
    /// Stiffness of the operator's hand, N/m (default 5000).
    pub hand_stiffness_n_per_m: f64,
    /// Stiffness holding the tip in the hard push, N/m (default 100000: a tip caught at the
    /// bend gives 0.4 mm under the full 40 N).
    pub hold_stiffness_n_per_m: f64,
    /// Control points of the distal bending section (default 10: about 10 cm).
    pub bending_section_points: usize,
    /// Contact projections per substep (default 2).
    pub contact_passes: u32,
    /// Stretch projections per substep, alternating sweep directions (default 2: a second
    /// sweep from the other end carries the hand's push along the whole scope).
    pub stretch_passes: u32,
    /// Axial re-projections of every section reading (the spec's `refine`; default 0), in
    /// process or through the daemon alike. 1 sees folds and bulge flanks ahead of a sample
    /// sooner, for more detection time.
    pub refine: u32,
    /// Contacts at the nearest point of the continuous wall (the spec's `nearest`; default
    /// true): a section's own reading measures a sample against its tangent plane, which on a
    /// steep fold passes millimetres from any wall point and lets the scope through
    /// (measurements: `docs/decisions/sim.md`).
    pub nearest: bool,
    /// The faces beside a contact of the scope's end segments at a concave crease of the wall
    /// join the frame's constraints (default true; see [`crate::crease`]): without them the
    /// end slides along one face of a fold into the next within a frame.
    pub crease_faces: bool,
    /// Speed limit of scope points and wall nodes, mm/s (default 1000; 0: none). A
    /// colonoscope's motions stay far below it; it keeps a frame's motion within about the
    /// detection margin, so conflicting contacts (where the tube model is ambiguous) cannot
    /// pump energy into the scope, and a wall no contact reported at the frame's start cannot
    /// be reached within the frame. It bounds a scope point's displacement in each substep too
    /// (`max * dt / substeps`): a point the constraints throw further is moved back along its
    /// path; and a wall node's inward move (a bulge springing back), not its giving way.
    /// Points and nodes it slows are counted in
    /// [`crate::FrameReport::speed_limited`].
    pub max_speed_mm_s: f64,
    /// Time over which the scope's initial shape is released, s (default 0.15): its rest
    /// curvature starts as the shape it was laid in (no elastic force) and falls linearly to
    /// straight, so the scope loads the wall gradually instead of springing at it.
    pub relax_s: f64,
}

impl Default for SimParams {
    fn default() -> Self {
        Self {
            dt_s: 1e-3,
            substeps: 16,
            gravity_mm_s2: [0.0, -9810.0, 0.0],
            precision: 4,
            margin_mm: 2.0,
            self_contact: true,
            hand_stiffness_n_per_m: 5000.0,
            hold_stiffness_n_per_m: 100_000.0,
            bending_section_points: 10,
            contact_passes: 2,
            stretch_passes: 2,
            refine: 0,
            nearest: true,
            crease_faces: true,
            relax_s: 0.15,
            max_speed_mm_s: 1000.0,
        }
    }
}

/// Everything a simulation is made of, besides the colon.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    pub rod: RodParams,
    pub wall: WallParams,
    pub sim: SimParams,
    pub script: Script,
    /// Depth of the scope's tip along the midline at the start, mm (default:
    /// [`crate::setup::start_depth_mm`], 20 mm before the sigmoid's sharpest bend).
    pub start_depth_mm: Option<f64>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self { rod: RodParams::default(), wall: WallParams::default(), sim: SimParams::default(), script: Script::colonoscopy(), start_depth_mm: None }
    }
}
