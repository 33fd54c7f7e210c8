//! The figures of a simulation run against the daemon, as `lumen sim` writes them and
//! `lumen demo` reads them back.
//!
//! **Units**: microseconds of wall time, millimetres.
//!
//! - [`FrameRow`]: one frame (a line of `lumen sim --figures FILE`, JSON lines).
//! - [`RunFigures`]: the run so far, from its rows ([`Tally`]).
//! - [`SimLine`]: what `lumen sim` prints on stdout after its `session <id>` line: a progress
//!   line every so many frames and a final summary, one JSON object each.

use serde::{Deserialize, Serialize};

/// The figures of one frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    /// Frame number (1 for the first step).
    pub frame: u64,
    /// Wall time of the physics (everything but the detection round trip), us.
    pub physics_us: f64,
    /// Round trip to the daemon, from submit to the reply in hand, us.
    pub rtt_us: f64,
    /// Detection time the daemon reported, us.
    pub detect_us: f64,
    /// Contacts the daemon reported (all pairs, including those within the margin).
    pub contacts: u32,
    /// Deepest scope-colon penetration at the end of the frame, mm.
    pub max_penetration_mm: f32,
    /// Scope samples outside the wall at the end of the frame.
    pub escaped: u32,
    /// Whether the frame produced a non-finite value (the run stops there).
    pub nan: bool,
    /// Bytes of the frame's message on the wire (zenoh: whole or a delta); 0 over iceoryx2.
    #[serde(default)]
    pub wire_bytes: u64,
}

/// The figures of a run so far.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunFigures {
    /// Frames completed (a NaN frame counts).
    pub frames: u64,
    /// Frames the run was asked for.
    pub frames_planned: u64,
    /// Frames per second of wall time, physics and round trips together.
    pub physics_fps: f64,
    /// Mean physics time per frame, us.
    pub physics_us_mean: f64,
    /// Round trip percentiles, us.
    pub rtt_p50_us: f64,
    pub rtt_p99_us: f64,
    /// Contacts in the last frame and at most in a frame.
    pub contacts: u32,
    pub contacts_max: u32,
    /// Deepest penetration over the run, mm, and the frame it happened in.
    pub max_penetration_mm: f32,
    pub max_penetration_frame: u64,
    /// Most escaped samples at the end of a frame, and frames with any.
    pub escaped_samples_max: u32,
    pub escaped_frames: u64,
    /// Frames that produced a non-finite value.
    pub nan_frames: u64,
    /// Bytes of a frame's message on the wire, median and most (0 over iceoryx2).
    #[serde(default)]
    pub wire_bytes_p50: f64,
    #[serde(default)]
    pub wire_bytes_max: u64,
}

/// A line of `lumen sim`'s stdout after the first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum SimLine {
    /// The run so far.
    Progress(RunFigures),
    /// The run at its end; `error` says why it stopped early, if it did.
    Summary {
        #[serde(flatten)]
        figures: RunFigures,
        error: Option<String>,
    },
}

/// Adds up [`FrameRow`]s into [`RunFigures`].
#[derive(Debug, Default)]
pub struct Tally {
    figures: RunFigures,
    rtt_us: Vec<f64>,
    wire_bytes: Vec<f64>,
    physics_us: f64,
}

impl Tally {
    /// An empty tally of a run of `planned` frames.
    pub fn new(planned: u64) -> Self {
        Self { figures: RunFigures { frames_planned: planned, ..RunFigures::default() }, ..Self::default() }
    }

    /// Counts one frame.
    pub fn add(&mut self, r: &FrameRow) {
        let f = &mut self.figures;
        f.frames += 1;
        f.contacts = r.contacts;
        f.contacts_max = f.contacts_max.max(r.contacts);
        if r.max_penetration_mm > f.max_penetration_mm {
            f.max_penetration_mm = r.max_penetration_mm;
            f.max_penetration_frame = r.frame;
        }
        f.escaped_samples_max = f.escaped_samples_max.max(r.escaped);
        f.escaped_frames += (r.escaped > 0) as u64;
        f.nan_frames += r.nan as u64;
        self.physics_us += r.physics_us;
        if !r.nan {
            self.rtt_us.push(r.rtt_us);
        }
        if r.wire_bytes > 0 {
            self.wire_bytes.push(r.wire_bytes as f64);
            f.wire_bytes_max = f.wire_bytes_max.max(r.wire_bytes);
        }
    }

    /// The figures, with the rate over `wall_s` seconds of wall time.
    pub fn figures(&self, wall_s: f64) -> RunFigures {
        let mut f = self.figures.clone();
        f.physics_fps = if wall_s > 0.0 { f.frames as f64 / wall_s } else { 0.0 };
        f.physics_us_mean = if f.frames > 0 { self.physics_us / f.frames as f64 } else { 0.0 };
        let mut v = self.rtt_us.clone();
        f.rtt_p50_us = percentile(&mut v, 0.5);
        f.rtt_p99_us = percentile(&mut v, 0.99);
        f.wire_bytes_p50 = percentile(&mut self.wire_bytes.clone(), 0.5);
        f
    }
}

/// The `q` quantile (0 to 1) of `v`, nearest rank; 0 if `v` is empty. Sorts `v`.
pub fn percentile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_unstable_by(f64::total_cmp);
    let i = ((v.len() as f64 * q).ceil() as usize).clamp(1, v.len()) - 1;
    v[i]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tally_takes_maxima_counts_and_percentiles() {
        let mut t = Tally::new(4);
        for (i, (rtt, contacts, pen, esc, nan)) in [(10.0, 3, 0.1, 0, false), (30.0, 7, 0.4, 2, false), (20.0, 5, 0.2, 0, false), (0.0, 0, 0.0, 0, true)].into_iter().enumerate() {
            t.add(&FrameRow { frame: i as u64 + 1, physics_us: 100.0, rtt_us: rtt, contacts, max_penetration_mm: pen, escaped: esc, nan, ..FrameRow::default() });
        }
        let f = t.figures(2.0);
        assert_eq!((f.frames, f.frames_planned, f.contacts_max, f.contacts), (4, 4, 7, 0));
        assert_eq!((f.max_penetration_mm, f.max_penetration_frame), (0.4, 2));
        assert_eq!((f.escaped_samples_max, f.escaped_frames, f.nan_frames), (2, 1, 1));
        assert_eq!((f.rtt_p50_us, f.rtt_p99_us), (20.0, 30.0));
        assert_eq!((f.physics_fps, f.physics_us_mean), (2.0, 100.0));
    }

    #[test]
    fn sim_lines_read_back() {
        let s = SimLine::Summary { figures: RunFigures { frames: 3, ..RunFigures::default() }, error: Some("x".into()) };
        let text = serde_json::to_string(&s).unwrap();
        assert!(text.starts_with("{\"type\":\"summary\""), "{text}");
        assert_eq!(serde_json::from_str::<SimLine>(&text).unwrap(), s);
        let p = SimLine::Progress(RunFigures { frames: 100, ..RunFigures::default() });
        assert_eq!(serde_json::from_str::<SimLine>(&serde_json::to_string(&p).unwrap()).unwrap(), p);
    }
}
