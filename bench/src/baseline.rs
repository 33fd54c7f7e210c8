//! The generic choice a Rapier / parry3d user would make instead of Lumen: the colon wall as a
//! parry [`TriMesh`] whose BVH is refit every frame as the wall deforms, the endoscope as a
//! chain of capsules, contacts from parry's queries with a prediction distance.
//!
//! **Wall.** One vertex per spoke tip (`P_i + V_ik`, the render mesh's vertices), two triangles
//! per quad of consecutive rings x consecutive spokes (`(i, k) (i, k+1) (i+1, k+1)` and
//! `(i, k) (i+1, k+1) (i+1, k)`), no caps. Built once with [`TriMeshFlags::DEFORMABLE`]; every
//! frame [`TriMesh::update_vertices`] writes the tips from the state in place and refits the
//! BVH (parry 0.31's refit: leaf boxes recomputed, tree structure kept, no rebuild, no
//! allocation). No pseudo-normals are requested (they would be recomputed every frame and
//! `query::contact` does not use them).
//!
//! **Endoscope.** Sampled `x` times per segment on the same centripetal Catmull-Rom as
//! `lumen-detect` ([`lumen_detect::spline::Cubic::of_chain`], `f32`, world coordinates as a
//! parry user has them); one [`Capsule`] per pair of consecutive samples, radius = the scope's.
//!
//! **Contacts.** [`parry3d::query::contact`] per capsule against the mesh with the prediction
//! distance (the scene margin, 0 by default): parry traverses the mesh's BVH with the capsule's
//! box and runs GJK (EPA when penetrating) on every triangle there, and returns the deepest
//! contact. The contact is located at the capsule's axis point under it (`point1 - r normal1`)
//! and given to the capsule's first sample (capsule `s` joins samples `s` and `s + 1`). So the
//! baseline reports at most one contact per rod sample, with depth (`-dist`), unit normal from
//! the rod towards the wall (`normal1`) and the wall point (`point2`), which the
//! [`crate::metrics`] compare with the reference at the axis point where parry computed them.
//!
//! **Round segments (the default).** Asked for a capsule, parry runs GJK on capsule vs triangle,
//! which penetrate whenever there is a contact, so every contact goes through EPA (and EPA
//! allocates its polytope on every call). A parry user who cares about speed asks the same
//! question about the capsule's axis [`Segment`] with the radius added to the prediction
//! (parry's own "round shape" treatment of capsules in its contact manifolds): same contact,
//! found by GJK distance alone while the axis stays clear of the wall. Where the axis comes
//! within `r / 2` of the wall (EPA on two flat shapes is unreliable there, and the axis may cross
//! the wall), the capsule query is asked instead. [`ParryShape::Capsules`] asks the capsule
//! everywhere (about 7x slower, same accuracy).
//!
//! Single thread; buffers are reused from frame to frame (what parry allocates inside its
//! queries, e.g. EPA's polytope, is parry's).

use lumen_detect::proto::StateLayout;
use lumen_detect::spline::Cubic;
use lumen_detect::{SceneSpec, V3};
use parry3d::math::{Pose, Vector};
use parry3d::query;
use parry3d::shape::{Capsule, Segment, TriMesh, TriMeshFlags};

/// Which parry shape stands for each piece of the endoscope.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ParryShape {
    /// A [`Capsule`] per pair of consecutive samples, queried as such.
    Capsules,
    /// The capsule's axis [`Segment`], queried with `prediction + radius`; the capsule where the
    /// axis comes within half the radius of the wall (the default).
    #[default]
    RoundSegments,
}

/// One contact of the baseline, in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParryContact {
    /// The capsule's first sample (`segment * x + step`, as `lumen-detect` counts samples).
    pub sample: u32,
    /// Point of the capsule's axis under the contact (where depth and normal were computed).
    pub centre: [f32; 3],
    /// Rod radius there.
    pub radius: f32,
    /// Penetration depth (positive: overlapping).
    pub depth: f32,
    /// Unit normal from the rod towards the wall.
    pub normal: [f32; 3],
    /// The wall point.
    pub wall: [f32; 3],
}

/// The parry3d baseline for one scene (one tube, one rod, the rod inside the tube).
pub struct ParryBaseline {
    mesh: TriMesh,
    tube_offset: usize,
    rings: usize,
    spokes: usize,
    rod_offset: usize,
    rod_points: usize,
    radius: f32,
    x: usize,
    alpha: f32,
    prediction: f32,
    shape: ParryShape,
    samples: Vec<Vector>,
    contacts: Vec<ParryContact>,
}

impl std::fmt::Debug for ParryBaseline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParryBaseline")
            .field("rings", &self.rings)
            .field("spokes", &self.spokes)
            .field("triangles", &self.mesh.num_triangles())
            .field("rod_points", &self.rod_points)
            .field("x", &self.x)
            .field("shape", &self.shape)
            .finish_non_exhaustive()
    }
}

#[inline]
fn arr(v: Vector) -> [f32; 3] {
    [v.x, v.y, v.z]
}

impl ParryBaseline {
    /// The baseline for `spec` (its first tube and first rod; precision, alpha and margin from
    /// the spec, the margin as parry's prediction distance), with the wall taken from `state`
    /// (any valid frame: the mesh is rewritten every frame). The rod must have one radius.
    pub fn new(spec: &SceneSpec, state: &[f32], shape: ParryShape) -> Result<Self, crate::Error> {
        use lumen_detect::proto::Shape;
        let layout = StateLayout::of(spec);
        if state.len() != layout.floats {
            return Err(crate::Error::BaselineState { got: state.len(), expected: layout.floats });
        }
        let tube = spec.bodies.iter().position(|b| matches!(b.shape, Shape::Tube { .. })).ok_or(crate::Error::NoTube)?;
        let rod = spec.bodies.iter().position(|b| matches!(b.shape, Shape::Rod { .. })).ok_or(crate::Error::NoRod)?;
        let Shape::Rod { radius, .. } = &spec.bodies[rod].shape else { unreachable!() };
        let radius = match radius.as_slice() {
            [r] => *r,
            r => return Err(crate::Error::RodRadii { radii: r.len() }),
        };
        let (lt, lr) = (layout.bodies[tube], layout.bodies[rod]);
        let (rings, spokes) = (lt.points, lt.spokes);
        let mut indices = Vec::with_capacity(2 * (rings - 1) * spokes);
        for i in 0..rings - 1 {
            for k in 0..spokes {
                let k1 = (k + 1) % spokes;
                let v = |i: usize, k: usize| (i * spokes + k) as u32;
                indices.push([v(i, k), v(i, k1), v(i + 1, k1)]);
                indices.push([v(i, k), v(i + 1, k1), v(i + 1, k)]);
            }
        }
        let mut vertices = vec![Vector::ZERO; rings * spokes];
        write_tips(&state[lt.offset..], rings, spokes, &mut vertices);
        let mesh = TriMesh::with_flags(vertices, indices, TriMeshFlags::DEFORMABLE)?;
        let n = (lr.points - 1) * spec.precision as usize + 1;
        Ok(Self {
            mesh,
            tube_offset: lt.offset,
            rings,
            spokes,
            rod_offset: lr.offset,
            rod_points: lr.points,
            radius,
            x: spec.precision as usize,
            alpha: spec.alpha,
            prediction: spec.margin,
            shape,
            samples: Vec::with_capacity(n),
            contacts: Vec::with_capacity(n),
        })
    }

    /// Number of wall triangles.
    pub fn triangles(&self) -> usize {
        self.mesh.num_triangles()
    }

    /// Contacts of one frame: the wall mesh rewritten and refit, the rod resampled, one query
    /// per capsule. Ordered by sample.
    pub fn detect(&mut self, state: &[f32]) -> &[ParryContact] {
        let (rings, spokes, off) = (self.rings, self.spokes, self.tube_offset);
        self.mesh.update_vertices(|v| write_tips(&state[off..], rings, spokes, v));

        // Rod samples, as lumen-detect takes them.
        let rod = &state[self.rod_offset..self.rod_offset + 3 * self.rod_points];
        let at = |i: usize| V3::new(rod[3 * i], rod[3 * i + 1], rod[3 * i + 2]);
        self.samples.clear();
        let inv = 1.0 / self.x as f32;
        for j in 0..self.rod_points - 1 {
            let c = Cubic::of_chain(at, self.rod_points, j, self.alpha);
            for s in 0..self.x {
                let p = c.at(s as f32 * inv);
                self.samples.push(Vector::new(p.x, p.y, p.z));
            }
        }
        let last = at(self.rod_points - 1);
        self.samples.push(Vector::new(last.x, last.y, last.z));

        self.contacts.clear();
        let r = self.radius;
        for s in 0..self.samples.len() - 1 {
            let (a, b) = (self.samples[s], self.samples[s + 1]);
            let capsule = |mesh: &TriMesh| query::contact(&Pose::IDENTITY, &Capsule::new(a, b, r), &Pose::IDENTITY, mesh, self.prediction);
            let found = match self.shape {
                ParryShape::Capsules => capsule(&self.mesh),
                ParryShape::RoundSegments => match query::contact(&Pose::IDENTITY, &Segment::new(a, b), &Pose::IDENTITY, &self.mesh, self.prediction + r) {
                    Ok(Some(c)) if c.dist < 0.5 * r => capsule(&self.mesh),
                    other => other.map(|c| {
                        c.map(|mut c| {
                            c.point1 += c.normal1 * r;
                            c.dist -= r;
                            c
                        })
                    }),
                },
            };
            let Ok(Some(c)) = found else { continue };
            // Kept while `depth > -prediction`, as lumen-detect keeps `depth > -margin`.
            if c.dist >= self.prediction {
                continue;
            }
            let axis = c.point1 - c.normal1 * r;
            self.contacts.push(ParryContact { sample: s as u32, centre: arr(axis), radius: r, depth: -c.dist, normal: arr(c.normal1), wall: arr(c.point2) });
        }
        &self.contacts
    }

    /// Contacts of the last frame.
    pub fn contacts(&self) -> &[ParryContact] {
        &self.contacts
    }
}

/// Spoke tips `P_i + V_ik` of a tube's floats (per ring: point, then its spokes).
fn write_tips(tube: &[f32], rings: usize, spokes: usize, out: &mut [Vector]) {
    let stride = 3 * (spokes + 1);
    for i in 0..rings {
        let ring = &tube[i * stride..(i + 1) * stride];
        let p = Vector::new(ring[0], ring[1], ring[2]);
        for (k, v) in out[i * spokes..(i + 1) * spokes].iter_mut().enumerate() {
            let o = 3 * (k + 1);
            *v = p + Vector::new(ring[o], ring[o + 1], ring[o + 2]);
        }
    }
}
