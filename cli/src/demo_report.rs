//! `lumen demo`'s report: the verdict and figures ([`Summary`], `summary.json`), a Markdown
//! page (`report.md`) and SVG plots: time per frame and contacts per frame over the run, and
//! time against contacts.
//!
//! **Units**: microseconds of wall time, millimetres.

use crate::commands::transport::TransportArg;
use crate::error::{CliError, CliResult};
use crate::figures::{FrameRow, RunFigures};
use plotters::prelude::*;
use serde::Serialize;
use std::path::Path;

/// The SVG plots, file name and what they show.
pub const PLOTS: [(&str, &str); 3] = [
    ("time_per_frame.svg", "Physics time and daemon round trip per frame"),
    ("contacts_per_frame.svg", "Contacts per frame"),
    ("time_vs_contacts.svg", "Round trip and physics time against contacts"),
];

/// What `summary.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    pub scene: String,
    pub transport: String,
    /// Frames run, and asked for.
    pub frames: u64,
    pub frames_planned: u64,
    /// Most scope samples outside the wall at the end of a frame, and frames with any.
    pub escaped_samples_max: u32,
    pub escaped_frames: u64,
    /// Deepest penetration over the run, mm, its frame, and the most a sound run may have.
    pub max_penetration_mm: f32,
    pub max_penetration_frame: u64,
    pub max_penetration_limit_mm: f32,
    /// Frames that produced a NaN.
    pub nan_frames: u64,
    /// Frames per second of wall time (physics and round trips), and mean physics time, us.
    pub physics_fps: f64,
    pub physics_us_mean: f64,
    /// Round trip to the daemon, submit to reply, us.
    pub rtt_p50_us: f64,
    pub rtt_p99_us: f64,
    /// Most contacts in a frame.
    pub contacts_max: u32,
    /// Bytes of a frame on the wire, median and most (zenoh; 0 over iceoryx2).
    pub wire_bytes_p50: f64,
    pub wire_bytes_max: u64,
    /// Wall time of the run from the session's opening, s.
    pub wall_s: f64,
    /// Why the simulation stopped early, if it did.
    pub error: Option<String>,
    /// What the recorder said it wrote into `run.mcap` (`None`: not recorded).
    pub recording: Option<String>,
    /// Whether the run was sound (no failures).
    pub sound: bool,
    /// Each failed criterion, named with its figure.
    pub failures: Vec<String>,
}

impl Summary {
    /// The summary of a run with `figures`, judged against `limit_mm`.
    pub fn new(scene: &str, transport: TransportArg, f: &RunFigures, error: Option<String>, wall_s: f64, limit_mm: f32) -> Self {
        let mut failures = Vec::new();
        if let Some(e) = &error {
            failures.push(format!("the simulation stopped: {e}"));
        }
        if f.frames < f.frames_planned {
            failures.push(format!("frames: only {} of {} ran", f.frames, f.frames_planned));
        }
        if f.escaped_samples_max > 0 {
            failures.push(format!("escaped samples: up to {} at the end of a frame, in {} frames", f.escaped_samples_max, f.escaped_frames));
        }
        if f.max_penetration_mm > limit_mm || f.max_penetration_mm.is_nan() {
            failures.push(format!("max penetration: {:.3} mm (frame {}) is over {limit_mm} mm", f.max_penetration_mm, f.max_penetration_frame));
        }
        if f.nan_frames > 0 {
            failures.push(format!("NaN frames: {}", f.nan_frames));
        }
        Self {
            scene: scene.to_owned(),
            transport: lumen_client::Transport::from(transport).to_string(),
            frames: f.frames,
            frames_planned: f.frames_planned,
            escaped_samples_max: f.escaped_samples_max,
            escaped_frames: f.escaped_frames,
            max_penetration_mm: f.max_penetration_mm,
            max_penetration_frame: f.max_penetration_frame,
            max_penetration_limit_mm: limit_mm,
            nan_frames: f.nan_frames,
            physics_fps: f.physics_fps,
            physics_us_mean: f.physics_us_mean,
            rtt_p50_us: f.rtt_p50_us,
            rtt_p99_us: f.rtt_p99_us,
            contacts_max: f.contacts_max,
            wire_bytes_p50: f.wire_bytes_p50,
            wire_bytes_max: f.wire_bytes_max,
            wall_s,
            sound: failures.is_empty(),
            error,
            recording: None,
            failures,
        }
    }

    /// A few lines for the terminal.
    pub fn text(&self) -> String {
        let verdict = if self.sound { "SOUND".to_string() } else { format!("NOT SOUND: {}", self.failures.join("; ")) };
        format!(
            "{} frames of the {} colon over {}: {:.0} frames/s (physics {:.0} us/frame), round trip p50 {:.0} us p99 {:.0} us\n\
             max penetration {:.3} mm (frame {}), escaped samples at most {}, NaN frames {}, contacts at most {}\n{verdict}",
            self.frames,
            self.scene,
            self.transport,
            self.physics_fps,
            self.physics_us_mean,
            self.rtt_p50_us,
            self.rtt_p99_us,
            self.max_penetration_mm,
            self.max_penetration_frame,
            self.escaped_samples_max,
            self.nan_frames,
            self.contacts_max
        )
    }

    /// The Markdown report.
    pub fn markdown(&self) -> String {
        let mut s = String::from("# Lumen demo: a colonoscopy through the daemon\n\n");
        s += &format!(
            "The scripted colonoscopy (lumen-sim's XPBD scope, pushed hard at the sigmoid) ran as its own process (`lumen sim`) on the **{}** colon, \
             getting every frame's contacts from the daemon (`lumen serve`) over **{}**.\n\n",
            self.scene, self.transport
        );
        s += &format!("**Verdict: {}**\n\n", if self.sound { "sound".to_string() } else { format!("not sound — {}", self.failures.join("; ")) });
        s += "| figure | value |\n|---|---|\n";
        let mut rows = vec![
            ("frames (of planned)", format!("{} ({})", self.frames, self.frames_planned)),
            ("escaped samples, most at the end of a frame", self.escaped_samples_max.to_string()),
            ("frames with escaped samples", self.escaped_frames.to_string()),
            ("max penetration", format!("{:.3} mm (frame {}; limit {} mm)", self.max_penetration_mm, self.max_penetration_frame, self.max_penetration_limit_mm)),
            ("NaN frames", self.nan_frames.to_string()),
            ("frames per second (physics + round trip)", format!("{:.0}", self.physics_fps)),
            ("physics per frame, mean", format!("{:.0} us", self.physics_us_mean)),
            ("round trip p50 / p99", format!("{:.0} / {:.0} us", self.rtt_p50_us, self.rtt_p99_us)),
            ("contacts, most in a frame", self.contacts_max.to_string()),
            ("wall time", format!("{:.1} s", self.wall_s)),
        ];
        if self.wire_bytes_max > 0 {
            rows.push(("a frame on the wire, median / most", format!("{:.1} / {:.1} KiB", self.wire_bytes_p50 / 1024.0, self.wire_bytes_max as f64 / 1024.0)));
        }
        for (k, v) in rows {
            s += &format!("| {k} | {v} |\n");
        }
        if let Some(e) = &self.error {
            s += &format!("\nThe simulation stopped early: {e}\n");
        }
        if let Some(r) = &self.recording {
            s += &format!("\nRecording (`run.mcap`, `lumen record`; play it back with `lumen replay run.mcap --check`): {r}\n");
        }
        s += "\n";
        for (file, title) in PLOTS {
            s += &format!("## {title}\n\n![{title}]({file})\n\n");
        }
        s += "Per-frame figures: `frames.jsonl` (one JSON object per frame); these figures: `summary.json`.\n";
        s
    }
}

/// Writes `summary.json`, `report.md` and the plots of `rows` into `dir`.
pub fn write(dir: &Path, summary: &Summary, rows: &[FrameRow]) -> CliResult {
    let write = |name: &str, text: String| std::fs::write(dir.join(name), text).map_err(|source| CliError::Write { path: dir.join(name), source });
    write("summary.json", serde_json::to_string_pretty(summary)? + "\n")?;
    write("report.md", summary.markdown())?;
    let title = format!("{} colon over {}", summary.scene, summary.transport);
    write(PLOTS[0].0, time_per_frame(rows, &title)?)?;
    write(PLOTS[1].0, contacts_per_frame(rows, &title)?)?;
    write(PLOTS[2].0, time_vs_contacts(rows, &title)?)?;
    Ok(())
}

/// The error of drawing `plot` (a file name of [`PLOTS`]).
fn plot_error(plot: &'static str) -> impl Fn(plotters::drawing::DrawingAreaErrorKind<std::io::Error>) -> CliError + Copy {
    move |source| CliError::Plot { plot, source }
}

const SIZE: (u32, u32) = (900, 480);
const PHYSICS: RGBColor = RGBColor(0, 114, 178);
const ROUND_TRIP: RGBColor = RGBColor(213, 94, 0);

/// A log axis of microseconds showing every positive value of `v` (never empty).
fn log_range(v: impl Iterator<Item = f64>) -> LogCoord<f64> {
    let (lo, hi) = v.filter(|x| x.is_finite() && *x > 0.0).fold((f64::MAX, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
    let (lo, hi) = if hi > 0.0 { (lo * 0.8, hi * 1.25) } else { (1.0, 10.0) };
    (lo..hi).log_scale().into()
}

fn us_label(v: &f64) -> String {
    if *v >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

/// Upper end of a y axis showing `v` (a little headroom; never empty).
fn top(v: impl Iterator<Item = f64>) -> f64 {
    let m = v.filter(|x| x.is_finite()).fold(0.0, f64::max);
    if m > 0.0 {
        m * 1.1
    } else {
        1.0
    }
}

fn frames_axis(rows: &[FrameRow]) -> std::ops::Range<u64> {
    0..rows.last().map_or(1, |r| r.frame.max(1))
}

/// Physics time and round trip against frame number.
pub fn time_per_frame(rows: &[FrameRow], title: &str) -> CliResult<String> {
    let pe = plot_error(PLOTS[0].0);
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let y = log_range(rows.iter().flat_map(|r| [r.physics_us, r.rtt_us]));
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Time per frame ({title})"), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(frames_axis(rows), y)
            .map_err(pe)?;
        chart.configure_mesh().x_desc("frame").y_desc("us (log)").y_label_formatter(&us_label).draw().map_err(pe)?;
        chart
            .draw_series(LineSeries::new(rows.iter().filter(|r| !r.nan).map(|r| (r.frame, r.physics_us)), &PHYSICS))
            .map_err(pe)?
            .label("physics")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], PHYSICS));
        chart
            .draw_series(LineSeries::new(rows.iter().filter(|r| !r.nan).map(|r| (r.frame, r.rtt_us)), &ROUND_TRIP))
            .map_err(pe)?
            .label("round trip to the daemon")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], ROUND_TRIP));
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(pe)?;
        root.present().map_err(pe)?;
    }
    Ok(out)
}

/// Contacts against frame number.
pub fn contacts_per_frame(rows: &[FrameRow], title: &str) -> CliResult<String> {
    let pe = plot_error(PLOTS[1].0);
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let y = top(rows.iter().map(|r| r.contacts as f64));
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Contacts per frame ({title})"), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(frames_axis(rows), 0.0..y)
            .map_err(pe)?;
        chart.configure_mesh().x_desc("frame").y_desc("contacts").y_label_formatter(&|v| format!("{v:.0}")).draw().map_err(pe)?;
        chart.draw_series(LineSeries::new(rows.iter().filter(|r| !r.nan).map(|r| (r.frame, r.contacts as f64)), &PHYSICS)).map_err(pe)?;
        root.present().map_err(pe)?;
    }
    Ok(out)
}

/// Round trip and physics time of each frame against its contacts.
pub fn time_vs_contacts(rows: &[FrameRow], title: &str) -> CliResult<String> {
    let pe = plot_error(PLOTS[2].0);
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        let x = top(rows.iter().map(|r| r.contacts as f64));
        let y = log_range(rows.iter().flat_map(|r| [r.physics_us, r.rtt_us]));
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("Time against contacts ({title})"), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..x, y)
            .map_err(pe)?;
        chart.configure_mesh().x_desc("contacts in the frame").y_desc("us (log)").x_label_formatter(&|v| format!("{v:.0}")).y_label_formatter(&us_label).draw().map_err(pe)?;
        let ok = || rows.iter().filter(|r| !r.nan);
        chart
            .draw_series(ok().map(|r| Circle::new((r.contacts as f64, r.physics_us), 2, PHYSICS.filled())))
            .map_err(pe)?
            .label("physics")
            .legend(|(x, y)| Circle::new((x + 8, y), 3, PHYSICS.filled()));
        chart
            .draw_series(ok().map(|r| Circle::new((r.contacts as f64, r.rtt_us), 2, ROUND_TRIP.filled())))
            .map_err(pe)?
            .label("round trip to the daemon")
            .legend(|(x, y)| Circle::new((x + 8, y), 3, ROUND_TRIP.filled()));
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(pe)?;
        root.present().map_err(pe)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figures() -> RunFigures {
        RunFigures { frames: 10, frames_planned: 10, max_penetration_mm: 0.3, contacts_max: 4, ..RunFigures::default() }
    }

    #[test]
    fn a_clean_run_is_sound() {
        let s = Summary::new("generated", TransportArg::Iceoryx2, &figures(), None, 1.0, 1.0);
        assert!(s.sound && s.failures.is_empty(), "{:?}", s.failures);
    }

    #[test]
    fn each_failure_is_named_with_its_figure() {
        let f = RunFigures { escaped_samples_max: 3, escaped_frames: 2, max_penetration_mm: 1.5, max_penetration_frame: 7, nan_frames: 1, frames: 8, ..figures() };
        let s = Summary::new("gca", TransportArg::Zenoh, &f, Some("frame 8 produced a non-finite value (NaN)".into()), 1.0, 1.0);
        assert!(!s.sound);
        let all = s.failures.join("\n");
        for want in ["escaped samples: up to 3", "max penetration: 1.500 mm (frame 7)", "NaN frames: 1", "only 8 of 10", "the simulation stopped"] {
            assert!(all.contains(want), "{want:?} missing from {all}");
        }
        assert_eq!(s.transport, "zenoh");
    }

    #[test]
    fn plots_draw_the_rows() {
        let rows: Vec<FrameRow> = (1..=50).map(|i| FrameRow { frame: i, physics_us: 300.0 + i as f64, rtt_us: 150.0, contacts: (i % 7) as u32, ..FrameRow::default() }).collect();
        for svg in [time_per_frame(&rows, "t").unwrap(), contacts_per_frame(&rows, "t").unwrap(), time_vs_contacts(&rows, "t").unwrap()] {
            assert!(svg.starts_with("<svg") && svg.len() > 2000, "{}", &svg[..svg.len().min(200)]);
        }
        // An empty run still gives plots (a run that failed at once is reported too).
        assert!(time_per_frame(&[], "t").unwrap().starts_with("<svg"));
    }
}
