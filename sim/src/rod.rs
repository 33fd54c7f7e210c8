//! The endoscope: an XPBD rod of equally spaced control points, tip first.
//!
//! **Units**: millimetres, seconds, kilograms; forces are then in mN (kg mm/s^2), stiffnesses
//! in mN/mm = N/m (kg/s^2), XPBD compliances in s^2/kg.
//!
//! **State**: positions `x_i` and velocities `v_i` of `N` control points (point 0 is the distal
//! tip, point `N - 1` the handle end), each of mass `m = rho_l * L / (N - 1)` (`rho_l` the linear
//! density; the two end points carry half a segment each, kept equal here for a uniform
//! response), rest segment length `l0 = L / (N - 1)`.
//!
//! **Constraints** (one XPBD iteration per substep of length `h`, Lagrange multipliers reset
//! every substep, as in "Small Steps in Physics Simulation", Macklin et al. 2019):
//! - *stretch*, per segment: `C = |x_{j+1} - x_j| - l0`, compliance `alpha_s` (0: inextensible);
//!   `dlambda = -C / (w_j + w_{j+1} + alpha_s / h^2)`, `dx_j = -w_j n dlambda`,
//!   `dx_{j+1} = w_{j+1} n dlambda` with `n` the unit segment direction and `w = 1/m`;
//! - *bend*, per interior point: the discrete curvature vector
//!   `C = x_{i-1} - 2 x_i + x_{i+1} - d_i` (three components, `d_i` the rest curvature vector,
//!   zero for a straight scope). For equal segments `|x_{i-1} - 2 x_i + x_{i+1}| ~ l0 theta_i`
//!   (`theta_i` the turning angle), and the elastic energy of a rod of flexural rigidity `EI`,
//!   `E = EI/2 int kappa^2 ds ~ sum EI theta_i^2 / (2 l0)`, is `sum |C|^2 / (2 alpha_b)` with
//!   `alpha_b = l0^3 / EI`. The constraint is linear in the positions, so its projection is
//!   exact: `dlambda = -C / (w_{i-1} + 4 w_i + w_{i+1} + alpha_b / h^2)`, `dx_{i-1} = w_{i-1}
//!   dlambda`, `dx_i = -2 w_i dlambda`, `dx_{i+1} = w_{i+1} dlambda`.
//!
//! **Twist** is not a degree of freedom: the shaft is taken as torsionally rigid (a colonoscope
//! transmits nearly all of the handle's rotation to the tip), so its material frame is the
//! rotation-minimising frame carried from the handle ([`Rod::transported_normals`]) turned by
//! the handle's roll. Rolling the handle turns the plane of the angulated bending section
//! ([`Rod::set_tip_bend`]); a straight tip does not see it.
//!
//! **Integration** per substep: `v <- v / (1 + c h) + g h` (linear damping `c`, gravity `g`),
//! `x <- x + v h`, constraints, `v <- (x - x_prev) / h`. Everything is deterministic: plain
//! loops in a fixed order, no randomness.

// The physics runs in `f64` (`lumen_detect::V3d`): gravity's step `g h^2` is far below `f32`'s
// resolution at colon coordinates.
use lumen_detect::V3d;

/// Kilograms of mass per kg mm^3/s^2 of EI: `1 N m^2 = 1e9 kg mm^3 / s^2`.
const NM2_TO_KG_MM3_S2: f64 = 1e9;

/// The scope's physical parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct RodParams {
    /// Length, mm (default 1600: a colonoscope's insertion tube).
    pub length_mm: f64,
    /// Control points (default 160; 10.06 mm apart at 1.6 m).
    pub points: usize,
    /// Radius, mm (default 6.5: a 13 mm adult colonoscope).
    pub radius_mm: f64,
    /// Linear density, kg/m (default 0.2).
    pub mass_per_m_kg: f64,
    /// Flexural rigidity `EI`, N m^2 (default 0.15, within the range measured on adult
    /// colonoscopes' insertion tubes).
    pub flexural_rigidity_nm2: f64,
    /// Stretch compliance, s^2/kg (default 0: inextensible).
    pub stretch_compliance: f64,
    /// Linear velocity damping, 1/s (default 10).
    pub damping_per_s: f64,
}

impl Default for RodParams {
    fn default() -> Self {
        Self { length_mm: 1600.0, points: 160, radius_mm: 6.5, mass_per_m_kg: 0.2, flexural_rigidity_nm2: 0.15, stretch_compliance: 0.0, damping_per_s: 10.0 }
    }
}

impl RodParams {
    /// Rest segment length `l0`, mm.
    pub fn segment_mm(&self) -> f64 {
        self.length_mm / (self.points - 1) as f64
    }

    /// Mass of one control point, kg.
    pub fn point_mass_kg(&self) -> f64 {
        self.mass_per_m_kg * 1e-3 * self.segment_mm()
    }

    /// Bend compliance `alpha_b = l0^3 / EI`, s^2/kg.
    pub fn bend_compliance(&self) -> f64 {
        self.segment_mm().powi(3) / (self.flexural_rigidity_nm2 * NM2_TO_KG_MM3_S2)
    }
}

/// The rod's state and its internal constraints.
#[derive(Debug, Clone)]
pub struct Rod {
    pub params: RodParams,
    /// Positions, mm, tip first.
    pub x: Vec<V3d>,
    /// Velocities, mm/s.
    pub v: Vec<V3d>,
    /// Inverse masses, 1/kg (0: the point does not move).
    pub inv_mass: Vec<f64>,
    /// Rest curvature vector `d_i` of each point (zero at the two ends).
    pub rest_bend: Vec<V3d>,
    prev: Vec<V3d>,
    rest_len: f64,
    bend_compliance: f64,
}

impl Rod {
    /// A rod through `points` (tip first; `params.points` of them, about `l0` apart), at rest.
    ///
    /// # Panics
    /// If the count differs from `params.points` or is below 3.
    pub fn new(params: RodParams, points: Vec<V3d>) -> Self {
        assert!(params.points >= 3 && points.len() == params.points, "{} points for a rod of {}", points.len(), params.points);
        let n = points.len();
        let w = 1.0 / params.point_mass_kg();
        Self {
            rest_len: params.segment_mm(),
            bend_compliance: params.bend_compliance(),
            v: vec![V3d::zeros(); n],
            prev: points.clone(),
            inv_mass: vec![w; n],
            rest_bend: vec![V3d::zeros(); n],
            x: points,
            params,
        }
    }

    /// A straight rod from `tip` along unit `dir` (towards the handle).
    pub fn straight(params: RodParams, tip: V3d, dir: V3d) -> Self {
        let l0 = params.segment_mm();
        let pts = (0..params.points).map(|i| tip + dir * (l0 * i as f64)).collect();
        Self::new(params, pts)
    }

    /// Number of control points.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Always false (a rod has at least 3 points).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Rest segment length `l0`, mm.
    pub fn rest_segment(&self) -> f64 {
        self.rest_len
    }

    /// Rest length `(N - 1) l0`, mm.
    pub fn rest_length(&self) -> f64 {
        self.rest_len * (self.len() - 1) as f64
    }

    /// Current length along the control polygon, mm.
    pub fn length(&self) -> f64 {
        self.x.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }

    /// Largest distance of a control point from the line through the two ends, mm.
    pub fn max_deviation_from_chord(&self) -> f64 {
        let (a, b) = (self.x[0], self.x[self.len() - 1]);
        let d = (b - a).normalize();
        self.x.iter().map(|p| (p - a - d * (p - a).dot(&d)).norm()).fold(0.0, f64::max)
    }

    /// True if every position and velocity is finite.
    pub fn is_finite(&self) -> bool {
        self.x.iter().chain(&self.v).all(|p| p.iter().all(|c| c.is_finite()))
    }

    /// Starts a substep: damping, gravity `g` (mm/s^2), and the explicit position update.
    pub fn predict(&mut self, h: f64, g: V3d) {
        let damp = 1.0 / (1.0 + self.params.damping_per_s * h);
        for i in 0..self.x.len() {
            self.prev[i] = self.x[i];
            if self.inv_mass[i] == 0.0 {
                self.v[i] = V3d::zeros();
                continue;
            }
            self.v[i] = self.v[i] * damp + g * h;
            self.x[i] += self.v[i] * h;
        }
    }

    /// Ends a substep: velocities from the positions' change.
    pub fn update_velocity(&mut self, h: f64) {
        let inv_h = 1.0 / h;
        for i in 0..self.x.len() {
            self.v[i] = (self.x[i] - self.prev[i]) * inv_h;
        }
    }

    /// Scales down every velocity faster than `max` (mm/s) to `max`, and moves its point back
    /// along its substep's path to where that speed takes it in `h` (s): a point the
    /// constraints threw further than `max h` within the substep would otherwise keep that
    /// jump, and a frame could carry a sample past the detection margin into a wall nobody
    /// reported. Returns how many.
    pub fn limit_speed(&mut self, max: f64, h: f64) -> u32 {
        let reach = max * h;
        let mut n = 0;
        for i in 0..self.v.len() {
            let mut hit = false;
            let d = self.x[i] - self.prev[i];
            let d2 = d.norm_squared();
            if d2 > reach * reach {
                self.x[i] = self.prev[i] + d * (reach / d2.sqrt());
                hit = true;
            }
            let s2 = self.v[i].norm_squared();
            if s2 > max * max {
                self.v[i] *= max / s2.sqrt();
                hit = true;
            }
            n += hit as u32;
        }
        n
    }

    /// Projects every stretch constraint once, from the tip (or from the handle if `reverse`).
    pub fn solve_stretch(&mut self, h: f64, reverse: bool) {
        let n = self.x.len();
        let at = self.params.stretch_compliance / (h * h);
        for k in 0..n - 1 {
            let j = if reverse { n - 2 - k } else { k };
            let (wa, wb) = (self.inv_mass[j], self.inv_mass[j + 1]);
            let ws = wa + wb + at;
            if ws == 0.0 {
                continue;
            }
            let d = self.x[j + 1] - self.x[j];
            let len = d.norm();
            if len < 1e-12 {
                continue;
            }
            let nrm = d / len;
            let dl = -(len - self.rest_len) / ws;
            self.x[j] -= nrm * (wa * dl);
            self.x[j + 1] += nrm * (wb * dl);
        }
    }

    /// Projects every bend constraint once, from the tip.
    pub fn solve_bend(&mut self, h: f64) {
        let at = self.bend_compliance / (h * h);
        for i in 1..self.x.len() - 1 {
            let (w0, w1, w2) = (self.inv_mass[i - 1], self.inv_mass[i], self.inv_mass[i + 1]);
            let ws = w0 + 4.0 * w1 + w2 + at;
            if ws == 0.0 {
                continue;
            }
            let c = self.x[i - 1] - self.x[i] * 2.0 + self.x[i + 1] - self.rest_bend[i];
            let dl = -c / ws;
            self.x[i - 1] += dl * w0;
            self.x[i] -= dl * (2.0 * w1);
            self.x[i + 1] += dl * w2;
        }
    }

    /// The rod's material "normal" at each point for a torsionally rigid shaft: `reference`
    /// (perpendicular to the handle's last segment, in the handle's frame) carried from the
    /// handle to the tip by parallel transport (projection onto each segment's normal plane,
    /// which is the rotation-minimising frame for segments that turn by less than 90 degrees).
    pub fn transported_normals(&self, reference: V3d, out: &mut Vec<V3d>) {
        let n = self.x.len();
        out.clear();
        out.resize(n, V3d::zeros());
        let mut r = reference;
        // Segment j joins points j and j + 1; walk from the handle's segment to the tip's.
        let mut seg = vec![V3d::zeros(); n - 1];
        for j in (0..n - 1).rev() {
            let t = (self.x[j + 1] - self.x[j]).try_normalize(1e-12).unwrap_or_else(V3d::x);
            let p = r - t * r.dot(&t);
            r = p.try_normalize(1e-12).unwrap_or(r);
            seg[j] = r;
        }
        out[0] = seg[0];
        out[n - 1] = seg[n - 2];
        for i in 1..n - 1 {
            out[i] = (seg[i - 1] + seg[i]).try_normalize(1e-12).unwrap_or(seg[i]);
        }
    }

    /// Angulates the distal bending section: the first `section` joints (points `1..=section`)
    /// get a rest turning angle of `angle / section` each, towards `normals[i]` (see
    /// [`Rod::transported_normals`]); every other point is straight at rest.
    pub fn set_tip_bend(&mut self, angle: f64, section: usize, normals: &[V3d]) {
        let n = self.x.len();
        let section = section.min(n - 2);
        for d in self.rest_bend.iter_mut() {
            *d = V3d::zeros();
        }
        if angle == 0.0 || section == 0 {
            return;
        }
        let theta = angle / section as f64;
        // |x_{i-1} - 2 x_i + x_{i+1}| = 2 l0 sin(theta / 2) for equal segments turning by theta,
        // pointing to the inside of the bend.
        let mag = 2.0 * self.rest_len * (0.5 * theta).sin();
        for (d, n) in self.rest_bend[1..=section].iter_mut().zip(&normals[1..=section]) {
            *d = n * mag;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_in_units() {
        let p = RodParams::default();
        assert!((p.segment_mm() - 1600.0 / 159.0).abs() < 1e-12);
        // 0.2 kg/m over 10.06 mm: about 2 g per point.
        assert!((p.point_mass_kg() - 2.0126e-3).abs() < 1e-6);
        // l0^3 / EI = 1019 mm^3 / 1.5e8 kg mm^3/s^2.
        assert!((p.bend_compliance() - 6.794e-6).abs() < 1e-8);
    }

    #[test]
    fn the_speed_limit_bounds_a_substeps_displacement_too() {
        // A point a constraint threw 5 mm within a substep, whose velocity was then cut below the
        // limit (as a contact's separating velocity is removed): it ends `max h` from where the
        // substep started, along its path. Another, 0.5 mm/s slow, is left alone.
        let p = RodParams { points: 3, length_mm: 20.0, ..RodParams::default() };
        let mut rod = Rod::straight(p, V3d::zeros(), V3d::x());
        let h = 1e-3 / 16.0;
        rod.predict(h, V3d::zeros());
        let start = [rod.prev[0], rod.prev[1]];
        rod.x[0] += V3d::new(0.0, 3.0, 4.0);
        rod.x[1] += V3d::new(0.0, 0.5 * h, 0.0);
        rod.update_velocity(h);
        rod.v[0] = V3d::new(0.0, 30.0, 40.0);
        let (max, moved) = (1000.0, rod.limit_speed(1000.0, h));
        assert_eq!(moved, 1);
        let d = rod.x[0] - start[0];
        assert!((d.norm() - max * h).abs() < 1e-12, "moved {} mm, the limit allows {}", d.norm(), max * h);
        assert!((d.normalize() - V3d::new(0.0, 0.6, 0.8)).norm() < 1e-12, "along its path: {d:?}");
        assert!((rod.v[0] - V3d::new(0.0, 30.0, 40.0)).norm() < 1e-12, "a velocity under the limit stays");
        assert!((rod.x[1] - start[1] - V3d::new(0.0, 0.5 * h, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn a_bent_rest_shape_is_reached() {
        let p = RodParams { points: 12, length_mm: 110.0, ..RodParams::default() };
        let mut rod = Rod::straight(p, V3d::zeros(), V3d::x());
        let mut normals = Vec::new();
        rod.inv_mass[11] = 0.0;
        rod.inv_mass[10] = 0.0;
        let h = 1e-3 / 16.0;
        for step in 0..16 * 3000 {
            // As the world does once per frame: the bend follows the rod's own frame.
            if step % 16 == 0 {
                rod.transported_normals(V3d::y(), &mut normals);
                rod.set_tip_bend(std::f64::consts::FRAC_PI_2, 10, &normals);
            }
            rod.predict(h, V3d::zeros());
            rod.solve_bend(h);
            rod.solve_stretch(h, false);
            rod.update_velocity(h);
        }
        // The tip's segment has turned by about 90 degrees towards +y.
        let t = (rod.x[0] - rod.x[1]).normalize();
        let angle = t.dot(&-V3d::x()).clamp(-1.0, 1.0).acos();
        assert!((angle.to_degrees() - 90.0).abs() < 5.0, "{}", angle.to_degrees());
        assert!(rod.x[0].y > 30.0, "{:?}", rod.x[0]);
    }
}
