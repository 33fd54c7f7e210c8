//! What a page is sent: the scene once (JSON), then frames in a compact binary form, each
//! carrying only the wall rows that changed since the frame that page was sent before.
//!
//! A frame message (all little-endian; `README.md` has the full table):
//!
//! ```text
//! 0  u32  magic 0x57564D4C ("LMVW")
//! 4  u32  json_len, a multiple of 4 (the JSON is padded with spaces)
//! 8  json_len bytes of JSON: frame, stats, and the blocks that follow
//! .. f32  per wall block rows * spokes * 3, per rod points * 3, per contact 8
//!         (point_b xyz, normal xyz, depth, flags)
//! ```
//!
//! A Catmull-Rom segment depends on rings `i - 1 ..= i + 2`, so a ring that moved re-sends the
//! rows of segments `i - 2 ..= i + 1`: a colonoscopy frame that moves the scope and a few wall
//! tips costs the rows near them, not the colon.

use lumen_detect::wall::WallGrid;
use lumen_proto::{Contact, SceneSpec, Shape};
use serde::Serialize;
use std::ops::Range;

/// Magic of a frame message: the bytes `4C 4D 56 57` (ASCII `LMVW`).
pub const MAGIC: u32 = 0x5756_4D4C;
/// Floats per contact in a frame message.
pub const CONTACT_FLOATS: usize = 8;

/// One body as the page draws it, with where its floats sit in the frame state.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BodyInfo {
    /// A tube drawn as `(rings - 1) * steps + 1` rows of `spokes` wall points.
    Tube {
        name: String,
        rings: usize,
        spokes: usize,
        rows: usize,
        #[serde(skip)]
        offset: usize,
    },
    /// A rod drawn as a tube of its radius (one value, or one per point) through its points.
    Rod {
        name: String,
        points: usize,
        radius: Vec<f32>,
        #[serde(skip)]
        offset: usize,
    },
}

/// Where the frames come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// A running session, observed.
    Live,
    /// A recording, played back (the page shows play, pause, step, speed and a scrubber).
    Recording,
}

/// The scene message: sent first, as text, to every page.
#[derive(Debug, Clone, Serialize)]
pub struct SceneInfo {
    #[serde(rename = "type")]
    kind: &'static str,
    /// The observed (or recorded) session's id.
    pub session: u64,
    pub source: Source,
    /// Wall rows per ring segment (the subdivision along the tube).
    pub steps: usize,
    pub bodies: Vec<BodyInfo>,
    /// Frames in the recording (0 for a live session).
    pub frames: u64,
    /// A label: the transport or the file.
    pub label: String,
    #[serde(skip)]
    floats: usize,
    #[serde(skip)]
    alpha: f32,
}

impl SceneInfo {
    /// The scene of `spec`, drawn with `steps` rows per ring segment (clamped to 1..=16).
    pub fn new(spec: &SceneSpec, session: u64, source: Source, steps: usize, frames: u64, label: &str) -> Self {
        let steps = steps.clamp(1, 16);
        let mut offset = 0;
        let bodies = spec
            .bodies
            .iter()
            .map(|b| {
                let at = offset;
                offset += b.floats();
                match &b.shape {
                    Shape::Tube { rings, spokes } => BodyInfo::Tube { name: b.name.clone(), rings: *rings, spokes: *spokes, rows: rings.saturating_sub(1) * steps + 1, offset: at },
                    Shape::Rod { points, radius } => BodyInfo::Rod { name: b.name.clone(), points: *points, radius: radius.clone(), offset: at },
                }
            })
            .collect();
        Self { kind: "scene", session, source, steps, bodies, frames, label: label.to_owned(), floats: offset, alpha: spec.alpha }
    }

    /// The whole frame state's float count.
    pub fn floats(&self) -> usize {
        self.floats
    }

    /// The scene message's text.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("the scene serialises")
    }
}

/// The figures the page's panel shows for one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Stats {
    /// The frame number (the client's).
    pub frame: u64,
    /// The client's frame rate, frames per second (from frame numbers over the observer's
    /// clock, or the recording's timestamps).
    pub fps: f64,
    /// The daemon's turnaround (a frame in to its reply out, p50 over its last seconds, from
    /// its status report), microseconds; `None` in a recording, or before the daemon has it.
    pub turnaround_us: Option<f64>,
    /// The daemon's detection time of this frame, microseconds.
    pub detect_us: f64,
    /// The reply's status (0 ok, see `proto/README.md`).
    pub status: u16,
    /// Contacts in the reply.
    pub contacts: usize,
    /// The deepest contact's depth (0 when none is deeper), in the scene's unit.
    pub max_depth: f32,
    /// Contacts whose rod sample is outside the wall (flag bit 1).
    pub escaped: usize,
    /// Recording playback: the frame's index in the file.
    pub index: Option<u64>,
    /// Recording playback: whether it is playing, and how fast.
    pub playing: Option<bool>,
    pub speed: Option<f64>,
}

impl Stats {
    /// Stats with `contacts`, `max_depth` and `escaped` read from a reply's contacts.
    pub fn of_contacts(mut self, contacts: &[Contact]) -> Self {
        self.contacts = contacts.len();
        self.max_depth = contacts.iter().map(|c| c.depth).fold(0.0, f32::max);
        self.escaped = contacts.iter().filter(|c| c.flags & lumen_proto::contact::FLAG_OUTSIDE != 0).count();
        self
    }
}

/// One frame and its reply, as the view holds them between the observer and the pages.
#[derive(Debug, Clone, Default)]
pub struct Snapshot {
    pub state: Vec<f32>,
    pub contacts: Vec<Contact>,
    pub stats: Stats,
}

#[derive(Serialize)]
struct WallBlock {
    body: usize,
    first_row: usize,
    rows: usize,
}

#[derive(Serialize)]
struct RodBlock {
    body: usize,
    points: usize,
}

#[derive(Serialize)]
struct FrameJson<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    key: bool,
    /// Frames of the session that came between the frame this page was sent before and this
    /// one, and that it never saw (newest wins).
    dropped: u64,
    stats: &'a Stats,
    walls: Vec<WallBlock>,
    rods: Vec<RodBlock>,
    contacts: usize,
}

/// One page's encoder: remembers the state it last sent, so each message carries what changed.
#[derive(Debug)]
pub struct Encoder {
    last: Vec<f32>,
    last_frame: Option<u64>,
    points: Vec<[f32; 3]>,
}

impl Encoder {
    pub fn new() -> Self {
        Self { last: Vec::new(), last_frame: None, points: Vec::new() }
    }

    /// `snap` as a frame message into `out` (cleared first); a key frame (every row) when the
    /// page has nothing yet or `key` is set. Returns the wall rows sent.
    pub fn encode(&mut self, scene: &SceneInfo, snap: &Snapshot, key: bool, out: &mut Vec<u8>) -> usize {
        out.clear();
        let key = key || self.last.len() != snap.state.len() || snap.state.len() != scene.floats;
        let grid = WallGrid { steps: scene.steps, alpha: scene.alpha };
        self.points.clear();
        let (mut walls, mut rods) = (Vec::new(), Vec::new());
        let mut rows_sent = 0;
        for (body, info) in scene.bodies.iter().enumerate() {
            match *info {
                BodyInfo::Tube { rings, spokes, offset, .. } => {
                    let n = rings * (spokes + 1) * 3;
                    let Some(data) = snap.state.get(offset..offset + n) else { continue };
                    let runs: Vec<Range<usize>> = if key { std::iter::once(0..rings.saturating_sub(1)).collect() } else { changed_segments(data, &self.last[offset..offset + n], rings, spokes) };
                    for run in runs {
                        let rows = grid.rows(rings, &run);
                        grid.append(data, rings, spokes, run.clone(), &mut self.points);
                        walls.push(WallBlock { body, first_row: run.start * scene.steps, rows });
                        rows_sent += rows;
                    }
                }
                BodyInfo::Rod { points, offset, .. } => {
                    let Some(data) = snap.state.get(offset..offset + points * 3) else { continue };
                    self.points.extend(data.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
                    rods.push(RodBlock { body, points });
                }
            }
        }
        let dropped = match self.last_frame {
            Some(f) if snap.stats.frame > f => snap.stats.frame - f - 1,
            _ => 0,
        };
        let json = FrameJson { kind: "frame", key, dropped, stats: &snap.stats, walls, rods, contacts: snap.contacts.len() };
        let mut text = serde_json::to_vec(&json).expect("a frame serialises");
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        out.extend_from_slice(&MAGIC.to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(&text);
        for p in &self.points {
            for v in p {
                out.extend_from_slice(&finite(*v).to_le_bytes());
            }
        }
        for c in &snap.contacts {
            let floats = [c.point_b[0], c.point_b[1], c.point_b[2], c.normal[0], c.normal[1], c.normal[2], c.depth, c.flags as f32];
            for v in floats {
                out.extend_from_slice(&finite(v).to_le_bytes());
            }
        }
        self.last.clear();
        self.last.extend_from_slice(&snap.state);
        self.last_frame = Some(snap.stats.frame);
        rows_sent
    }
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

/// A non-finite value (never sent by the daemon, but a recording may be damaged) as 0, so the
/// page never draws NaN.
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// The runs of segments whose rows changed between `old` and `new` (a tube's floats): ring `i`
/// moving touches segments `i - 2 ..= i + 1`.
pub fn changed_segments(new: &[f32], old: &[f32], rings: usize, spokes: usize) -> Vec<Range<usize>> {
    let stride = (spokes + 1) * 3;
    let segments = rings.saturating_sub(1);
    let mut runs: Vec<Range<usize>> = Vec::new();
    for i in 0..rings {
        let (a, b) = (&new[i * stride..(i + 1) * stride], &old[i * stride..(i + 1) * stride]);
        if a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()) {
            continue;
        }
        let run = i.saturating_sub(2)..(i + 2).min(segments);
        match runs.last_mut() {
            Some(last) if run.start <= last.end => last.end = last.end.max(run.end),
            _ => runs.push(run),
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumen_proto::{BodySpec, ContactKind, PairSpec};

    fn spec(rings: usize, spokes: usize, points: usize) -> SceneSpec {
        SceneSpec::new(
            vec![BodySpec { name: "colon".into(), shape: Shape::Tube { rings, spokes } }, BodySpec { name: "scope".into(), shape: Shape::Rod { points, radius: vec![1.5] } }],
            vec![PairSpec { a: "scope".into(), b: "colon".into(), kind: ContactKind::Interior }],
        )
    }

    /// A straight tube along x (rings 1 apart, radius 4) and a rod on its axis.
    fn state(rings: usize, spokes: usize, points: usize) -> Vec<f32> {
        let mut s = Vec::new();
        for i in 0..rings {
            s.extend_from_slice(&[i as f32, 0.0, 0.0]);
            for k in 0..spokes {
                let a = k as f32 / spokes as f32 * std::f32::consts::TAU;
                s.extend_from_slice(&[0.0, 4.0 * a.cos(), 4.0 * a.sin()]);
            }
        }
        for j in 0..points {
            s.extend_from_slice(&[j as f32 * 0.5, 0.0, 0.0]);
        }
        s
    }

    /// The JSON and the floats of a message, as the page reads them.
    fn decode(msg: &[u8]) -> (serde_json::Value, Vec<f32>) {
        assert_eq!(u32::from_le_bytes(msg[0..4].try_into().unwrap()), MAGIC);
        let n = u32::from_le_bytes(msg[4..8].try_into().unwrap()) as usize;
        assert_eq!(n % 4, 0);
        let json = serde_json::from_slice(&msg[8..8 + n]).unwrap();
        let floats = msg[8 + n..].chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        (json, floats)
    }

    #[test]
    fn a_key_frame_holds_every_row_then_a_delta_only_the_moved_ring() {
        let (rings, spokes, points, steps) = (20, 6, 5, 3);
        let scene = SceneInfo::new(&spec(rings, spokes, points), 7, Source::Live, steps, 0, "test");
        let mut snap = Snapshot { state: state(rings, spokes, points), ..Default::default() };
        let (mut enc, mut out) = (Encoder::new(), Vec::new());
        let rows = enc.encode(&scene, &snap, false, &mut out);
        assert_eq!(rows, (rings - 1) * steps + 1);
        let (json, floats) = decode(&out);
        assert_eq!(json["key"], true);
        assert_eq!(floats.len(), (rows * spokes + points) * 3);
        // Row 3 (ring 1, u = 0), spoke 0: the control point plus the spoke (0, 4, 0).
        let at = 3 * spokes * 3;
        assert_eq!(&floats[at..at + 3], &[1.0, 4.0, 0.0]);

        // Move one spoke of ring 10: segments 8..=11 are re-sent, nothing else.
        snap.state[(10 * (spokes + 1) + 1) * 3 + 1] += 1.0;
        snap.stats.frame = 5;
        snap.contacts = vec![Contact { point_b: [1.0, 2.0, 3.0], normal: [0.0, 1.0, 0.0], depth: 0.25, flags: 2, ..Default::default() }];
        let rows = enc.encode(&scene, &snap, false, &mut out);
        assert_eq!(rows, 4 * steps);
        let (json, floats) = decode(&out);
        assert_eq!(json["key"], false);
        assert_eq!(json["dropped"], 4);
        assert_eq!(json["walls"][0]["first_row"], 8 * steps);
        assert_eq!(floats.len(), (rows * spokes + points) * 3 + CONTACT_FLOATS);
        assert_eq!(&floats[floats.len() - 8..], &[1.0, 2.0, 3.0, 0.0, 1.0, 0.0, 0.25, 2.0]);

        // Nothing moved: no wall rows at all, the rod still sent.
        let rows = enc.encode(&scene, &snap, false, &mut out);
        assert_eq!(rows, 0);
        assert_eq!(decode(&out).1.len(), points * 3 + CONTACT_FLOATS);
    }

    #[test]
    fn changed_rings_at_the_ends_and_side_by_side_merge_into_runs() {
        let (rings, spokes) = (12, 3);
        let old = state(rings, spokes, 0);
        let mut new = old.clone();
        let stride = (spokes + 1) * 3;
        for i in [0, 5, 6, 11] {
            new[i * stride] += 0.5;
        }
        assert_eq!(changed_segments(&new, &old, rings, spokes), vec![0..2, 3..8, 9..11]);
        assert!(changed_segments(&old, &old, rings, spokes).is_empty());
    }

    #[test]
    fn stats_read_depth_and_escapes_from_contacts() {
        let c = |depth, flags| Contact { depth, flags, ..Default::default() };
        let s = Stats::default().of_contacts(&[c(-0.5, 0), c(1.25, 2), c(0.5, 4)]);
        assert_eq!((s.contacts, s.max_depth, s.escaped), (3, 1.25, 1));
        assert_eq!(Stats::default().of_contacts(&[c(-0.5, 0)]).max_depth, 0.0);
    }

    #[test]
    fn the_scene_message_names_bodies_and_rows() {
        let scene = SceneInfo::new(&spec(20, 6, 5), 7, Source::Recording, 4, 300, "run.mcap");
        let v: serde_json::Value = serde_json::from_str(&scene.to_json()).unwrap();
        assert_eq!(v["type"], "scene");
        assert_eq!(v["bodies"][0]["kind"], "tube");
        assert_eq!(v["bodies"][0]["rows"], 19 * 4 + 1);
        assert_eq!(v["bodies"][1]["radius"][0], 1.5);
        assert_eq!(v["source"], "recording");
        assert_eq!(v["frames"], 300);
        assert_eq!(scene.floats(), 20 * 7 * 3 + 15);
    }
}
