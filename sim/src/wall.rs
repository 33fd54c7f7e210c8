//! The colon wall: it gives where the scope touches it and springs back elsewhere.
//!
//! **Units**: millimetres, seconds, kilograms (stiffnesses in N/m = kg/s^2, pressures in kPa).
//!
//! **Model.** The midline is anchored: ring control points never move. A wall tip `(i, k)`
//! (ring `i`, spoke `k`) moves only outward along its rest spoke's unit direction `e_ik`:
//! `tip = P_i + V_ik + u_ik e_ik`, which keeps every section star-shaped about its control
//! point (what the detector needs) and the ring and spoke structure. The displacements `u` are
//! not free per tip: they are interpolated from a coarse grid of *wall nodes* about
//! [`WallParams::node_spacing_mm`] apart along and around the colon (node row `q` at ring
//! `(q - 1) R`, node column `c` at spoke `c B / C`, periodic), by uniform quadratic B-splines in
//! (ring index / R, spoke index C / B):
//!
//! `u_ik = sum_{a,b} beta(x - a) beta(y - b) U_ab`, `beta(f) = 3/4 - f^2` for `|f| <= 1/2`,
//! `(3/2 - |f|)^2 / 2` for `1/2 <= |f| <= 3/2`: each tip depends on the 3 x 3 nodes around its
//! nearest one, the weights sum to one, and the wall's displacement is C1 (no creases).
//!
//! A pushed wall therefore forms a smooth dimple at least two node spacings wide, as a wall
//! under a 13 mm scope does, instead of a pocket between rings with flanks and creases where
//! the contact normals turn from frame to frame and throw the scope about; and a frame solves
//! a handful of nodes, not thousands of tips. Each node has the stiffness of its own patch of
//! wall, `k = K_p A` (`A` its row's patch: its rings' mean spoke length around, `R` rings
//! along; `K_p` the pressure needed per mm of displacement), so an anal canal narrower than the
//! scope is as soft as its few millimetres of circumference; and the mass of a patch at the
//! colon's median radius, `m = rho_A A_med` (`rho_A` the wall's areal mass): a canal's nodes as
//! light as their patch, tied by the membrane to the rectum's, went deeper where the canal
//! opens out (`docs/decisions/sim.md`). Each node has:
//! - a spring to rest, `C = U`, compliance `1 / k`;
//! - a membrane coupling to its four neighbour nodes, `C = U_a - U_b`, compliance
//!   `1 / (c_m k)`, which spreads a deep bulge over neighbouring nodes;
//! - a range `0 <= U <= u_max`: the wall is never pulled inwards, and stretches at most `u_max`
//!   before what surrounds the colon stops it (what the hard push runs into);
//! - strong linear velocity damping `c` (tissue is viscous): a bulge springs back with a time
//!   constant of about `c m / k`, slowly enough for a frame's contacts to follow.
//!
//! The same XPBD substep as the rod: `V <- V / (1 + c h)`, `U <- U + V h`, one projection of
//! each constraint (multipliers reset per substep), `V <- (U - U_prev) / h`.
//!
//! **Only what is touched is simulated.** Nodes start at rest and inactive. A node becomes
//! active when a contact's tips depend on it ([`Wall::touch_tip`]) or when a neighbour is
//! displaced by more than [`WallParams::spread_mm`] ([`Wall::settle`]); it goes back to rest
//! (exactly `U = 0`) once untouched, nearly at rest, nearly still, and with no displaced
//! neighbour. Active nodes live in a compact list in activation order (deterministic), found
//! through a slot table; the state writer visits only the blocks of tips around active nodes
//! (a block: the tips whose nearest node is the same) and rewrites to rest the blocks that were
//! around them last frame.
//!
//! **What a frame carries changes little.** A tip is written again only once its displacement
//! has moved more than [`WallParams::publish_mm`] (1 um) from the one last written: a bulge
//! springing back moves thousands of tips by less than that a frame, and a client sending what
//! changed (a delta frame, a recording) would pay for every one of them. The detector sees a
//! wall within 1 um of the simulated one, fifty times finer than the detector's own depth
//! target.

use lumen_detect::Tube;
use lumen_detect::V3d;

/// Slot value: the node is inactive (at rest).
const INACTIVE: u32 = u32::MAX;
/// Neighbour value: there is no neighbour (beyond the first or the last row of nodes).
const NO_NEIGHBOUR: u32 = u32::MAX;
/// Neighbour value: the neighbour exists but is at rest (immovable this frame).
const AT_REST: u32 = u32::MAX - 1;

/// The wall's physical parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct WallParams {
    /// Spacing of the wall nodes along and around the colon, mm (default 12: a bulge under the
    /// 13 mm scope spreads over a few centimetres; with 8 mm nodes the bulges are tight, the
    /// tip plows into the rim ahead of it, and the deepest penetration of the default 3 s run
    /// on the generated colon goes from 0.25 mm to 0.86 mm).
    pub node_spacing_mm: f64,
    /// Pressure per millimetre of outward displacement, kPa/mm (default 2: 1 N on a square
    /// centimetre moves the wall 5 mm).
    pub stiffness_kpa_per_mm: f64,
    /// Stiffness of the coupling between neighbour nodes, as a multiple of a node's own
    /// spring (of the mean of the two rows' where they differ; default 2).
    pub membrane_ratio: f64,
    /// Mass per area of the wall and what moves with it, kg/m^2 (default 5: a 3 mm wall and
    /// about as much again of tissue and fluid).
    pub areal_mass_kg_m2: f64,
    /// Velocity damping, 1/s (default 4000: strongly overdamped; a bulge springs back with a
    /// time constant of about 10 ms).
    pub damping_per_s: f64,
    /// Largest outward displacement, mm (default 15).
    pub max_out_mm: f64,
    /// A neighbour of a node displaced by more than this is simulated too, mm (default 0.02).
    pub spread_mm: f64,
    /// An untouched node closer than this to rest and slower than this per millisecond goes
    /// back to rest, mm (default 0.005).
    pub rest_mm: f64,
    /// Dead band of the wall a frame carries, mm (default 0.001): a tip is written again only
    /// once its displacement differs from the one last written by more than this, so the
    /// slow tail of a bulge springing back does not rewrite thousands of tips every frame
    /// (what a delta frame or a recording pays for); the detector sees a wall within this of
    /// the simulated one. 0: every tip around an active node, every frame.
    pub publish_mm: f64,
}

impl Default for WallParams {
    fn default() -> Self {
        Self {
            node_spacing_mm: 12.0,
            stiffness_kpa_per_mm: 2.0,
            membrane_ratio: 2.0,
            areal_mass_kg_m2: 5.0,
            damping_per_s: 4000.0,
            max_out_mm: 15.0,
            spread_mm: 0.02,
            rest_mm: 0.005,
            publish_mm: 0.001,
        }
    }
}

/// One active wall node.
#[derive(Debug, Clone, Copy)]
pub struct ActiveNode {
    /// Node index `row * C + column`.
    pub node: u32,
    /// Outward displacement, mm.
    pub u: f64,
    /// Its rate, mm/s.
    pub v: f64,
    prev: f64,
    /// Spring stiffness (N/m), its row's ([`Wall::node_mass_stiffness`]).
    k: f64,
    /// Slots of the neighbours (row - 1, row + 1, column - 1, column + 1), or `AT_REST` /
    /// `NO_NEIGHBOUR`.
    nb: [u32; 4],
    touched: bool,
}

/// The nine nodes a tip is interpolated from, and their weights (summing to one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipNodes {
    pub nodes: [u32; 9],
    pub weights: [f64; 9],
}

/// Quadratic B-spline weights of the nodes at offsets -1, 0, +1 from the nearest one, for a
/// position `f` in [-1/2, 1/2] from it.
#[inline]
fn bspline3(f: f64) -> [f64; 3] {
    [0.5 * (0.5 - f) * (0.5 - f), 0.75 - f * f, 0.5 * (0.5 + f) * (0.5 + f)]
}

/// The wall of one tube.
#[derive(Debug, Clone)]
pub struct Wall {
    pub params: WallParams,
    rings: usize,
    spokes: usize,
    /// Rings per node row (`R`).
    per_row: usize,
    /// Node rows: row `q` sits at ring `(q - 1) R` (one row of padding at either end).
    rows: usize,
    /// Node columns around the colon (`C`).
    cols: usize,
    /// Block rows (tips whose nearest node row is `q = r + 1`): their rings `start..end`.
    block_rings: Vec<(u32, u32)>,
    /// Block columns (tips whose nearest node column is `c`): their spokes.
    block_spokes: Vec<Vec<u32>>,
    /// Per ring: nearest node row and the B-spline weights of rows `r - 1 ..= r + 1`.
    ring_w: Vec<(u32, [f64; 3])>,
    /// Per spoke: nearest node column and the weights of columns `c - 1 ..= c + 1`.
    spoke_w: Vec<(u32, [f64; 3])>,
    /// Unit rest direction of every tip.
    dir: Vec<[f32; 3]>,
    /// Per node row: the area of one of its nodes' patches of wall, mm^2.
    row_area: Vec<f64>,
    /// Every node's mass, a patch's at the median radius, kg.
    node_mass: f64,
    /// Rest spokes, relative to their control point.
    rest: Vec<[f32; 3]>,
    /// Control points (they never move).
    points: Vec<[f32; 3]>,
    slot: Vec<u32>,
    active: Vec<ActiveNode>,
    /// Blocks written last frame (their tips may differ from rest), and a stamp per block.
    live: Vec<u32>,
    next_live: Vec<u32>,
    stamp: Vec<u32>,
    /// Displacement of each tip as last written (0: at rest), mm.
    published: Vec<f32>,
    epoch: u32,
}

fn norm3(a: [f32; 3]) -> f64 {
    ((a[0] as f64).powi(2) + (a[1] as f64).powi(2) + (a[2] as f64).powi(2)).sqrt()
}

impl Wall {
    /// The wall of `tube`, at rest.
    pub fn new(tube: &Tube, params: WallParams) -> Self {
        let (rings, spokes) = (tube.rings(), tube.spokes);
        let spacing = {
            let p = &tube.points;
            let total: f64 = p.windows(2).map(|w| norm3([w[1][0] - w[0][0], w[1][1] - w[0][1], w[1][2] - w[0][2]])).sum();
            (total / (rings - 1).max(1) as f64).max(1e-6)
        };
        let per_row = ((params.node_spacing_mm / spacing).round() as usize).clamp(1, rings.max(2) - 1);
        let nearest_row = |i: usize| (2 * i + per_row) / (2 * per_row);
        let block_rows = nearest_row(rings - 1) + 1;
        let rows = block_rows + 2;
        let mut block_rings = vec![(u32::MAX, 0u32); block_rows];
        for i in 0..rings {
            let b = &mut block_rings[nearest_row(i)];
            b.0 = b.0.min(i as u32);
            b.1 = b.1.max(i as u32 + 1);
        }
        let mut radii: Vec<f64> = tube.radial.iter().map(|&s| norm3(s)).collect();
        radii.sort_by(f64::total_cmp);
        let r_med = radii[radii.len() / 2];
        let cols = ((std::f64::consts::TAU * r_med / params.node_spacing_mm).round() as usize).clamp(3, spokes);
        let mut block_spokes = vec![Vec::new(); cols];
        for k in 0..spokes {
            block_spokes[Self::nearest_col(k, spokes, cols).0].push(k as u32);
        }
        // Each node row's patch: its rings' mean spoke length around, `per_row` rings along (the
        // padding rows take their neighbours'): an anal canal of 3 mm in a colon of 40 mm is a
        // wall a thirteenth as wide, and as soft.
        let patch = |r: f64| per_row as f64 * spacing * std::f64::consts::TAU * r / cols as f64;
        let ring_r: Vec<f64> = (0..rings).map(|i| (0..spokes).map(|k| norm3(tube.radial[i * spokes + k])).sum::<f64>() / spokes as f64).collect();
        let mut row_area: Vec<f64> = block_rings.iter().map(|&(a, b)| patch(if a < b { ring_r[a as usize..b as usize].iter().sum::<f64>() / (b - a) as f64 } else { r_med }.max(1e-3))).collect();
        row_area.insert(0, row_area[0]);
        row_area.push(row_area[rows - 2]);
        let blocks = block_rows * cols;
        let ring_w = (0..rings)
            .map(|i| {
                let r = nearest_row(i);
                (r as u32, bspline3(i as f64 / per_row as f64 - r as f64))
            })
            .collect();
        let spoke_w = (0..spokes)
            .map(|k| {
                let (c, f) = Self::nearest_col(k, spokes, cols);
                (c as u32, bspline3(f))
            })
            .collect();
        let dir = tube
            .radial
            .iter()
            .map(|&v| {
                let l = norm3(v);
                if l > 0.0 {
                    [(v[0] as f64 / l) as f32, (v[1] as f64 / l) as f32, (v[2] as f64 / l) as f32]
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        Self {
            row_area,
            node_mass: params.areal_mass_kg_m2 * 1e-6 * patch(r_med),
            params,
            rings,
            spokes,
            per_row,
            rows,
            cols,
            block_rings,
            block_spokes,
            ring_w,
            spoke_w,
            dir,
            rest: tube.radial.clone(),
            points: tube.points.clone(),
            slot: vec![INACTIVE; rows * cols],
            active: Vec::new(),
            live: Vec::new(),
            next_live: Vec::new(),
            stamp: vec![0; blocks],
            published: vec![0.0; rings * spokes],
            epoch: 0,
        }
    }

    /// Rings (control points).
    pub fn rings(&self) -> usize {
        self.rings
    }

    /// Spokes per ring.
    pub fn spokes(&self) -> usize {
        self.spokes
    }

    /// Node grid: rings per row, rows, columns.
    pub fn grid(&self) -> (usize, usize, usize) {
        (self.per_row, self.rows, self.cols)
    }

    /// Mass (kg) and spring stiffness (N/m) of a node of row `row`: `rho_A A_med` and `K_p A`,
    /// `A` the row's patch of wall and `A_med` a patch at the colon's median radius.
    pub fn node_mass_stiffness(&self, row: usize) -> (f64, f64) {
        (self.node_mass, self.params.stiffness_kpa_per_mm * self.row_area[row.min(self.rows - 1)])
    }

    /// The active nodes, in activation order.
    pub fn active(&self) -> &[ActiveNode] {
        &self.active
    }

    /// Slot of `node` in [`Wall::active`], if active.
    pub fn slot_of(&self, node: u32) -> Option<usize> {
        let s = self.slot[node as usize];
        (s != INACTIVE).then_some(s as usize)
    }

    /// Largest outward displacement of any node, mm.
    pub fn max_displacement(&self) -> f64 {
        self.active.iter().map(|t| t.u).fold(0.0, f64::max)
    }

    /// True if every active node's state is finite.
    pub fn is_finite(&self) -> bool {
        self.active.iter().all(|t| t.u.is_finite() && t.v.is_finite())
    }

    /// Unit rest direction of tip `tip` (zero for a zero spoke).
    pub fn tip_dir(&self, tip: u32) -> V3d {
        crate::v3(self.dir[tip as usize])
    }

    /// Where tip `tip` is now: its control point, rest spoke and outward displacement, mm.
    pub fn tip(&self, tip: u32) -> V3d {
        let p = self.points[tip as usize / self.spokes];
        let s = self.rest[tip as usize];
        crate::v3(p) + crate::v3(s) + self.tip_dir(tip) * self.tip_displacement(tip)
    }

    /// Nearest node column of spoke `k` and the spoke's offset from it, in columns.
    fn nearest_col(k: usize, spokes: usize, cols: usize) -> (usize, f64) {
        let pos = (k * cols) as f64 / spokes as f64;
        let c = pos.round();
        ((c as usize) % cols, pos - c)
    }

    /// The nine nodes tip `tip` is interpolated from, and their weights.
    pub fn tip_nodes(&self, tip: u32) -> TipNodes {
        let (i, k) = (tip as usize / self.spokes, tip as usize % self.spokes);
        let (r, wr) = self.ring_w[i];
        let (c, wc) = self.spoke_w[k];
        let (r, c) = (r as usize, c as usize);
        let mut out = TipNodes { nodes: [0; 9], weights: [0.0; 9] };
        for (a, &w_row) in wr.iter().enumerate() {
            let q = r + a; // node rows r - 1 + 1 .. r + 1 + 1
            for (b, &w_col) in wc.iter().enumerate() {
                let col = (c + self.cols + b - 1) % self.cols;
                out.nodes[3 * a + b] = (q * self.cols + col) as u32;
                out.weights[3 * a + b] = w_row * w_col;
            }
        }
        out
    }

    /// Outward displacement of tip `tip` now, mm.
    pub fn tip_displacement(&self, tip: u32) -> f64 {
        let tn = self.tip_nodes(tip);
        (0..9).filter(|&q| tn.weights[q] > 0.0).map(|q| tn.weights[q] * self.slot_of(tn.nodes[q]).map_or(0.0, |s| self.active[s].u)).sum()
    }

    /// Starts a frame: no node is touched yet.
    pub fn begin_frame(&mut self) {
        for t in &mut self.active {
            t.touched = false;
        }
    }

    /// Marks the nodes tip `tip` depends on as touched by a contact this frame, activating
    /// them if needed.
    pub fn touch_tip(&mut self, tip: u32) {
        let tn = self.tip_nodes(tip);
        for q in 0..9 {
            if tn.weights[q] > 0.0 {
                let s = self.activate(tn.nodes[q]);
                self.active[s].touched = true;
            }
        }
    }

    /// Marks `node` as touched by a contact this frame, activating it if needed.
    pub fn touch_node(&mut self, node: u32) {
        let s = self.activate(node);
        self.active[s].touched = true;
    }

    fn activate(&mut self, node: u32) -> usize {
        let s = self.slot[node as usize];
        if s != INACTIVE {
            return s as usize;
        }
        let s = self.active.len();
        let k = self.node_mass_stiffness(node as usize / self.cols).1;
        self.active.push(ActiveNode { node, u: 0.0, v: 0.0, prev: 0.0, k, nb: [AT_REST; 4], touched: false });
        self.slot[node as usize] = s as u32;
        s
    }

    fn neighbours(&self, node: u32) -> [u32; 4] {
        let c = self.cols as u32;
        let (r, k) = (node / c, node % c);
        [if r > 0 { node - c } else { NO_NEIGHBOUR }, if (r as usize) + 1 < self.rows { node + c } else { NO_NEIGHBOUR }, r * c + (k + c - 1) % c, r * c + (k + 1) % c]
    }

    /// Between the contacts' [`Wall::touch_tip`] and the frame's substeps: activates the
    /// neighbours of displaced nodes, releases nodes back at rest (`dt` the frame's length, s),
    /// and links every active node to its neighbours' slots. Returns how many were released.
    pub fn settle(&mut self, dt: f64) -> usize {
        let spread = self.params.spread_mm;
        let n = self.active.len();
        for s in 0..n {
            if self.active[s].u.abs() > spread {
                for nb in self.neighbours(self.active[s].node) {
                    if nb != NO_NEIGHBOUR {
                        self.activate(nb);
                    }
                }
            }
        }
        let rest = self.params.rest_mm;
        let mut released = 0;
        let mut s = 0;
        while s < self.active.len() {
            let t = self.active[s];
            let quiet = !t.touched && t.u.abs() < rest && (t.v * dt).abs() < rest;
            let calm = quiet && self.neighbours(t.node).iter().all(|&nb| nb == NO_NEIGHBOUR || self.slot[nb as usize] == INACTIVE || self.active[self.slot[nb as usize] as usize].u.abs() <= spread);
            if calm {
                self.slot[t.node as usize] = INACTIVE;
                self.active.swap_remove(s);
                if s < self.active.len() {
                    let moved = self.active[s].node;
                    self.slot[moved as usize] = s as u32;
                }
                released += 1;
            } else {
                s += 1;
            }
        }
        for s in 0..self.active.len() {
            let nbs = self.neighbours(self.active[s].node);
            let mut link = [NO_NEIGHBOUR; 4];
            for (e, &nb) in nbs.iter().enumerate() {
                if nb != NO_NEIGHBOUR {
                    let sl = self.slot[nb as usize];
                    link[e] = if sl == INACTIVE { AT_REST } else { sl };
                }
            }
            self.active[s].nb = link;
        }
        released
    }

    /// Starts a substep of length `h`, s.
    pub fn predict(&mut self, h: f64) {
        let damp = 1.0 / (1.0 + self.params.damping_per_s * h);
        for t in &mut self.active {
            t.prev = t.u;
            t.v *= damp;
            t.u += t.v * h;
        }
    }

    /// Inverse mass of a node, 1/kg.
    pub fn node_inv_mass(&self) -> f64 {
        1.0 / self.node_mass
    }

    /// Projects the springs, the membrane and the range once.
    pub fn solve(&mut self, h: f64) {
        let w = 1.0 / self.node_mass;
        let ih2 = 1.0 / (h * h);
        let ratio = self.params.membrane_ratio;
        // A membrane edge between two rows: the mean of their stiffnesses.
        let a_edge = |k: f64| ih2 / (ratio * k).max(1e-12);
        let hi = self.params.max_out_mm;
        for s in 0..self.active.len() {
            let ActiveNode { u, k, nb, .. } = self.active[s];
            self.active[s].u = u - u * (w / (w + ih2 / k));
            for &o in &nb {
                if o == NO_NEIGHBOUR {
                    continue;
                }
                if o == AT_REST {
                    let ua = self.active[s].u;
                    self.active[s].u = ua - ua * (w / (w + a_edge(k)));
                } else if (o as usize) > s {
                    let b = self.active[o as usize];
                    let ua = self.active[s].u;
                    let dl = -(ua - b.u) / (2.0 * w + a_edge(0.5 * (k + b.k)));
                    self.active[s].u = ua + w * dl;
                    self.active[o as usize].u = b.u - w * dl;
                }
            }
        }
        for t in &mut self.active {
            t.u = t.u.clamp(0.0, hi);
        }
    }

    /// Ends a substep: rates from the displacements' change.
    pub fn update_velocity(&mut self, h: f64) {
        let inv_h = 1.0 / h;
        for t in &mut self.active {
            t.v = (t.u - t.prev) * inv_h;
        }
    }

    /// Moves active node `slot` by `du`, within its range; returns the move made.
    #[inline]
    pub fn push(&mut self, slot: usize, du: f64) -> f64 {
        let t = &mut self.active[slot];
        let u = (t.u + du).clamp(0.0, self.params.max_out_mm);
        let done = u - t.u;
        t.u = u;
        done
    }

    /// Displacement of active node `slot`, mm.
    #[inline]
    pub fn node_u(&self, slot: usize) -> f64 {
        self.active[slot].u
    }

    /// Clamps every node's rate to `max` (mm/s) and its inward move in the substep of length
    /// `h` (s) to `max * h`: a bulge springing back by projection closes on the scope no faster
    /// than its rate may. Outward moves (the wall giving way) are not cut. Returns how many
    /// nodes were slowed.
    pub fn limit_speed(&mut self, max: f64, h: f64) -> u32 {
        let reach = max * h;
        let mut n = 0;
        for t in &mut self.active {
            let mut hit = false;
            if t.u < t.prev - reach {
                t.u = t.prev - reach;
                hit = true;
            }
            if t.v.abs() > max {
                t.v = t.v.clamp(-max, max);
                hit = true;
            }
            n += hit as u32;
        }
        n
    }

    /// Sets every node's rate to zero.
    pub fn zero_velocities(&mut self) {
        for t in &mut self.active {
            t.v = 0.0;
        }
    }

    /// Rate of active node `slot`, mm/s.
    #[inline]
    pub fn node_v(&self, slot: usize) -> f64 {
        self.active[slot].v
    }

    /// Changes the rate of active node `slot` by `dv`, mm/s.
    #[inline]
    pub fn add_node_v(&mut self, slot: usize, dv: f64) {
        self.active[slot].v += dv;
    }

    /// Whether active node `slot` can still move outwards.
    #[inline]
    pub fn can_move_out(&self, slot: usize) -> bool {
        self.active[slot].u < self.params.max_out_mm
    }

    /// Calls `f(tip, spoke)` for every tip whose spoke may differ from what was written last
    /// time: the tips of the blocks around active nodes (their current spokes, each unless it
    /// is within [`WallParams::publish_mm`] of the one last written) and, unless `full` (the
    /// caller rewrites the whole rest colon itself), the tips of blocks that were around active
    /// nodes last time and are not now (their rest spokes). With `full`, every tip around an
    /// active node is written, as last written where it is within the dead band: the frame is
    /// the same whether the caller kept its buffer or not.
    pub fn write_spokes(&mut self, full: bool, mut f: impl FnMut(u32, [f32; 3])) {
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.epoch = 1;
        }
        let (cols, block_rows) = (self.cols, self.block_rings.len());
        let band = self.params.publish_mm as f32;
        self.next_live.clear();
        for t in &self.active {
            let (q, c) = (t.node as usize / cols, t.node as usize % cols);
            // Node row q is used by block rows q - 2 ..= q.
            for r in q.saturating_sub(2)..=q {
                if r >= block_rows {
                    continue;
                }
                for dc in [cols - 1, 0, 1] {
                    let block = r * cols + (c + dc) % cols;
                    if self.stamp[block] != self.epoch {
                        self.stamp[block] = self.epoch;
                        self.next_live.push(block as u32);
                    }
                }
            }
        }
        // Blocks no longer around an active node go back to rest (written by the caller when
        // `full`).
        for &block in &self.live {
            if self.stamp[block as usize] != self.epoch {
                let (rings, c) = self.block_of(block);
                for i in rings {
                    for &k in &self.block_spokes[c] {
                        let tip = i * self.spokes as u32 + k;
                        self.published[tip as usize] = 0.0;
                        if !full {
                            f(tip, self.rest[tip as usize]);
                        }
                    }
                }
            }
        }
        for &block in &self.next_live {
            let (r, c) = (block as usize / cols, block as usize % cols);
            let mut nodes = [0.0; 9];
            for a in 0..3 {
                for b in 0..3 {
                    let node = (r + a) * cols + (c + cols + b - 1) % cols;
                    nodes[3 * a + b] = self.slot_of(node as u32).map_or(0.0, |s| self.active[s].u);
                }
            }
            let any = nodes.iter().any(|&u| u != 0.0);
            let (i0, i1) = self.block_rings[r];
            for i in i0..i1 {
                let wr = self.ring_w[i as usize].1;
                // Row-weighted node values: then one 3-term sum per tip.
                let row = [wr[0] * nodes[0] + wr[1] * nodes[3] + wr[2] * nodes[6], wr[0] * nodes[1] + wr[1] * nodes[4] + wr[2] * nodes[7], wr[0] * nodes[2] + wr[1] * nodes[5] + wr[2] * nodes[8]];
                for &k in &self.block_spokes[c] {
                    let tip = i * self.spokes as u32 + k;
                    let rest = self.rest[tip as usize];
                    if !any {
                        self.published[tip as usize] = 0.0;
                        f(tip, rest);
                        continue;
                    }
                    let wc = self.spoke_w[k as usize].1;
                    let u = (wc[0] * row[0] + wc[1] * row[1] + wc[2] * row[2]) as f32;
                    let last = self.published[tip as usize];
                    let u = if u != 0.0 && (u - last).abs() <= band {
                        if !full {
                            continue;
                        }
                        last
                    } else {
                        u
                    };
                    self.published[tip as usize] = u;
                    if u == 0.0 {
                        f(tip, rest);
                    } else {
                        let d = self.dir[tip as usize];
                        f(tip, [rest[0] + d[0] * u, rest[1] + d[1] * u, rest[2] + d[2] * u]);
                    }
                }
            }
        }
        std::mem::swap(&mut self.live, &mut self.next_live);
    }

    /// The rings of block `block` and its node column.
    fn block_of(&self, block: u32) -> (std::ops::Range<u32>, usize) {
        let (r, c) = (block as usize / self.cols, block as usize % self.cols);
        let (i0, i1) = self.block_rings[r];
        (i0..i1, c)
    }

    #[cfg(test)]
    fn for_block_tips(&self, block: u32, mut f: impl FnMut(u32)) {
        let (rings, c) = self.block_of(block);
        for i in rings {
            for &k in &self.block_spokes[c] {
                f(i * self.spokes as u32 + k);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tube() -> Tube {
        let b = 32;
        let ring = |_: usize| {
            (0..b).map(|k| {
                let a = k as f32 * std::f32::consts::TAU / b as f32;
                [0.0, 25.0 * a.cos(), 25.0 * a.sin()]
            })
        };
        Tube::new((0..100).map(|i| [i as f32 * 1.2, 0.0, 0.0]).collect(), (0..100).flat_map(ring).collect(), b).unwrap()
    }

    /// Starts a frame with a contact at `tip` and moves the node it weighs most on outward by
    /// `du` mm; returns that node's slot.
    fn press(w: &mut Wall, tip: u32, du: f64) -> usize {
        w.begin_frame();
        w.touch_tip(tip);
        w.settle(1e-3);
        let s = w.slot_of(w.tip_nodes(tip).nodes[4]).unwrap();
        w.push(s, du);
        s
    }

    /// One frame's 16 substeps of 1/16 ms: predict, project, rates.
    fn substeps(w: &mut Wall) {
        let h = 1e-3 / 16.0;
        for _ in 0..16 {
            w.predict(h);
            w.solve(h);
            w.update_velocity(h);
        }
    }

    #[test]
    fn blocks_cover_every_tip_once_and_weights_sum_to_one() {
        let t = tube();
        let w = Wall::new(&t, WallParams::default());
        let (per_row, rows, cols) = w.grid();
        assert_eq!(per_row, 10); // 12 mm / 1.2 mm
        assert_eq!(cols, 13); // 2 pi 25 / 12
        assert_eq!(rows, (2 * 99 + 10) / 20 + 3);
        let mut seen = vec![0; t.radial.len()];
        for block in 0..((rows - 2) * cols) as u32 {
            w.for_block_tips(block, |tip| seen[tip as usize] += 1);
        }
        assert!(seen.iter().all(|&n| n == 1));
        for tip in 0..t.radial.len() as u32 {
            let tn = w.tip_nodes(tip);
            assert!((tn.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(tn.weights.iter().all(|&x| x >= 0.0));
        }
    }

    #[test]
    fn a_pushed_node_springs_back_and_the_wall_is_rewritten_to_rest() {
        let t = tube();
        let mut w = Wall::new(&t, WallParams::default());
        let tip = 50 * 32 + 3;
        press(&mut w, tip, 5.0);
        let mut state: Vec<[f32; 3]> = t.radial.clone();
        w.write_spokes(false, |tip, sp| state[tip as usize] = sp);
        assert!(w.tip_displacement(tip) > 1.0);
        let mut frames = 0;
        while !w.active().is_empty() {
            w.begin_frame();
            w.settle(1e-3);
            substeps(&mut w);
            w.write_spokes(false, |tip, sp| state[tip as usize] = sp);
            frames += 1;
            assert!(frames < 2000, "never released");
        }
        w.write_spokes(false, |tip, sp| state[tip as usize] = sp);
        assert_eq!(state, t.radial);
    }

    /// A canal of 3 mm in a colon of 30 mm: its nodes are a tenth as stiff (their patch of wall
    /// a tenth as wide) and as heavy as the others, so the same push opens it further and it
    /// springs back more slowly.
    #[test]
    fn a_narrow_canal_is_a_softer_wall() {
        let b = 32;
        let radius = |i: usize| if i < 30 { 3.0 } else { 30.0 };
        let ring = |i: usize| {
            (0..b).map(move |k| {
                let a = k as f32 * std::f32::consts::TAU / b as f32;
                [0.0, radius(i) * a.cos(), radius(i) * a.sin()]
            })
        };
        let t = Tube::new((0..100).map(|i| [i as f32 * 1.2, 0.0, 0.0]).collect(), (0..100).flat_map(ring).collect(), b).unwrap();
        let mut w = Wall::new(&t, WallParams::default());
        let (per_row, _, _) = w.grid();
        let row = |ring: usize| (2 * ring + per_row) / (2 * per_row) + 1;
        let ((m_canal, k_canal), (m_wide, k_wide)) = (w.node_mass_stiffness(row(12)), w.node_mass_stiffness(row(70)));
        assert_eq!(m_canal, m_wide);
        assert!((k_canal / k_wide - 0.1).abs() < 1e-9, "stiffness {k_canal} against {k_wide}");
        // The same displacement, one frame later: the canal keeps more of it.
        let (canal, wide) = (12 * 32 + 3, 70 * 32 + 3);
        let (sc, sw) = (press(&mut w, canal, 3.0), press(&mut w, wide, 3.0));
        let (uc, uw) = (w.node_u(sc), w.node_u(sw));
        assert!((uc - uw).abs() < 1e-12, "pushed alike: {uc} {uw}");
        substeps(&mut w);
        assert!(w.node_u(sc) > w.node_u(sw) + 0.1, "after a frame: canal {} wide {}", w.node_u(sc), w.node_u(sw));
    }

    /// A bulge at the 15 mm limit springs back by projection faster than its rate may move it;
    /// the speed limit cuts each substep's inward move to `max * h` (1000 mm/s: 1/16 mm), so a
    /// frame closes it on the scope by at most 1 mm, and leaves a wall giving way uncut.
    #[test]
    fn the_speed_limit_bounds_a_bulge_springing_back() {
        let t = tube();
        let (max, h) = (1000.0, 1e-3 / 16.0);
        let run = |limit: bool| {
            let mut w = Wall::new(&t, WallParams::default());
            let s = press(&mut w, 50 * 32 + 3, 15.0);
            let before = w.node_u(s);
            let mut slowed = 0;
            for _ in 0..16 {
                let was = w.node_u(s);
                w.predict(h);
                w.solve(h);
                w.update_velocity(h);
                if limit {
                    slowed += w.limit_speed(max, h);
                    assert!(w.node_u(s) >= was - max * h - 1e-12, "{} -> {}", was, w.node_u(s));
                }
            }
            (before - w.node_u(s), slowed)
        };
        let (free, _) = run(false);
        let (limited, slowed) = run(true);
        assert!(free > 1.2, "without the limit the bulge springs back {free:.3} mm in a frame");
        assert!(limited <= 1.0 + 1e-9 && limited > 0.9, "with it, {limited:.3} mm");
        assert!(slowed >= 16);
        // Pushed outward by a contact, a node moves its whole push within the substep.
        let mut w = Wall::new(&t, WallParams::default());
        let s = press(&mut w, 50 * 32 + 3, 0.0);
        w.predict(h);
        assert_eq!(w.push(s, 2.0), 2.0);
        w.update_velocity(h);
        w.limit_speed(max, h);
        assert_eq!(w.node_u(s), 2.0);
    }

    #[test]
    fn a_tip_is_rewritten_only_once_it_moves_past_the_dead_band() {
        let t = tube();
        let mut w = Wall::new(&t, WallParams { publish_mm: 0.001, ..WallParams::default() });
        let tip = 50 * 32 + 3;
        let s = press(&mut w, tip, 1.0);
        let mut kept: Vec<[f32; 3]> = t.radial.clone();
        w.write_spokes(false, |tip, sp| kept[tip as usize] = sp);
        let written = |w: &mut Wall, full: bool, out: &mut Vec<[f32; 3]>| {
            let mut n = 0;
            w.write_spokes(full, |tip, sp| {
                n += (out[tip as usize] != sp) as usize;
                out[tip as usize] = sp;
            });
            n
        };
        // 0.5 um at the node: no tip moves by more than the band.
        w.push(s, 0.0005);
        assert_eq!(written(&mut w, false, &mut kept), 0);
        // A buffer rewritten whole gets the same frame: the tips as last written.
        let mut whole: Vec<[f32; 3]> = t.radial.clone();
        w.write_spokes(true, |tip, sp| whole[tip as usize] = sp);
        assert_eq!(whole, kept);
        // Another 3 um: 3.5 um at the node since the tips were written; the tips it weighs most
        // on (up to (3/4)^2) move past the band, the others stay within it of the wall.
        w.push(s, 0.003);
        let moved = written(&mut w, false, &mut kept);
        assert!(moved > 0);
        let u = w.tip_displacement(tip) as f32;
        let d = w.tip_dir(tip);
        let exact = [t.radial[tip as usize][0] + d.x as f32 * u, t.radial[tip as usize][1] + d.y as f32 * u, t.radial[tip as usize][2] + d.z as f32 * u];
        assert!((0..3).all(|j| (kept[tip as usize][j] - exact[j]).abs() <= 1e-3), "{:?} against {exact:?}", kept[tip as usize]);
    }

    #[test]
    fn a_kept_buffer_and_one_rewritten_whole_get_the_same_frames() {
        // Two walls in step: one writes over the buffer it wrote last frame, the other over the
        // rest colon every frame (a loaned buffer). A bulge springs back to rest, its blocks
        // leave the live set, and a second push brings them back.
        let t = tube();
        let (mut a, mut b) = (Wall::new(&t, WallParams::default()), Wall::new(&t, WallParams::default()));
        let mut kept: Vec<[f32; 3]> = t.radial.clone();
        let tip = 50 * 32 + 3;
        let mut left_rest = false;
        for frame in 0..400 {
            for w in [&mut a, &mut b] {
                if frame == 0 || frame == 300 {
                    press(w, tip, 3.0);
                } else {
                    w.begin_frame();
                    w.settle(1e-3);
                }
                substeps(w);
            }
            left_rest |= a.active().is_empty();
            a.write_spokes(false, |tip, sp| kept[tip as usize] = sp);
            let mut whole: Vec<[f32; 3]> = t.radial.clone();
            b.write_spokes(true, |tip, sp| whole[tip as usize] = sp);
            assert_eq!(kept, whole, "frame {frame}");
        }
        assert!(left_rest, "the bulge never went back to rest");
    }
}
