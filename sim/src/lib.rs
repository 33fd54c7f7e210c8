//! Lumen's colonoscopy physics: an endoscope pushed through a colon by a scripted operator,
//! kept inside by Lumen's contacts.
//!
//! The scope is an XPBD rod (stretch and bend constraints, a torsionally rigid shaft whose
//! handle roll turns the angulated tip); the colon is the rest wall of a Lumen tube whose spoke
//! tips move outward where they are touched and spring back (driven by a coarse grid of wall
//! nodes, only the touched ones simulated); every frame the contacts of the frame's starting
//! state become contact constraints on both, with the detector's normals and tip weights. The question it answers: does the scope stay inside the colon, however hard it
//! is pushed? ([`FrameReport::escaped`], [`FrameReport::max_penetration_mm`]).
//!
//! **Units.** Millimetres, seconds, kilograms throughout (forces in mN = kg mm/s^2 inside the
//! solver, N in parameters and reports; stiffnesses in N/m = mN/mm).
//!
//! **Determinism.** No randomness and no hash-ordered iteration: equal colons, configurations
//! and contact sources give bit-identical runs. The generated colon takes a seed.
//!
//! ## Modules
//! - [`rod`]: the scope (XPBD rod, the bend and stretch math, angulation).
//! - [`wall`]: the colon wall (spoke tips moved along their spokes by nodes on springs with a
//!   membrane and a range; only the touched nodes are simulated).
//! - [`operator`]: the scripted hands (insert, pull back, angulate, twist, the hard push).
//! - [`contact`]: Lumen contacts as XPBD contact constraints (mass-weighted, with the
//!   contact's normal; corners held by carrying a sample's previous contact; inelastic).
//! - [`crease`]: the faces beside a contact of the scope's end segments at a concave crease of the
//!   wall, added as contacts of their own (the detector reports nearest points only).
//! - [`world`]: one frame (operator, constraints, substeps, state, detection, figures) and the
//!   [`ContactSource`] seam where the daemon plugs in.
//! - [`config`]: [`SimParams`] and [`SimConfig`], what a run is made of besides the colon.
//! - [`setup`]: the colons, the scope's starting pose, the scene spec.
//! - [`daemon`]: contacts from the Lumen daemon ([`daemon::DaemonSource`], what `lumen sim`
//!   runs on).
//!
//! **Time and rate.** A frame is 1 ms of simulated time (the 1 kHz of a haptic loop) in 16
//! XPBD substeps; the default script ([`Script::colonoscopy`]) is 3 s, 3,000 frames (what a
//! frame costs: `docs/measurements.md`). `lumen sim` runs it as its own process against the daemon
//! ([`daemon::DaemonSource`]) and `lumen demo` runs daemon, physics and recorder together.
//!
//! ```no_run
//! use lumen_sim::{setup, SimConfig, World};
//! let colon = setup::generated_colon(1, 1500.0);
//! let mut world = World::in_process(&colon, SimConfig::default()).unwrap();
//! for _ in 0..3000 {
//!     let r = world.step().unwrap();
//!     assert_eq!(r.escaped, 0);
//! }
//! ```

pub mod config;
pub mod contact;
pub mod crease;
pub mod daemon;
pub mod operator;
pub mod rod;
pub mod setup;
pub mod wall;
pub mod world;

pub use config::{SimConfig, SimParams};
pub use lumen_detect::V3d;
pub use lumen_proto::Contact;
pub use operator::{Action, Operator, Phase, Script};
pub use rod::{Rod, RodParams};
pub use wall::{Wall, WallParams};
pub use world::{ContactSource, FnSource, FrameReport, InProcess, SimError, SourceError, World};

/// A point or vector of the detector's wire (`f32`) in the simulation's `f64`.
pub(crate) fn v3(a: [f32; 3]) -> V3d {
    V3d::new(a[0] as f64, a[1] as f64, a[2] as f64)
}
