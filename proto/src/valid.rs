//! A scene spec that passed validation, with what validation resolved kept: the pairs as body
//! indices and the state layout. Built only by [`SceneSpec::validate`] or
//! [`ValidScene::try_from`], so whoever holds one needs neither to check nor to derive again.

use crate::contact::ContactKind;
use crate::error::{InputError, SpecError};
use crate::limits::*;
use crate::scene::{BodySpec, Method, SceneSpec, Shape};
use crate::state::StateLayout;

impl SceneSpec {
    /// Checks every count, limit and pair; returns the scene with its pairs resolved to body
    /// indices and its state layout, computed once.
    pub fn validate(&self) -> Result<ValidScene, SpecError> {
        let pairs = self.resolve()?;
        Ok(ValidScene::new(self.clone(), pairs))
    }

    /// Checks every count, limit and pair; returns the pairs resolved to body indices.
    pub(crate) fn resolve(&self) -> Result<Vec<PairIndex>, SpecError> {
        if self.bodies.is_empty() {
            return Err(SpecError::NoBodies);
        }
        if self.bodies.len() > MAX_BODIES {
            return Err(SpecError::TooManyBodies { got: self.bodies.len(), max: MAX_BODIES });
        }
        if self.pairs.len() > MAX_PAIRS {
            return Err(SpecError::TooManyPairs { got: self.pairs.len(), max: MAX_PAIRS });
        }
        if !(1..=MAX_PRECISION).contains(&self.precision) {
            return Err(SpecError::Precision(self.precision));
        }
        if self.refine > MAX_REFINE {
            return Err(SpecError::Refine(self.refine));
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(SpecError::Alpha(self.alpha));
        }
        if !(self.margin.is_finite() && (0.0..=MAX_COORDINATE).contains(&self.margin)) {
            return Err(SpecError::Margin(self.margin));
        }
        for (i, b) in self.bodies.iter().enumerate() {
            if b.name.len() > MAX_NAME_BYTES {
                return Err(SpecError::NameTooLong { index: i, got: b.name.len(), start: b.name.chars().take(24).collect(), max: MAX_NAME_BYTES });
            }
            b.validate()?;
            if self.bodies[..i].iter().any(|o| o.name == b.name) {
                return Err(SpecError::DuplicateName(b.name.clone()));
            }
        }
        let floats: usize = self.bodies.iter().map(BodySpec::floats).sum();
        if floats > MAX_STATE_FLOATS {
            return Err(SpecError::StateTooLarge { got: floats, max: MAX_STATE_FLOATS });
        }
        let mut resolved = Vec::with_capacity(self.pairs.len());
        for (p, pair) in self.pairs.iter().enumerate() {
            let find = |name: &str| self.body_index(name).ok_or_else(|| SpecError::UnknownBody { pair: p, name: name.to_owned() });
            let (a, b) = (find(&pair.a)?, find(&pair.b)?);
            let bad = |reason| Err(SpecError::BadPair { pair: p, a: pair.a.clone(), b: pair.b.clone(), reason });
            let a_rod = matches!(self.bodies[a].shape, Shape::Rod { .. });
            let b_rod = matches!(self.bodies[b].shape, Shape::Rod { .. });
            if !a_rod {
                return bad("body a must be a rod");
            }
            match pair.kind {
                ContactKind::Interior if b_rod => return bad("interior contacts need a tube as body b"),
                ContactKind::SelfContact if a != b => return bad("self contact names the same rod twice"),
                ContactKind::Exterior | ContactKind::Interior if a == b => return bad("a body against itself is a self contact"),
                _ => {}
            }
            if self.pairs[..p].iter().any(|q| q.a == pair.a && q.b == pair.b && q.kind == pair.kind) {
                return bad("declared twice");
            }
            resolved.push(PairIndex { a, b, kind: pair.kind });
        }
        Ok(resolved)
    }
}

/// A declared pair resolved to body indices: `a` is always a rod; `a == b` exactly for
/// [`ContactKind::SelfContact`]; `b` is a tube for [`ContactKind::Interior`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PairIndex {
    /// The rod.
    pub a: usize,
    /// The other body (a tube or a rod; `a` itself for a self contact).
    pub b: usize,
    pub kind: ContactKind,
}

/// A validated [`SceneSpec`], its pairs resolved and its [`StateLayout`] derived once.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidScene {
    spec: SceneSpec,
    pairs: Vec<PairIndex>,
    layout: StateLayout,
    max_contacts: usize,
}

impl ValidScene {
    /// Only after validation (see [`SceneSpec::validate`]).
    pub(crate) fn new(spec: SceneSpec, pairs: Vec<PairIndex>) -> Self {
        let layout = StateLayout::of(&spec);
        let max_contacts = max_contacts(&spec, &pairs);
        Self { spec, pairs, layout, max_contacts }
    }

    /// Most contacts one frame of this scene can produce: one per sample of each pair's rod
    /// (`(points - 1) * precision + 1`), and for an interior pair of the signed method,
    /// [`MAX_OTHER_WALLS`] more per sample (the other walls within reach: a lumen narrower than
    /// the rod, and with `nearest` a corner or a pocket). A reply sized for this is never cut.
    pub fn max_contacts(&self) -> usize {
        self.max_contacts
    }

    /// The spec, as declared.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }

    /// The declared pairs, in order, as body indices.
    pub fn pairs(&self) -> &[PairIndex] {
        &self.pairs
    }

    /// Where each body's floats go in the state.
    pub fn layout(&self) -> &StateLayout {
        &self.layout
    }

    /// [`StateLayout::check`] of one frame's state against this scene.
    pub fn check(&self, state: &[f32]) -> Result<(), InputError> {
        self.layout.check(&self.spec.bodies, state)
    }

    /// The spec back, owned.
    pub fn into_spec(self) -> SceneSpec {
        self.spec
    }
}

/// See [`ValidScene::max_contacts`] (at least 1, so a reply buffer is never empty).
fn max_contacts(spec: &SceneSpec, pairs: &[PairIndex]) -> usize {
    let x = spec.precision as usize;
    let others = spec.method == Method::Signed;
    let per_pair = |p: &PairIndex| {
        let samples = spec.bodies[p.a].points().saturating_sub(1) * x + 1;
        let per_sample = if others && p.kind == ContactKind::Interior { 1 + MAX_OTHER_WALLS } else { 1 };
        samples * per_sample
    };
    pairs.iter().map(per_pair).sum::<usize>().max(1)
}

impl TryFrom<SceneSpec> for ValidScene {
    type Error = SpecError;

    /// [`SceneSpec::validate`] without the copy.
    fn try_from(spec: SceneSpec) -> Result<Self, SpecError> {
        let pairs = spec.resolve()?;
        Ok(Self::new(spec, pairs))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{BodySpec, PairSpec, Shape};

    #[test]
    fn resolved_once() {
        let spec = SceneSpec::new(
            vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings: 10, spokes: 8 } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points: 5, radius: vec![1.0] } }],
            vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
        );
        let v = spec.validate().unwrap();
        assert_eq!(v.pairs(), [PairIndex { a: 1, b: 0, kind: ContactKind::Interior }]);
        assert_eq!(v.layout(), &StateLayout::of(&spec));
        assert_eq!(ValidScene::try_from(spec.clone()), Ok(v.clone()));
        assert_eq!(v.into_spec(), spec);
        let mut bad = spec.clone();
        bad.precision = 0;
        assert_eq!(ValidScene::try_from(bad), Err(SpecError::Precision(0)));
        // A name of MAX_NAME_BYTES is fine; one byte more is refused, without echoing it whole.
        let mut long = spec.clone();
        long.bodies[1].name = "s".repeat(MAX_NAME_BYTES);
        long.pairs[0].a = long.bodies[1].name.clone();
        assert!(long.validate().is_ok());
        long.bodies[1].name.push('s');
        let e = long.validate().unwrap_err();
        assert_eq!(e, SpecError::NameTooLong { index: 1, got: MAX_NAME_BYTES + 1, start: "s".repeat(24), max: MAX_NAME_BYTES });
        assert!(e.to_string().len() < 200, "{e}");
    }

    #[test]
    fn replies_are_sized_for_every_wall_a_sample_can_report() {
        // A 160-point scope at precision 4 (637 samples) inside a colon and against a second
        // rod: one contact per sample and pair, and interior samples may add MAX_OTHER_WALLS
        // other walls each, with or without `nearest` (the daemon once cut those replies at 637
        // and the scope's tip lost its contacts).
        let mut spec = SceneSpec::new(
            vec![
                BodySpec { name: "colon".into(), shape: Shape::Tube { rings: 10, spokes: 8 } },
                BodySpec { name: "scope".into(), shape: Shape::Rod { points: 160, radius: vec![6.5] } },
                BodySpec { name: "tool".into(), shape: Shape::Rod { points: 3, radius: vec![1.0] } },
            ],
            vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }, PairSpec { a: "tool".into(), b: "scope".into(), kind: ContactKind::Exterior }],
        );
        let tool = 2 * 4 + 1;
        assert_eq!(spec.validate().unwrap().max_contacts(), 637 * (1 + MAX_OTHER_WALLS) + tool);
        spec.nearest = false;
        assert_eq!(spec.validate().unwrap().max_contacts(), 637 * (1 + MAX_OTHER_WALLS) + tool);
        spec.method = Method::Thesis;
        assert_eq!(spec.validate().unwrap().max_contacts(), 637 + tool, "the published method reports one wall per sample");
    }
}
