//! The `/lumen/scene` channel of a recording: Foxglove's `foxglove.SceneUpdate` as JSON, so a
//! `run.mcap` opens in Foxglove's or Lichtblick's 3D panel with no plugin (see
//! `service/README.md`, "Recording format").
//!
//! [`SCENE_UPDATE_SCHEMA`] is Foxglove's own published JSON Schema, unchanged:
//! `schemas/jsonschema/SceneUpdate.json` of github.com/foxglove/foxglove-sdk at commit
//! `ca8a1ced73b2737d03e2e3f282b57359a1a4cb72` (the file last changed in `9ed45b16aac7`),
//! MIT licence, Copyright (c) Foxglove Technologies Inc; stored here as `SceneUpdate.json`.
//!
//! [`SceneWriter`] turns what the recorder sees into updates, every entity in frame
//! [`FRAME_ID`] with lifetime 0 (until replaced: an entity replaces the one of the same id):
//!
//! Updates are for a person watching: at most [`SCENE_EVERY_NS`] apart in log time (60 a
//! second, a display's rate), the frames between are left out of this channel (never out of
//! `/lumen/frames` and `/lumen/contacts`): an unpaced physics logs 1,000 frames a second, and
//! the arrows of every reply would more than double the file.
//!
//! - per frame ([`SceneWriter::frame`]): each rod body (the scope) as a `LINE_STRIP` through
//!   its points, as thick as its diameter (id `rod/<name>`); and each tube body (the colon) as
//!   triangle lists (id `tube/<name>`): its wall points, one row per ring (the ring's control
//!   point plus each radial vector, [`WallGrid`] at [`WALL_STEPS`] row per segment), two
//!   triangles per quad between consecutive rows and spokes (around, the last spoke to the
//!   first), by `indices`, one list per [`WALL_BLOCK_ROWS`] rows of quads (a list's last row of
//!   points is the next one's first). The colon is large (1,250 rings x 32 spokes: 40,000
//!   points and 240,000 indices, about 2.5 MB of JSON), so it goes with the first frame and then with the
//!   first frame at least [`COLON_EVERY_NS`] (1 s) of log time after the last one that had it
//!   (or whose log time is earlier, a client that restarted its clock). Log time, not a frame
//!   count: the cost is bounded per second of recording whatever the physics rate (60 Hz or
//!   unpaced), and a viewer waits at most a second of log time for the wall's deformation, or
//!   for the colon after a seek (a player may then start from the newest update before the
//!   seek point, which need not carry it). The frame and the reply are two updates at the same
//!   log time (the recorder sees them one after the other, and a reply may never come);
//! - per reply ([`SceneWriter::contacts`]): the reply's contacts as arrows (id `contacts`, one
//!   entity replaced by every reply, empty when there are none), each from the contact's
//!   `point_b` (the wall) along its `normal`: magenta for a sample outside the wall
//!   ([`FLAG_OUTSIDE`]), else yellow at depth 0 to red at [`RED_DEPTH`] (2 mm) and deeper.
//!
//! A drawn point (the scope's, the colon's) is rounded to a power of ten at or below
//! [`DRAWN_PRECISION`] of its body's largest coordinate (1 um for a colon in mm): shorter
//! numbers, a fifth fewer of the colon's bytes, nothing a display could show. The frames and replies are
//! recorded exactly.
//!
//! A message never holds a non-finite number (JSON cannot): a NaN or infinite coordinate is
//! written 0, and a contact whose point or normal is not finite has no arrow. A frame whose
//! float count does not match the spec has no update.

use lumen_detect::wall::WallGrid;
use lumen_proto::contact::FLAG_OUTSIDE;
use lumen_proto::{Contact, SceneSpec, Shape};
use serde::ser::{SerializeSeq, SerializeStruct, Serializer};
use serde::Serialize;

/// Foxglove's JSON Schema of `foxglove.SceneUpdate` (see the module doc for its source).
pub const SCENE_UPDATE_SCHEMA: &str = include_str!("SceneUpdate.json");
/// The schema's name, as Foxglove looks it up.
pub const SCENE_UPDATE: &str = "foxglove.SceneUpdate";
/// The frame every entity is in (Foxglove's 3D panel takes the only frame as its display frame).
pub const FRAME_ID: &str = "lumen";
/// Log time at least between two updates of the scope, and between two of the contacts, ns
/// (60 a second).
pub const SCENE_EVERY_NS: u64 = 1_000_000_000 / 60;
/// Log time at least between two updates carrying the colon (tube bodies), ns.
pub const COLON_EVERY_NS: u64 = 1_000_000_000;
/// A drawn point's coordinates are rounded to at most this fraction of the largest coordinate
/// of its body (see `step_of`): 1 um for a colon whose coordinates reach 100 to 1,000 mm.
pub const DRAWN_PRECISION: f64 = 1e-5;
/// Quad rows of a tube's wall per triangle list (see `WallBlocks`).
pub const WALL_BLOCK_ROWS: usize = 16;
/// Rows of the drawn wall per ring segment (1: the rings themselves).
pub const WALL_STEPS: usize = 1;
/// Depth (scene units: mm for the colonoscopy) at which a contact's arrow is fully red.
pub const RED_DEPTH: f32 = 2.0;
/// Id of the contacts entity.
pub const CONTACTS_ID: &str = "contacts";

const COLON_COLOR: Color = Color { r: 0.85, g: 0.45, b: 0.45, a: 0.35 };
const SCOPE_COLOR: Color = Color { r: 0.2, g: 0.55, b: 1.0, a: 1.0 };
const OUTSIDE_COLOR: Color = Color { r: 1.0, g: 0.0, b: 1.0, a: 1.0 };

/// One body of the spec, where its floats are.
#[derive(Debug, Clone)]
enum Body {
    Tube { id: String, offset: usize, rings: usize, spokes: usize },
    Rod { id: String, offset: usize, points: usize, diameter: f32 },
}

/// Builds the `/lumen/scene` messages of one recording (see the module doc). It keeps its
/// buffers: after the first frames an update allocates nothing but the output's growth.
#[derive(Debug)]
pub struct SceneWriter {
    bodies: Vec<Body>,
    floats: usize,
    grid: WallGrid,
    /// Radius of each body (rods; 1 for tubes), for the size of the arrows.
    radius: Vec<f32>,
    /// Log time of the last update that carried the colon.
    last_colon: Option<u64>,
    /// Log times of the last frame update and of the last contacts update.
    last_frame: Option<u64>,
    last_contacts: Option<u64>,
    /// Wall points of the tubes of the current update, all tubes one after another.
    wall: Vec<[f32; 3]>,
    arrows: Vec<Arrow>,
}

impl SceneWriter {
    /// A writer for the bodies of `spec`.
    pub fn new(spec: &SceneSpec) -> Self {
        let mut offset = 0;
        let mut bodies = Vec::with_capacity(spec.bodies.len());
        let mut radius = Vec::with_capacity(spec.bodies.len());
        for b in &spec.bodies {
            match &b.shape {
                Shape::Tube { rings, spokes } => {
                    bodies.push(Body::Tube { id: format!("tube/{}", b.name), offset, rings: *rings, spokes: *spokes });
                    radius.push(1.0);
                }
                Shape::Rod { points, radius: r } => {
                    let mean = if r.is_empty() { 1.0 } else { r.iter().sum::<f32>() / r.len() as f32 };
                    let mean = if mean.is_finite() && mean > 0.0 { mean } else { 1.0 };
                    bodies.push(Body::Rod { id: format!("rod/{}", b.name), offset, points: *points, diameter: 2.0 * mean });
                    radius.push(mean);
                }
            }
            offset += b.floats();
        }
        Self { bodies, floats: offset, grid: WallGrid { steps: WALL_STEPS, alpha: spec.alpha }, radius, last_colon: None, last_frame: None, last_contacts: None, wall: Vec::new(), arrows: Vec::new() }
    }

    /// Appends to `out` the update of a frame logged at `log_time` (ns) with floats `state`:
    /// the rods, and the tubes when they are due (see the module doc). Returns `None` (and
    /// appends nothing) for a state of the wrong length or a frame within [`SCENE_EVERY_NS`]
    /// of the last update, else whether the tubes went with it.
    pub fn frame(&mut self, log_time: u64, state: &[f32], out: &mut Vec<u8>) -> Option<bool> {
        if state.len() != self.floats || !due(&mut self.last_frame, log_time, SCENE_EVERY_NS) {
            return None;
        }
        let has_tube = self.bodies.iter().any(|b| matches!(b, Body::Tube { .. }));
        let colon = has_tube && due(&mut self.last_colon, log_time, COLON_EVERY_NS);
        self.wall.clear();
        if colon {
            for b in &self.bodies {
                if let Body::Tube { offset, rings, spokes, .. } = *b {
                    let data = &state[offset..offset + rings * (spokes + 1) * 3];
                    self.grid.append(data, rings, spokes, 0..rings.saturating_sub(1), &mut self.wall);
                }
            }
        }
        let update = FrameUpdate { time: Time::of(log_time), bodies: &self.bodies, state, grid: self.grid, wall: colon.then_some(&self.wall[..]) };
        serde_json::to_writer(&mut *out, &update).expect("a scene update serialises to memory");
        Some(colon)
    }

    /// Appends to `out` the update of a reply logged at `log_time`, its contacts as arrows,
    /// unless it comes within [`SCENE_EVERY_NS`] of the last; returns whether it did.
    pub fn contacts(&mut self, log_time: u64, contacts: &[Contact], out: &mut Vec<u8>) -> bool {
        if !due(&mut self.last_contacts, log_time, SCENE_EVERY_NS) {
            return false;
        }
        self.arrows.clear();
        for c in contacts {
            let r = self.radius.get(c.body_a as usize).copied().unwrap_or(1.0);
            if let Some(a) = Arrow::of(c, r) {
                self.arrows.push(a);
            }
        }
        let time = Time::of(log_time);
        let entity = Entity { time, id: CONTACTS_ID, arrows: &self.arrows, lines: &[], triangles: None };
        let update = Update { entities: std::slice::from_ref(&entity) };
        serde_json::to_writer(&mut *out, &update).expect("a scene update serialises to memory");
        true
    }
}

/// Whether an update at `log_time` is due, `every` ns after the `last` one (or at once when
/// the clock went back, a client that restarted it); if so, `last` becomes `log_time`.
fn due(last: &mut Option<u64>, log_time: u64, every: u64) -> bool {
    let yes = last.is_none_or(|l| log_time < l || log_time - l >= every);
    if yes {
        *last = Some(log_time);
    }
    yes
}

/// `v`, or 0 where it is not finite.
fn fin(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// `foxglove.Time` (`time` in the schema).
#[derive(Debug, Clone, Copy, Serialize)]
struct Time {
    sec: u64,
    nsec: u32,
}

impl Time {
    fn of(ns: u64) -> Self {
        Self { sec: ns / 1_000_000_000, nsec: (ns % 1_000_000_000) as u32 }
    }
    const ZERO: Time = Time { sec: 0, nsec: 0 };
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Color {
    r: f32,
    g: f32,
    b: f32,
    a: f32,
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Vector3 {
    x: f32,
    y: f32,
    z: f32,
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Quaternion {
    x: f32,
    y: f32,
    z: f32,
    w: f32,
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Pose {
    position: Vector3,
    orientation: Quaternion,
}

impl Pose {
    const IDENTITY: Pose = Pose { position: Vector3 { x: 0.0, y: 0.0, z: 0.0 }, orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 } };
}

/// An empty JSON array (`[]`), for the fields the schema requires and Lumen leaves empty.
struct Empty;

impl Serialize for Empty {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_seq(Some(0))?.end()
    }
}

/// Points given as flat `x y z` floats, written as `foxglove.Point3` objects (non-finite: 0),
/// each coordinate rounded to a multiple of `step`.
struct Points<'a> {
    xyz: &'a [f32],
    step: f64,
}

impl<'a> Points<'a> {
    /// The points `xyz`, rounded to [`step_of`] them.
    fn new(xyz: &'a [f32]) -> Self {
        Self { xyz, step: step_of(xyz) }
    }
}

/// The power of ten a body's coordinates `xyz` are drawn to: the largest at or below
/// [`DRAWN_PRECISION`] of the largest finite coordinate's magnitude (a colon in mm: 0.001). A
/// drawing needs no more, and shorter numbers make the colon's updates a fifth smaller.
fn step_of(xyz: &[f32]) -> f64 {
    let most = xyz.iter().filter(|v| v.is_finite()).fold(0f32, |m, v| m.max(v.abs()));
    if most == 0.0 {
        return 1.0;
    }
    10f64.powi((most as f64 * DRAWN_PRECISION).log10().floor() as i32)
}

/// `v` rounded to a multiple of `step`, as the float nearest that decimal (which JSON then
/// writes with no more digits than the decimal has); 0 where `v` is not finite.
fn rounded(v: f32, step: f64) -> f32 {
    let r = ((fin(v) as f64 / step).round() * step) as f32;
    fin(r)
}

impl Serialize for Points<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let step = self.step;
        s.collect_seq(self.xyz.chunks_exact(3).map(|p| Vector3 { x: rounded(p[0], step), y: rounded(p[1], step), z: rounded(p[2], step) }))
    }
}

/// The triangle indices of a wall grid of `rows` rows of `spokes` points: per quad (row `r`,
/// spoke `k`) the triangles `(r,k) (r+1,k) (r+1,k+1)` and `(r,k) (r+1,k+1) (r,k+1)`, spokes
/// around (`k + 1` of the last is 0), point `(r, k)` at `r * spokes + k`.
#[derive(Debug, Clone, Copy)]
struct QuadIndices {
    rows: usize,
    spokes: usize,
}

impl Serialize for QuadIndices {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let n = self.spokes;
        let quads = (0..self.rows.saturating_sub(1)).flat_map(move |r| (0..n).map(move |k| (r, k)));
        s.collect_seq(quads.flat_map(move |(r, k)| {
            let k1 = (k + 1) % n;
            let (p, q, pn, qn) = (r * n + k, (r + 1) * n + k, r * n + k1, (r + 1) * n + k1);
            [p, q, qn, p, qn, pn]
        }))
    }
}

/// `foxglove.LinePrimitive`, a `LINE_STRIP`.
struct Line<'a> {
    points: Points<'a>,
    thickness: f32,
    color: Color,
}

impl Serialize for Line<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("LinePrimitive", 8)?;
        st.serialize_field("type", &0u8)?; // LINE_STRIP
        st.serialize_field("pose", &Pose::IDENTITY)?;
        st.serialize_field("thickness", &fin(self.thickness))?;
        st.serialize_field("scale_invariant", &false)?;
        st.serialize_field("points", &self.points)?;
        st.serialize_field("color", &self.color)?;
        st.serialize_field("colors", &Empty)?;
        st.serialize_field("indices", &Empty)?;
        st.end()
    }
}

/// One tube's wall as triangle lists of [`WALL_BLOCK_ROWS`] quad rows each (the last may have
/// fewer): `rows` rows of `spokes` points, flat, drawn to `step`. A block's points are its
/// rows and the first of the next block's (written twice), its indices count from its own
/// first point: the same numbers in every whole block, which the chunks' zstd then stores
/// once instead of 240,000 distinct numbers a colon.
struct WallBlocks<'a> {
    xyz: &'a [f32],
    rows: usize,
    spokes: usize,
    step: f64,
}

impl Serialize for WallBlocks<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let quads = self.rows.saturating_sub(1);
        let row = 3 * self.spokes;
        s.collect_seq((0..quads.div_ceil(WALL_BLOCK_ROWS)).map(|b| {
            let (first, last) = (b * WALL_BLOCK_ROWS, ((b + 1) * WALL_BLOCK_ROWS).min(quads));
            let points = Points { xyz: &self.xyz[first * row..(last + 1) * row], step: self.step };
            Triangles { points, indices: QuadIndices { rows: last - first + 1, spokes: self.spokes } }
        }))
    }
}

/// `foxglove.TriangleListPrimitive`: a block of a tube's wall.
struct Triangles<'a> {
    points: Points<'a>,
    indices: QuadIndices,
}

impl Serialize for Triangles<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("TriangleListPrimitive", 5)?;
        st.serialize_field("pose", &Pose::IDENTITY)?;
        st.serialize_field("points", &self.points)?;
        st.serialize_field("color", &COLON_COLOR)?;
        st.serialize_field("colors", &Empty)?;
        st.serialize_field("indices", &self.indices)?;
        st.end()
    }
}

/// `foxglove.ArrowPrimitive`: a contact.
#[derive(Debug, Clone, Copy, Serialize)]
struct Arrow {
    pose: Pose,
    shaft_length: f32,
    shaft_diameter: f32,
    head_length: f32,
    head_diameter: f32,
    color: Color,
}

impl Arrow {
    /// The arrow of `c` (sized by the rod's radius `r`), or `None` when its point or normal is
    /// not finite or the normal is zero.
    fn of(c: &Contact, r: f32) -> Option<Self> {
        let [x, y, z] = c.point_b;
        let [nx, ny, nz] = c.normal;
        if ![x, y, z, nx, ny, nz].iter().all(|v| v.is_finite()) {
            return None;
        }
        let len = (nx * nx + ny * ny + nz * nz).sqrt();
        if !(len > 1e-12 && len.is_finite()) {
            return None;
        }
        let (nx, ny, nz) = (nx / len, ny / len, nz / len);
        // The rotation taking +x (an arrow's identity direction) to the normal.
        let orientation = if 1.0 + nx < 1e-6 {
            Quaternion { x: 0.0, y: 0.0, z: 1.0, w: 0.0 }
        } else {
            let (w, qy, qz) = (1.0 + nx, -nz, ny);
            let n = (w * w + qy * qy + qz * qz).sqrt();
            Quaternion { x: 0.0, y: qy / n, z: qz / n, w: w / n }
        };
        let color = if c.flags & FLAG_OUTSIDE != 0 {
            OUTSIDE_COLOR
        } else {
            let t = (fin(c.depth) / RED_DEPTH).clamp(0.0, 1.0);
            Color { r: 1.0, g: 1.0 - t, b: 0.0, a: 1.0 }
        };
        Some(Self { pose: Pose { position: Vector3 { x, y, z }, orientation }, shaft_length: r, shaft_diameter: 0.12 * r, head_length: 0.4 * r, head_diameter: 0.3 * r, color })
    }
}

/// `foxglove.SceneEntity` with the primitives Lumen uses; the others are written empty.
struct Entity<'a> {
    time: Time,
    id: &'a str,
    arrows: &'a [Arrow],
    lines: &'a [Line<'a>],
    triangles: Option<&'a WallBlocks<'a>>,
}

impl Serialize for Entity<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("SceneEntity", 14)?;
        st.serialize_field("timestamp", &self.time)?;
        st.serialize_field("frame_id", FRAME_ID)?;
        st.serialize_field("id", self.id)?;
        st.serialize_field("lifetime", &Time::ZERO)?;
        st.serialize_field("frame_locked", &false)?;
        st.serialize_field("metadata", &Empty)?;
        st.serialize_field("arrows", self.arrows)?;
        st.serialize_field("cubes", &Empty)?;
        st.serialize_field("spheres", &Empty)?;
        st.serialize_field("cylinders", &Empty)?;
        st.serialize_field("lines", &Lines(self.lines))?;
        match self.triangles {
            Some(wall) => st.serialize_field("triangles", wall)?,
            None => st.serialize_field("triangles", &Empty)?,
        }
        st.serialize_field("texts", &Empty)?;
        st.serialize_field("models", &Empty)?;
        st.end()
    }
}

struct Lines<'a>(&'a [Line<'a>]);
impl Serialize for Lines<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0)
    }
}

/// `foxglove.SceneUpdate` of given entities, no deletions.
struct Update<'a> {
    entities: &'a [Entity<'a>],
}

impl Serialize for Update<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("SceneUpdate", 2)?;
        st.serialize_field("deletions", &Empty)?;
        st.serialize_field("entities", self.entities)?;
        st.end()
    }
}

/// The update of one frame, its entities built while writing (no list of them is allocated).
struct FrameUpdate<'a> {
    time: Time,
    bodies: &'a [Body],
    state: &'a [f32],
    grid: WallGrid,
    /// The tubes' wall points, when the tubes go with this frame.
    wall: Option<&'a [[f32; 3]]>,
}

impl Serialize for FrameUpdate<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("SceneUpdate", 2)?;
        st.serialize_field("deletions", &Empty)?;
        st.serialize_field("entities", &FrameEntities(self))?;
        st.end()
    }
}

struct FrameEntities<'a>(&'a FrameUpdate<'a>);

impl Serialize for FrameEntities<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let u = self.0;
        let mut seq = s.serialize_seq(None)?;
        let mut wall_at = 0;
        for b in u.bodies {
            match b {
                Body::Rod { id, offset, points, diameter } => {
                    let line = Line { points: Points::new(&u.state[*offset..offset + points * 3]), thickness: *diameter, color: SCOPE_COLOR };
                    seq.serialize_element(&Entity { time: u.time, id, arrows: &[], lines: std::slice::from_ref(&line), triangles: None })?;
                }
                Body::Tube { id, rings, spokes, .. } => {
                    let Some(wall) = u.wall else { continue };
                    let rows = if *rings >= 2 { u.grid.rows(*rings, &(0..rings - 1)) } else { 0 };
                    let n = (rows * spokes).min(wall.len() - wall_at);
                    let mine = &wall[wall_at..wall_at + n];
                    wall_at += n;
                    let rows = if *spokes == 0 { 0 } else { n / spokes };
                    let xyz = mine.as_flattened();
                    let blocks = WallBlocks { xyz, rows, spokes: *spokes, step: step_of(xyz) };
                    seq.serialize_element(&Entity { time: u.time, id, arrows: &[], lines: &[], triangles: Some(&blocks) })?;
                }
            }
        }
        seq.end()
    }
}

#[cfg(test)]
mod tests;
