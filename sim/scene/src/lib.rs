//! Scenes for Lumen's collision detection: a seeded generated colon, a kinematic endoscope
//! inserted into it frame by frame, and real colons imported from a triangle surface and a
//! midline.
//!
//! **Units.** Millimetres throughout for the scenes built here (the generated colon, the scope,
//! the GCA colon); an imported surface keeps its own unit (the GCA files are in millimetres).
//! Tubes and rods are `lumen_detect`'s [`Tube`](lumen_detect::Tube) and
//! [`Rod`](lumen_detect::Rod): control points along the midline and, for a tube, `spokes` radial
//! vectors per ring, counter-clockwise about the midline's direction.
//!
//! **Determinism.** Everything random takes a seed (a SplitMix64 stream of this crate, stable
//! across platforms and dependency versions): equal inputs give bit-identical outputs.
//!
//! ## Modules
//! - [`colon`]: [`colon::generate`], a plausible 1.5 m colon (rectum, sigmoid loop, descending
//!   colon, splenic flexure, sagging transverse colon, hepatic flexure, ascending colon, caecum),
//!   radius 20-35 mm with haustral folds, checked free of wall overlap and of bends tighter than
//!   the lumen; any length and ring spacing.
//! - [`endoscope`]: [`endoscope::Insertion`], a 1.6 m, 13 mm scope pushed through the rectum,
//!   riding the outer wall of bends and deforming it, advancing about 1 mm per frame, with seeded
//!   escapes through the wall; [`endoscope::colonoscopy_scene`] for benchmarks.
//! - [`import`]: OBJ / STL surfaces and CSV midlines to a tube by ray casting (parry3d), with
//!   every repaired ray counted in an [`import::ImportReport`]; [`import::gca_paths`] finds the
//!   real colon.
//! - [`probe`]: tube coordinates for checks (where a point is along a tube, its distance to the
//!   midline and to the wall), and [`probe::clearance`] (wall overlap, bend tightness).
//! - [`geom`]: arc length, smoothing along the arc, rotation-minimising frames.
//!
//! ## Data attribution
//! The real colon is the Edinburgh Gut Cell Atlas model EdinGCA_3D_00090 (surface and midline
//! derived from Comparative-Pathology/GCA-Models), licensed CC BY 4.0. Wherever it or results
//! derived from it are shown, credit: "Edinburgh Gut Cell Atlas models
//! (Comparative-Pathology/GCA-Models), CC BY 4.0, doi:10.1186/s12911-023-02111-9"
//! ([`gca_attribution`]).

pub mod colon;
pub mod endoscope;
pub mod geom;
pub mod import;
pub mod probe;
mod rng;

pub use colon::{generate, ColonParams};
pub use endoscope::{colonoscopy_scene, Frame, Insertion};
pub use import::{build_tube, gca_attribution, gca_paths, ImportParams, ImportReport};
