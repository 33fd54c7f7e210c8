//! The scene spec: what a client declares once, before sending frames.
//!
//! Written as JSON by people and other languages:
//!
//! ```json
//! { "bodies": [
//!     { "name": "colon", "shape": { "tube": { "rings": 1250, "spokes": 32 } } },
//!     { "name": "scope", "shape": { "rod": { "points": 160, "radius": [6.5] } } } ],
//!   "pairs": [ { "a": "scope", "b": "colon", "kind": "interior" } ],
//!   "precision": 4 }
//! ```
//!
//! Units are the client's own (millimetres or metres); nothing here assumes one.

use crate::contact::ContactKind;
use crate::error::SpecError;
use crate::limits::*;
use serde::{Deserialize, Serialize};

/// Everything the pipeline needs to know that does not change per frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Bodies, in the order their floats appear in each frame's state.
    pub bodies: Vec<BodySpec>,
    /// The pairs to compute, and only these.
    pub pairs: Vec<PairSpec>,
    /// Samples per segment, `x` (>= 1). Higher is more accurate and slower.
    #[serde(default = "default_precision")]
    pub precision: u32,
    /// Catmull-Rom parameter: 0 uniform, 0.5 centripetal, 1 chordal.
    #[serde(default = "default_alpha")]
    pub alpha: f32,
    /// Contacts are reported while the penetration depth exceeds `-margin` (user units, >= 0):
    /// a positive margin reports surfaces about to touch.
    #[serde(default)]
    pub margin: f32,
    /// Which detection method runs.
    #[serde(default)]
    pub method: Method,
    /// `signed` only: each contact at the nearest point of the continuous wall (the distance
    /// to the wall itself, and the direction to it as normal, continuous as the sample moves).
    /// On by default, since a real colon's folds put the wall's nearest point in another
    /// cross-section than the sample's (docs/decisions/detect.md). `false` declares the
    /// `sections` reading: each contact in its sample's own cross-section, at the distance to
    /// the wall's tangent plane there; cheaper, and exact only where the wall is smooth and
    /// gently sloped along the tube.
    #[serde(default = "default_nearest")]
    pub nearest: bool,
    /// `signed` only: axial re-projections of every sample's section reading (0 to 4, default
    /// 0). Each moves the section to the foot of the last reading and reads the sample again
    /// there, which removes most of the error of a wall sloped along the tube (depth in the
    /// scene's unit, normal in degrees; figures in docs/decisions/detect.md), at the cost of
    /// reading every sample in full, where without it a sample clear of the wall stops at its
    /// sector.
    #[serde(default)]
    pub refine: u32,
}

fn default_precision() -> u32 {
    4
}
fn default_alpha() -> f32 {
    0.5
}
fn default_nearest() -> bool {
    true
}

/// One body of the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name, used by pairs and in error messages.
    pub name: String,
    pub shape: Shape,
}

/// The kind of body and its fixed counts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// A tube: `rings` control points along its midline, each with `spokes` radial vectors to
    /// its wall, ordered around the midline (either sense).
    Tube { rings: usize, spokes: usize },
    /// A rod: `points` control points and a radius, one for all (`[r]`) or one per point.
    Rod { points: usize, radius: Vec<f32> },
}

/// A pair of bodies and the kind of contact computed between them. Body `a` is always a rod.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    pub a: String,
    pub b: String,
    pub kind: ContactKind,
}

/// The detection method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Signed containment in tube coordinates with temporal coherence: contacts however deep,
    /// normals that never flip, cost that follows the rod, not the tube.
    #[default]
    #[serde(alias = "default")]
    Signed,
    /// The published method, faithfully: BVH rebuilt every frame, nearest-sample proximity
    /// list, unsigned sector test. The baseline the speed claims are measured against; it
    /// misses rod samples that have left the tube.
    Thesis,
}

impl BodySpec {
    /// Control points (rings) of this body.
    pub fn points(&self) -> usize {
        match self.shape {
            Shape::Tube { rings, .. } => rings,
            Shape::Rod { points, .. } => points,
        }
    }

    /// Radial vectors per ring, or `None` for a rod.
    pub fn spokes(&self) -> Option<usize> {
        match self.shape {
            Shape::Tube { spokes, .. } => Some(spokes),
            Shape::Rod { .. } => None,
        }
    }

    /// Radius at control point `i` of a rod (0 for a tube).
    pub fn radius(&self, i: usize) -> f32 {
        match &self.shape {
            Shape::Rod { radius, .. } if radius.len() == 1 => radius[0],
            Shape::Rod { radius, .. } => radius[i],
            Shape::Tube { .. } => 0.0,
        }
    }

    /// Number of `f32` values this body occupies in the state.
    pub fn floats(&self) -> usize {
        match self.shape {
            Shape::Tube { rings, spokes } => rings * (spokes + 1) * 3,
            Shape::Rod { points, .. } => points * 3,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), SpecError> {
        let n = self.points();
        if !(MIN_POINTS..=MAX_POINTS).contains(&n) {
            return Err(SpecError::PointCount { body: self.name.clone(), count: n, min: MIN_POINTS, max: MAX_POINTS });
        }
        match &self.shape {
            Shape::Tube { spokes, .. } => {
                if !(MIN_SPOKES..=MAX_SPOKES).contains(spokes) {
                    return Err(SpecError::SpokeCount { body: self.name.clone(), count: *spokes, min: MIN_SPOKES, max: MAX_SPOKES });
                }
            }
            Shape::Rod { radius, points } => {
                if radius.len() != 1 && radius.len() != *points {
                    return Err(SpecError::RadiusCount { body: self.name.clone(), got: radius.len(), points: *points });
                }
                if let Some((index, &value)) = radius.iter().enumerate().find(|(_, r)| !(r.is_finite() && **r > 0.0 && **r <= MAX_COORDINATE)) {
                    return Err(SpecError::BadRadius { body: self.name.clone(), index, value });
                }
            }
        }
        Ok(())
    }
}

impl SceneSpec {
    /// A scene of these bodies and pairs with default precision, alpha, margin and method.
    pub fn new(bodies: Vec<BodySpec>, pairs: Vec<PairSpec>) -> Self {
        Self { bodies, pairs, precision: default_precision(), alpha: default_alpha(), margin: 0.0, method: Method::default(), nearest: default_nearest(), refine: 0 }
    }

    /// Index of the body called `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::valid::PairIndex;

    fn spec() -> SceneSpec {
        SceneSpec::new(
            vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings: 10, spokes: 8 } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points: 5, radius: vec![1.0] } }],
            vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
        )
    }

    #[test]
    fn json_round_trip_and_defaults() {
        let json = r#"{"bodies":[{"name":"colon","shape":{"tube":{"rings":10,"spokes":8}}},
            {"name":"scope","shape":{"rod":{"points":5,"radius":[1.0]}}}],
            "pairs":[{"a":"scope","b":"colon","kind":"interior"}]}"#;
        let parsed: SceneSpec = serde_json::from_str(json).unwrap();
        assert_eq!(parsed, spec());
        assert_eq!(parsed.validate().unwrap().pairs(), [PairIndex { a: 1, b: 0, kind: ContactKind::Interior }]);
        assert_eq!(parsed.bodies[0].floats(), 10 * 9 * 3);
        assert!(parsed.nearest, "contacts at the nearest wall point unless the sections are declared");
        let on: SceneSpec = serde_json::from_str(&json.replace(r#""pairs""#, r#""nearest":false,"pairs""#)).unwrap();
        assert!(!on.nearest, "the sections reading, declared");
        assert_eq!(parsed.refine, 0, "one reading per sample unless declared");
        let refined: SceneSpec = serde_json::from_str(&json.replace(r#""pairs""#, r#""refine":2,"pairs""#)).unwrap();
        assert_eq!((refined.refine, refined.validate().is_ok()), (2, true));
        assert_eq!(serde_json::from_str::<SceneSpec>(&serde_json::to_string(&on).unwrap()).unwrap(), on);
    }

    #[test]
    fn errors_name_what_is_wrong() {
        let mut s = spec();
        s.bodies[0].shape = Shape::Tube { rings: 1, spokes: 8 };
        assert!(s.validate().unwrap_err().to_string().contains("\"colon\": 1 control points"));
        let mut s = spec();
        s.bodies[0].shape = Shape::Tube { rings: 10, spokes: 257 };
        assert!(matches!(s.validate(), Err(SpecError::SpokeCount { count: 257, .. })));
        let mut s = spec();
        s.bodies[1].shape = Shape::Rod { points: 5, radius: vec![1.0, f32::NAN, 1.0, 1.0, 1.0] };
        assert!(matches!(s.validate(), Err(SpecError::BadRadius { index: 1, .. })));
        let mut s = spec();
        s.pairs[0].a = "colon".into();
        assert!(s.validate().unwrap_err().to_string().contains("body a must be a rod"));
        let mut s = spec();
        s.pairs[0].b = "stomach".into();
        assert_eq!(s.validate(), Err(SpecError::UnknownBody { pair: 0, name: "stomach".into() }));
        let mut s = spec();
        s.precision = 0;
        assert_eq!(s.validate(), Err(SpecError::Precision(0)));
        let mut s = spec();
        s.refine = 5;
        assert!(s.validate().unwrap_err().to_string().contains("refine = 5; between 0 and 4"));
    }
}
