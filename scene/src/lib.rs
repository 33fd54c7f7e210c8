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
//! - [`frames`]: a colonoscopy as a spec and flat frame states (the IPC benchmark, the
//!   daemon's tests).
//! - [`gca`]: the real colon, found beside the workspace and imported through `lumen-import`
//!   (which also holds the midline geometry and the tube probes these scenes use).
//!
//! ## Data attribution
//! The real colon is the Edinburgh Gut Cell Atlas model EdinGCA_3D_00090 (surface and midline
//! derived from Comparative-Pathology/GCA-Models), licensed CC BY 4.0. Wherever it or results
//! derived from it are shown, credit: "Edinburgh Gut Cell Atlas models
//! (Comparative-Pathology/GCA-Models), CC BY 4.0, doi:10.1186/s12911-023-02111-9"
//! ([`gca::attribution`]).

pub mod colon;
pub mod endoscope;
pub mod frames;
pub mod gca;
pub mod insufflated;
pub mod nets;
mod rng;

pub use colon::{generate, ColonParams};
pub use endoscope::{colonoscopy_scene, Frame, Insertion};

/// The colons the scenes offer: the generated one (the default everywhere), its hard variants,
/// and the real GCA colon ([`gca`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ColonKind {
    /// [`colon::generate`]: seeded, 1.5 m, rings every 1.2 mm by default.
    #[default]
    Generated,
    /// The generated colon narrowed below a colonoscope's diameter ([`NARROW`]): in the anal
    /// canal and in the sigmoid, where the scope must push the wall open.
    Narrow,
    /// The generated colon with a collapsed segment in the sigmoid ([`COLLAPSED`]).
    Collapsed,
    /// The generated colon with two bends tighter than the lumen ([`TIGHT_BENDS`]): at the
    /// rectosigmoid junction and at the top of the sigmoid, both in the scripted scope's way;
    /// their ring planes cross inside the lumen.
    #[serde(rename = "tight-bend")]
    TightBend,
    /// The generated colon with a sigmoid that loops once around and passes beside itself
    /// ([`SIGMOID_LOOP`]), the scripted scope lying through the whole loop.
    Loop,
    /// The Edinburgh Gut Cell Atlas colon EdinGCA_3D_00090 ([`gca::load`]).
    Gca,
    /// A generated insufflated colon given as a surface and a midline, of the seed
    /// ([`insufflated::generate`]): lumens of 25 to 50 mm, bends a third to a half of that, a
    /// 3.25 mm anal canal; imported through the gate at 48 spokes ([`insufflated::load`]).
    Insufflated,
}

/// The narrowings of [`ColonKind::Narrow`]: the anal canal (4.5 mm radius over 30 mm, 30 mm in)
/// and a spastic segment of the sigmoid (5 mm over 40 mm, 200 mm in), both where the scripted
/// colonoscopy's scope passes; a 13 mm scope has radius 6.5.
pub const NARROW: [colon::Narrowing; 2] = [colon::Narrowing { at_mm: 30.0, radius_mm: 4.5, length_mm: 30.0 }, colon::Narrowing { at_mm: 200.0, radius_mm: 5.0, length_mm: 40.0 }];

/// The collapse of [`ColonKind::Collapsed`]: 3 mm radius over 60 mm, 150 mm in (the scope lies
/// through it all the colonoscopy long).
pub const COLLAPSED: [colon::Narrowing; 1] = [colon::Narrowing { at_mm: 150.0, radius_mm: 3.0, length_mm: 60.0 }];

/// The bends of [`ColonKind::TightBend`]: the midline's turning from 100 to 240 mm from the
/// anus (the rectosigmoid junction, about 60 degrees) and from 250 to 350 mm (the top of the
/// sigmoid, about 100 degrees) gathered into arcs of 0.6 times the largest lumen radius there
/// (about 18 and 16 mm, against 30 and 27), both between the anus and where the scripted
/// colonoscopy's tip starts (about 370 mm in).
pub const TIGHT_BENDS: [colon::TightBend; 2] = [colon::TightBend { at_mm: 170.0, half_window_mm: 70.0, ratio: 0.6 }, colon::TightBend { at_mm: 300.0, half_window_mm: 50.0, ratio: 0.6 }];

/// The loop of [`ColonKind::Loop`]: radius 50 mm (1.85 times the sigmoid's largest lumen
/// radius, 27 mm), the second pass 80 mm to the left of the first (midline to midline: about
/// 10 mm between the walls where they come nearest), and an exit bend of 44 mm, the sigmoid's
/// sharpest, where the scripted colonoscopy pushes: the scope lies through the whole loop.
pub const SIGMOID_LOOP: colon::SigmoidLoop = colon::SigmoidLoop { radius_mm: [50.0, 44.0], pitch_mm: 80.0 };

impl ColonKind {
    /// Every kind, in the order reports list them.
    pub const ALL: [ColonKind; 7] = [ColonKind::Generated, ColonKind::Narrow, ColonKind::Collapsed, ColonKind::TightBend, ColonKind::Loop, ColonKind::Gca, ColonKind::Insufflated];

    /// `generated`, `narrow`, `collapsed`, `tight-bend`, `loop`, `gca` or `insufflated`.
    pub fn name(self) -> &'static str {
        match self {
            ColonKind::Generated => "generated",
            ColonKind::Narrow => "narrow",
            ColonKind::Collapsed => "collapsed",
            ColonKind::TightBend => "tight-bend",
            ColonKind::Loop => "loop",
            ColonKind::Gca => "gca",
            ColonKind::Insufflated => "insufflated",
        }
    }

    /// The tube generator's parameters of a generated kind with `seed` (`None` for the colons
    /// that come through the import: the GCA colon and the insufflated one).
    pub fn generated(self, seed: u64) -> Option<ColonParams> {
        let base = ColonParams::seeded(seed);
        Some(match self {
            ColonKind::Generated => base,
            ColonKind::Narrow => ColonParams { narrowings: NARROW.to_vec(), ..base },
            ColonKind::Collapsed => ColonParams { narrowings: COLLAPSED.to_vec(), ..base },
            ColonKind::TightBend => ColonParams { tight_bends: TIGHT_BENDS.to_vec(), ..base },
            ColonKind::Loop => ColonParams { sigmoid_loop: Some(SIGMOID_LOOP), ..base },
            ColonKind::Gca | ColonKind::Insufflated => return None,
        })
    }
}

impl std::fmt::Display for ColonKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A colon name that is none of [`ColonKind::ALL`]'s.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown colon {0:?}: use generated, narrow, collapsed, tight-bend, loop, gca or insufflated")]
pub struct UnknownColon(pub String);

impl std::str::FromStr for ColonKind {
    type Err = UnknownColon;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ColonKind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| UnknownColon(s.to_owned()))
    }
}
