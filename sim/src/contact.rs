//! Lumen's contacts as XPBD contact constraints between the rod and the wall (or the rod
//! itself).
//!
//! **Units**: millimetres, seconds, kilograms.
//!
//! A [`lumen_detect::Contact`] says, for one rod sample: its segment `segment_a` and
//! parameter `param_a` (of the scope as the state lists it, handle first: rod segment
//! `j = N - 2 - segment_a`, `t = 1 - param_a`), a unit normal `n` from the rod towards the wall, the penetration
//! `depth` (positive: overlapping), and, for a tube, the four wall tips of its patch (rings
//! `index_b`, `index_b + 1`, spokes `spoke_b`, `spoke_b + 1` mod `B`) with bilinear weights
//! `beta_k`; for a rod (self contact), the other segment and its two weights.
//!
//! The frame's contacts are detected once, on the positions at the start of the frame, and
//! reused by every substep, linearised about those positions with the contact's own normal
//! (never recomputed from positions, so it cannot flip). With the sample's centre moving like
//! `p_a(x) = (1 - t) x_j + t x_{j+1}` and the wall point like `sum_k beta_k (tip_k)`:
//!
//! `C(x) = -depth - n . (p_a(x) - p_a(x0)) + n . (p_b(x) - p_b(x0)) >= 0`.
//!
//! For the wall, a tip moves only outward along its spoke, by a displacement interpolated from
//! the wall's nodes (`tip_k = rest_k + e_k sum_m N_km U_m`, see [`crate::wall`]), so
//! `n . (p_b - p_b0) = sum_m G_m (U_m - U_m0)` with
//! `G_m = sum_k beta_k max(0, n . e_k) N_km` over the (at most sixteen) nodes of the four tips; the
//! constant part is folded into `c0 = -depth + n . p_a(x0) - sum_m G_m U_m0` at build time, and a
//! substep evaluates `C = c0 - n . p_a(x) + sum_m G_m U_m`.
//!
//! Projection (inequality, compliance 0, mass-weighted): when `C < 0`,
//! `dlambda = -C / W`, `W = sum_a a_i^2 w_i + sum_b b_m^2 w_m` (`a = (1 - t, t)`, `w` the
//! inverse masses; a wall node already at its outer limit counts as immovable), then
//! `dx_i = -a_i w_i n dlambda` on the rod and `dU_m = G_m w_node dlambda` on the wall
//! (`dx = +b_j w_j n dlambda` on the other rod segment for a self contact). When a node stops at
//! its limit part-way, the rod's share grows to close the gap.
//!
//! **Corners.** A sample wedged where two faces meet (the tip against a fold or the front of a
//! bulge, and the outer wall) gets a contact for each face within the margin when the scene
//! declares `nearest` (all but the nearest flagged `FLAG_OTHER_WALL`), and so does a sample in a
//! lumen narrower than the scope, from the walls all around it; otherwise only the nearest face.
//! Along the scope's two end segments the faces rising beside a contact at a concave crease,
//! which are no nearest point of their own, join them too ([`crate::crease`]).
//! Either way the nearest face can change from frame to frame, and each frame's contacts push
//! the sample into a face they no longer hold. So a sample's contact of the previous frame is
//! carried into this one, as another one-sided constraint with its own (still valid)
//! linearisation, when none of the sample's contacts now has a normal within
//! [`ContactSet::CARRY_ANGLE_DEG`] of it: the sample is then held by every face it met.
//!
//! No friction (a lubricated colonoscope slides freely; the operator's hard push holds the tip
//! explicitly).

use crate::rod::Rod;
use crate::v3;
use crate::wall::Wall;
use lumen_detect::V3d;
use lumen_proto::{Contact, ContactKind};

/// Most interior contacts of one rod sample: its nearest wall and up to three others
/// (`FLAG_OTHER_WALL`, see [`lumen_proto::contact::FLAG_OTHER_WALL`]).
const WALLS: usize = 4;

/// Most wall nodes one contact's four tips (two rings, two spokes) depend on: 4 x 4.
const MAX_NODES: usize = 16;

/// The other side of a contact constraint (kept inline: the constraints are projected
/// several times per substep and read straight through).
#[derive(Debug, Clone, Copy)]
#[allow(clippy::large_enum_variant)]
enum Other {
    /// Wall nodes: their indices, their slots in the wall's active list this frame, and `G_m`.
    Wall { n: u8, nodes: [u32; MAX_NODES], slots: [u32; MAX_NODES], g: [f64; MAX_NODES] },
    /// Two rod points and their weights.
    Rod { points: [u32; 2], w: [f64; 2] },
}

/// One contact constraint.
#[derive(Debug, Clone, Copy)]
pub struct ContactConstraint {
    sample: u32,
    a: [u32; 2],
    wa: [f64; 2],
    other: Other,
    n: V3d,
    c0: f64,
}

/// Contacts of one frame, ready to project.
#[derive(Debug, Clone, Default)]
pub struct ContactSet {
    list: Vec<ContactConstraint>,
    /// Interior constraints of the previous frame (with wall node indices).
    prev: Vec<ContactConstraint>,
    /// Which of `prev` are carried into this frame.
    carry: Vec<u32>,
    /// This frame's interior normals per rod sample, at most [`WALLS`] (zero: none).
    normal_of: Vec<[V3d; WALLS]>,
    /// Whether each constraint was violated in the current substep.
    hit: Vec<bool>,
    /// The anus plane (a point and the unit normal into the body) and the scope's radius (mm),
    /// if set: contacts of samples further behind it are not answered (see
    /// [`ContactSet::set_body_entry`]).
    entry: Option<(V3d, V3d, f64)>,
}

/// The tips a tube contact touches: (ring, spoke), (ring, spoke+1), (ring+1, spoke),
/// (ring+1, spoke+1) as tip indices.
fn tips_of(c: &Contact, spokes: usize) -> [u32; 4] {
    let (i, k) = (c.index_b as usize, c.spoke_b as usize);
    let k1 = (k + 1) % spokes;
    [(i * spokes + k) as u32, (i * spokes + k1) as u32, ((i + 1) * spokes + k) as u32, ((i + 1) * spokes + k1) as u32]
}

/// Whether a contact is one this simulation answers: the scope (`rod_body`) against the colon
/// (`tube_body`) from inside, or against itself.
fn usable(c: &Contact, rod_body: u16, tube_body: u16) -> bool {
    c.body_a == rod_body && ((c.kind == ContactKind::Interior as u8 && c.body_b == tube_body) || (c.kind == ContactKind::SelfContact as u8 && c.body_b == rod_body))
}

fn interior(c: &Contact, wall: &Wall) -> bool {
    c.kind == ContactKind::Interior as u8 && (c.index_b as usize) + 1 < wall.rings()
}

impl ContactSet {
    /// A sample's contact of the previous frame is kept when its normal turned by more than
    /// this, degrees.
    pub const CARRY_ANGLE_DEG: f64 = 15.0;

    /// Number of constraints this frame.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Constraints carried from the previous frame.
    pub fn carried(&self) -> usize {
        self.carry.len()
    }

    /// Sets the plane where the scope enters the body (a point and the unit normal pointing
    /// in) and the scope's radius (mm). Scope samples behind it are outside the patient, held by
    /// the anus guide: contacts the detector reports for them (a tube's first rings can tilt so
    /// that their slab reaches behind the anus) are not answered, except within the scope's
    /// radius of the plane, where the sample's surface is in the body. Unanswered there, a
    /// sample entering the body could already be a millimetre into the wall by the frame it
    /// crosses the plane (`docs/decisions/sim.md`).
    pub fn set_body_entry(&mut self, origin: V3d, dir: V3d, radius_mm: f64) {
        self.entry = Some((origin, dir, radius_mm));
    }

    /// The rod segment and parameter of contact `c` (state order is handle first).
    fn rod_place(c: &Contact, last: usize) -> (usize, f64) {
        let s = (c.segment_a as usize).min(last - 1);
        (last - 1 - s, 1.0 - (c.param_a as f64).clamp(0.0, 1.0))
    }

    /// Whether contact `c`'s sample is inside the body (in front of the entry plane).
    pub fn in_body(&self, c: &Contact, rod: &Rod) -> bool {
        self.behind(c, rod) <= 0.0
    }

    /// How far behind the entry plane contact `c`'s sample is (mm; <= 0 in the body).
    fn behind(&self, c: &Contact, rod: &Rod) -> f64 {
        let Some((o, a, _)) = self.entry else { return f64::NEG_INFINITY };
        let (j, t) = Self::rod_place(c, rod.len() - 1);
        -a.dot(&(rod.x[j] * (1.0 - t) + rod.x[j + 1] * t - o))
    }

    /// Whether contact `c` is answered: its sample's surface reaches into the body.
    fn answered(&self, c: &Contact, rod: &Rod) -> bool {
        self.behind(c, rod) <= self.entry.map_or(0.0, |e| e.2)
    }

    /// Chooses what to carry from the previous frame and marks the wall nodes this frame's
    /// constraints use as touched (before [`Wall::settle`]).
    pub fn touch(&mut self, contacts: &[Contact], rod_body: u16, tube_body: u16, rod: &Rod, wall: &mut Wall) {
        for v in self.normal_of.iter_mut() {
            *v = [V3d::zeros(); WALLS];
        }
        for c in contacts {
            if usable(c, rod_body, tube_body) && interior(c, wall) && self.answered(c, rod) {
                for (tip, &b) in tips_of(c, wall.spokes()).iter().zip(&c.weights_b) {
                    if b > 0.0 {
                        wall.touch_tip(*tip);
                    }
                }
                let s = c.sample as usize;
                if self.normal_of.len() <= s {
                    self.normal_of.resize(s + 1, [V3d::zeros(); WALLS]);
                }
                if let Some(slot) = self.normal_of[s].iter_mut().find(|n| **n == V3d::zeros()) {
                    *slot = v3(c.normal);
                }
            }
        }
        let cos = Self::CARRY_ANGLE_DEG.to_radians().cos();
        self.carry.clear();
        for (i, k) in self.prev.iter().enumerate() {
            let now = self.normal_of.get(k.sample as usize).copied().unwrap_or([V3d::zeros(); WALLS]);
            // Carried unless one of the sample's walls now is the same face (a zero normal, no
            // contact, is never within the angle).
            if now.iter().all(|n| n.dot(&k.n) < cos) {
                self.carry.push(i as u32);
                if let Other::Wall { n, nodes, .. } = k.other {
                    for &node in &nodes[..n as usize] {
                        wall.touch_node(node);
                    }
                }
            }
        }
    }

    /// Builds this frame's constraints: `contacts` linearised about the current positions,
    /// then the carried ones (after [`ContactSet::touch`] and [`Wall::settle`], so every node
    /// has its final slot).
    pub fn build(&mut self, contacts: &[Contact], rod_body: u16, tube_body: u16, rod: &Rod, wall: &Wall) {
        self.list.clear();
        let last = rod.len() - 1;
        for c in contacts {
            if !usable(c, rod_body, tube_body) || !self.answered(c, rod) {
                continue;
            }
            let is_wall = c.kind == ContactKind::Interior as u8;
            if is_wall && !interior(c, wall) {
                continue;
            }
            // The state lists the scope handle first (see `crate::world`): state segment `s`
            // joins rod points `N-1-s` and `N-2-s`, at parameter `t` from the former.
            let (j, t) = Self::rod_place(c, last);
            let n = v3(c.normal);
            let nn = n.norm();
            if nn.is_nan() || nn <= 0.5 {
                continue;
            }
            let n = n / nn;
            let wa = [1.0 - t, t];
            let pa = rod.x[j] * wa[0] + rod.x[j + 1] * wa[1];
            let mut c0 = -(c.depth as f64) + n.dot(&pa);
            let other = if is_wall {
                let mut m = 0usize;
                let mut nodes = [0u32; MAX_NODES];
                let mut slots = [0u32; MAX_NODES];
                let mut g = [0.0; MAX_NODES];
                for (&tip, &b) in tips_of(c, wall.spokes()).iter().zip(&c.weights_b) {
                    let gk = b as f64 * n.dot(&wall.tip_dir(tip)).max(0.0);
                    if gk <= 0.0 {
                        continue;
                    }
                    let tn = wall.tip_nodes(tip);
                    for q in 0..9 {
                        if tn.weights[q] <= 0.0 {
                            continue;
                        }
                        // Touched in `touch`, so active.
                        let Some(s) = wall.slot_of(tn.nodes[q]) else { continue };
                        let gm = gk * tn.weights[q];
                        match nodes[..m].iter().position(|&x| x == tn.nodes[q]) {
                            Some(e) => g[e] += gm,
                            None if m < MAX_NODES => {
                                nodes[m] = tn.nodes[q];
                                slots[m] = s as u32;
                                g[m] = gm;
                                m += 1;
                            }
                            None => {}
                        }
                    }
                }
                for e in 0..m {
                    c0 -= g[e] * wall.node_u(slots[e] as usize);
                }
                Other::Wall { n: m as u8, nodes, slots, g }
            } else {
                let i = last - 1 - (c.index_b as usize).min(last - 1);
                let w = [c.weights_b[1] as f64, c.weights_b[0] as f64];
                let pb = rod.x[i] * w[0] + rod.x[i + 1] * w[1];
                c0 -= n.dot(&pb);
                Other::Rod { points: [i as u32, i as u32 + 1], w }
            };
            self.list.push(ContactConstraint { sample: c.sample, a: [j as u32, j as u32 + 1], wa, other, n, c0 });
        }
        let fresh = self.list.len();
        for &i in &self.carry {
            let mut k = self.prev[i as usize];
            if let Other::Wall { n, nodes, ref mut slots, .. } = k.other {
                for e in 0..n as usize {
                    slots[e] = wall.slot_of(nodes[e]).expect("carried nodes are touched") as u32;
                }
            }
            self.list.push(k);
        }
        self.prev.clear();
        self.prev.extend(self.list[..fresh].iter().filter(|k| matches!(k.other, Other::Wall { .. })));
    }

    /// Starts a substep: no constraint has been violated yet.
    pub fn begin_substep(&mut self) {
        self.hit.clear();
        self.hit.resize(self.list.len(), false);
    }

    /// Projects every constraint once; returns the largest violation met (mm, >= 0).
    pub fn project(&mut self, rod: &mut Rod, wall: &mut Wall) -> f64 {
        let w_node = wall.node_inv_mass();
        let mut worst = 0.0f64;
        if self.hit.len() != self.list.len() {
            self.begin_substep();
        }
        for (ki, k) in self.list.iter().enumerate() {
            let (a0, a1) = (k.a[0] as usize, k.a[1] as usize);
            let pa = rod.x[a0] * k.wa[0] + rod.x[a1] * k.wa[1];
            let mut c = k.c0 - k.n.dot(&pa);
            let rod_w = k.wa[0] * k.wa[0] * rod.inv_mass[a0] + k.wa[1] * k.wa[1] * rod.inv_mass[a1];
            let mut wsum = rod_w;
            match k.other {
                Other::Wall { n, slots, g, .. } => {
                    for e in 0..n as usize {
                        let s = slots[e] as usize;
                        c += g[e] * wall.node_u(s);
                        if wall.can_move_out(s) {
                            wsum += g[e] * g[e] * w_node;
                        }
                    }
                }
                Other::Rod { points, w } => {
                    let (b0, b1) = (points[0] as usize, points[1] as usize);
                    c += k.n.dot(&(rod.x[b0] * w[0] + rod.x[b1] * w[1]));
                    wsum += w[0] * w[0] * rod.inv_mass[b0] + w[1] * w[1] * rod.inv_mass[b1];
                }
            }
            if c >= 0.0 || wsum <= 0.0 {
                continue;
            }
            self.hit[ki] = true;
            worst = worst.max(-c);
            let dl = -c / wsum;
            let mut rest = dl;
            match k.other {
                Other::Wall { n, slots, g, .. } => {
                    // The wall first: a node stopped by its limit passes the remainder to the rod.
                    let mut gained = 0.0;
                    for e in 0..n as usize {
                        let s = slots[e] as usize;
                        if wall.can_move_out(s) {
                            gained += g[e] * wall.push(s, g[e] * w_node * dl);
                        }
                    }
                    if rod_w > 0.0 {
                        rest = (-c - gained) / rod_w;
                    }
                }
                Other::Rod { points, w } => {
                    let (b0, b1) = (points[0] as usize, points[1] as usize);
                    rod.x[b0] += k.n * (w[0] * rod.inv_mass[b0] * dl);
                    rod.x[b1] += k.n * (w[1] * rod.inv_mass[b1] * dl);
                }
            }
            rod.x[a0] -= k.n * (k.wa[0] * rod.inv_mass[a0] * rest);
            rod.x[a1] -= k.n * (k.wa[1] * rod.inv_mass[a1] * rest);
        }
        worst
    }

    /// After the substep's velocity update: every constraint violated in the substep is made
    /// inelastic, its separating normal velocity `dC/dt > 0` (which the position correction of
    /// a penetration creates, `depth / h`) removed by a mass-weighted velocity change
    /// `dv = w grad(C) dlambda`, `dlambda = -dC/dt / W`. Without it a sample pushed out of one face
    /// of a corner leaves at `depth / h` and crosses into the other face within the frame.
    pub fn stop_separation(&self, rod: &mut Rod, wall: &mut Wall) {
        let w_node = wall.node_inv_mass();
        for (k, _) in self.list.iter().zip(&self.hit).filter(|(_, &h)| h) {
            let (a0, a1) = (k.a[0] as usize, k.a[1] as usize);
            let va = rod.v[a0] * k.wa[0] + rod.v[a1] * k.wa[1];
            let mut rate = -k.n.dot(&va);
            let mut wsum = k.wa[0] * k.wa[0] * rod.inv_mass[a0] + k.wa[1] * k.wa[1] * rod.inv_mass[a1];
            match k.other {
                Other::Wall { n, slots, g, .. } => {
                    for e in 0..n as usize {
                        let s = slots[e] as usize;
                        rate += g[e] * wall.node_v(s);
                        wsum += g[e] * g[e] * w_node;
                    }
                }
                Other::Rod { points, w } => {
                    let (b0, b1) = (points[0] as usize, points[1] as usize);
                    rate += k.n.dot(&(rod.v[b0] * w[0] + rod.v[b1] * w[1]));
                    wsum += w[0] * w[0] * rod.inv_mass[b0] + w[1] * w[1] * rod.inv_mass[b1];
                }
            }
            if rate <= 0.0 || wsum <= 0.0 {
                continue;
            }
            let dl = -rate / wsum;
            rod.v[a0] -= k.n * (k.wa[0] * rod.inv_mass[a0] * dl);
            rod.v[a1] -= k.n * (k.wa[1] * rod.inv_mass[a1] * dl);
            match k.other {
                Other::Wall { n, slots, g, .. } => {
                    for e in 0..n as usize {
                        wall.add_node_v(slots[e] as usize, g[e] * w_node * dl);
                    }
                }
                Other::Rod { points, w } => {
                    let (b0, b1) = (points[0] as usize, points[1] as usize);
                    rod.v[b0] += k.n * (w[0] * rod.inv_mass[b0] * dl);
                    rod.v[b1] += k.n * (w[1] * rod.inv_mass[b1] * dl);
                }
            }
        }
    }
}
