//! A scene spec that passed validation, with what validation resolved kept: the pairs as body
//! indices and the state layout. Built only by [`SceneSpec::validate`] or
//! [`ValidScene::try_from`], so whoever holds one needs neither to check nor to derive again.

use crate::contact::ContactKind;
use crate::error::{InputError, SpecError};
use crate::scene::SceneSpec;
use crate::state::StateLayout;

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
}

impl ValidScene {
    /// Only after validation (see [`SceneSpec::validate`]).
    pub(crate) fn new(spec: SceneSpec, pairs: Vec<PairIndex>) -> Self {
        let layout = StateLayout::of(&spec);
        Self { spec, pairs, layout }
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
        let mut bad = spec;
        bad.precision = 0;
        assert_eq!(ValidScene::try_from(bad), Err(SpecError::Precision(0)));
    }
}
