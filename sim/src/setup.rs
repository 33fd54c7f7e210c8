//! Scenes for the simulation: the colons, the scope's starting pose, the scene spec.
//!
//! **Units**: millimetres.
//!
//! - [`generated_colon`]: `lumen_scene`'s seeded colon (default 1.5 m, 1.2 mm rings, 32 spokes).
//! - [`gca_colon`]: the real colon (Edinburgh Gut Cell Atlas EdinGCA_3D_00090, CC BY 4.0,
//!   doi:10.1186/s12911-023-02111-9, see [`lumen_scene::gca::attribution`]) imported with 32
//!   spokes every 1 mm and inflated twice (the scan is not insufflated).
//! - [`insertion_pose`]: the scope laid through the lumen with its tip at a given depth, the way
//!   [`lumen_scene::endoscope::Insertion`] lays it (riding the outer wall of bends), but not
//!   pressing into the wall, the rest straight out of the anus.
//! - [`sigmoid_bend_mm`]: where the hard push happens: the sharpest bend of the midline in the
//!   sigmoid's stretch of the colon; [`start_depth_mm`], the tip's start 20 mm before it.

use crate::config::SimParams;
use crate::rod::RodParams;
use lumen_detect::model::{is_text_path, parse_model, ModelError};
use lumen_detect::Body;
use lumen_detect::Tube;
use lumen_detect::V3d;
use lumen_import::probe::Lumen;
use lumen_proto::{BodySpec, ContactKind, PairSpec, SceneSpec, Shape};
use lumen_scene::colon::{generate, ColonParams};
use lumen_scene::endoscope::Insertion;
use lumen_scene::gca::{self, GcaError};
use lumen_scene::ColonKind;
use std::path::Path;

/// Name of the colon body in the scene spec (body 0).
pub const COLON: &str = "colon";
/// Name of the scope body in the scene spec (body 1).
pub const SCOPE: &str = "scope";

/// The generated colon of `seed`, `length_mm` long (1500 for the adult colon).
pub fn generated_colon(seed: u64, length_mm: f32) -> Tube {
    generate(&ColonParams { length_mm, ..ColonParams::seeded(seed) })
}

/// The GCA colon from `dir` (default: `../shared/data/colon-gca00090` beside the workspace),
/// 32 spokes every 1 mm, inflated twice; the error says what is missing.
pub fn gca_colon(dir: Option<&Path>) -> Result<Tube, GcaError> {
    gca::load(dir, GCA_INFLATE)
}

/// The GCA colon's default inflation (the scan is not insufflated): `ImportParams::gca`'s.
pub use lumen_import::GCA_INFLATE;

/// The scope's control points (tip first) with its tip `tip_depth_mm` along the colon's
/// midline: through the lumen, on the outer side of bends but not into the wall, and straight
/// back out of the first ring for the part that is not inside.
pub fn insertion_pose(tube: &Tube, rod: &RodParams, tip_depth_mm: f64) -> Vec<V3d> {
    let ins = Insertion { length_mm: rod.length_mm as f32, radius_mm: rod.radius_mm as f32, points: rod.points, press_mm: 0.0, residual_mm: 0.0, escapes: false };
    let f = ins.frame(tube, tip_depth_mm as f32);
    f.scope.points.iter().copied().map(crate::v3).collect()
}

/// The insertion axis: the first ring's control point and the unit direction into the colon.
pub fn insertion_axis(tube: &Tube) -> (V3d, V3d) {
    let lumen = Lumen::new(tube);
    let p = tube.points[0];
    (crate::v3(p), lumen.normal(0))
}

/// Depth of the scope's tip along the midline at the start when none is given, mm: 20 mm before
/// the sigmoid's sharpest bend ([`sigmoid_bend_mm`]), so the insertion brings it there.
pub fn start_depth_mm(tube: &Tube) -> f64 {
    (sigmoid_bend_mm(tube) - 20.0).max(0.0)
}

/// Arc length of the midline (mm) at its sharpest bend between 12% and 35% of its length
/// (the sigmoid of an adult colon: about 180 to 525 mm of 1.5 m), curvature measured over a
/// 20 mm chord either side, among the places where the tube model is valid for 30 mm around:
/// the midline's bend radius at least its ring's longest spoke ([`valid_bends`]), so ring
/// planes do not cross inside the lumen. (The generated colon is valid everywhere; the GCA
/// colon inflated twice is not: see [`valid_bends`].) Falls back to the sharpest bend if no
/// place qualifies.
pub fn sigmoid_bend_mm(tube: &Tube) -> f64 {
    let p: Vec<V3d> = tube.points.iter().copied().map(crate::v3).collect();
    let mut arc = vec![0.0; p.len()];
    for i in 1..p.len() {
        arc[i] = arc[i - 1] + (p[i] - p[i - 1]).norm();
    }
    let valid = valid_bends(tube);
    let total = arc[arc.len() - 1];
    let (lo, hi) = (0.12 * total, 0.35 * total);
    let h = 20.0;
    let mut best = (f64::NEG_INFINITY, 0.5 * (lo + hi));
    let mut best_any = best;
    for i in 0..p.len() {
        if arc[i] < lo || arc[i] > hi {
            continue;
        }
        let a = arc.partition_point(|&s| s < arc[i] - h);
        let b = arc.partition_point(|&s| s <= arc[i] + h).min(p.len() - 1);
        if a >= i || b <= i {
            continue;
        }
        let (u, v) = ((p[i] - p[a]).normalize(), (p[b] - p[i]).normalize());
        let turn = u.dot(&v).clamp(-1.0, 1.0).acos();
        if turn > best_any.0 {
            best_any = (turn, arc[i]);
        }
        let (wa, wb) = (arc.partition_point(|&s| s < arc[i] - 30.0), arc.partition_point(|&s| s <= arc[i] + 30.0));
        if turn > best.0 && valid[wa..wb].iter().all(|&ok| ok) {
            best = (turn, arc[i]);
        }
    }
    if best.0 > f64::NEG_INFINITY {
        best.1
    } else {
        best_any.1
    }
}

/// For each ring, whether the midline's bend radius there (the circumradius of the midline
/// points one longest-spoke length before and after it, as [`lumen_import::probe::clearance`]
/// measures) is at least the ring's longest spoke: where it is not, the ring planes of the
/// bend cross inside the lumen and tube coordinates are ambiguous.
pub fn valid_bends(tube: &Tube) -> Vec<bool> {
    let lm = Lumen::new(tube);
    let n = lm.rings();
    let arc = lm.arc().to_vec();
    let pts: Vec<V3d> = (0..n).map(|i| lm.point(i)).collect();
    (0..n)
        .map(|i| {
            let r = lm.max_radius(i);
            let (a, b) = (arc[i] - r, arc[i] + r);
            if a < 0.0 || b > arc[n - 1] {
                return true;
            }
            let pa = lumen_import::geom::at_arc(&pts, &arc, a);
            let pb = lumen_import::geom::at_arc(&pts, &arc, b);
            let pc = pts[i];
            let (x, y, z) = ((pa - pc).norm(), (pb - pc).norm(), (pa - pb).norm());
            let area2 = (pa - pc).cross(&(pb - pc)).norm();
            area2 <= 1e-12 || x * y * z / (2.0 * area2) >= r
        })
        .collect()
}

/// The scene spec: the colon (body 0) and the scope (body 1, its points listed from the handle
/// to the tip), the interior pair, and the scope against itself if [`SimParams::self_contact`].
pub fn scene_spec(tube: &Tube, rod: &RodParams, sim: &SimParams) -> SceneSpec {
    let mut pairs = vec![PairSpec { a: SCOPE.into(), b: COLON.into(), kind: ContactKind::Interior }];
    if sim.self_contact {
        pairs.push(PairSpec { a: SCOPE.into(), b: SCOPE.into(), kind: ContactKind::SelfContact });
    }
    let mut spec = SceneSpec::new(
        vec![
            BodySpec { name: COLON.into(), shape: Shape::Tube { rings: tube.rings(), spokes: tube.spokes } },
            BodySpec { name: SCOPE.into(), shape: Shape::Rod { points: rod.points, radius: vec![rod.radius_mm as f32] } },
        ],
        pairs,
    );
    spec.precision = sim.precision;
    spec.margin = sim.margin_mm;
    spec.nearest = sim.nearest;
    spec.refine = sim.refine;
    spec
}

/// Why a model file gave no colon.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    /// The file could not be read.
    #[error(transparent)]
    Read(std::io::Error),
    /// It is no model (the parser's reason).
    #[error(transparent)]
    Parse(ModelError),
    /// It holds a rod.
    #[error("holds a rod, not a colon (a tube)")]
    NotATube,
    /// The colon fails the import's gate (it folds).
    #[error(transparent)]
    Refused(lumen_import::ImportError),
}

/// The colon in a model file written by `lumen import` (native, or the text format when its
/// name ends in `.txt`), behind the import's checks on a tube ([`lumen_import::check`]): a
/// model that folds is refused, as `lumen import` would refuse it.
pub fn model_colon(path: &Path) -> Result<Tube, ModelFileError> {
    let bytes = std::fs::read(path).map_err(ModelFileError::Read)?;
    match parse_model(&bytes, is_text_path(path)).map_err(ModelFileError::Parse)? {
        (Body::Tube(t), _) => {
            lumen_import::check(&t).map_err(ModelFileError::Refused)?;
            Ok(t)
        }
        (Body::Rod(_), _) => Err(ModelFileError::NotATube),
    }
}

/// The colon of `kind`: the generated one of `seed` (1.5 m) or one of its hard variants, the
/// insufflated one of `seed` (imported), or the GCA colon from `data` (its files' folder, or
/// the default place); the error says what is missing or why the import refused it.
pub fn colon(kind: ColonKind, seed: u64, data: Option<&Path>) -> Result<Tube, GcaError> {
    colon_inflated(kind, seed, data, GCA_INFLATE)
}

/// [`colon`], with the GCA colon inflated `inflate` times (1: as scanned, collapsed, narrower
/// than a scope in places; 4: a lumen far wider than its flexures' bend radius); the generated
/// ones ignore it.
pub fn colon_inflated(kind: ColonKind, seed: u64, data: Option<&Path>, inflate: f32) -> Result<Tube, GcaError> {
    match kind.generated(seed) {
        Some(p) => Ok(generate(&ColonParams { length_mm: 1500.0, ..p })),
        None if kind == ColonKind::Insufflated => Ok(lumen_scene::insufflated::load(seed)?.0),
        None => gca::load(data, inflate),
    }
}
