//! `lumen replay run.mcap [--speed 1|max] [--check]`: plays a recording back as a new session
//! (same spec, same frames in the same order, same frame numbers) and compares every reply with
//! the recorded one, bit for bit: a recorded run becomes a regression test and a benchmark input.

use super::transport::TransportArgs;
use super::{CliError, CliResult};
use crate::recording::{compare_replies, Recording, ReplyDifference};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lumen_service::stats::pick;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::{Duration, Instant};

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The recording (`lumen record -o FILE`).
    pub input: PathBuf,
    /// Pace: `1` follows the recorded timestamps (2 twice as fast...), `max` sends each frame as
    /// soon as the previous reply is in.
    #[arg(long, default_value = "1")]
    pub speed: Speed,
    /// Exit non-zero if any reply differs from the recorded one.
    #[arg(long)]
    pub check: bool,
    /// Seconds to wait for each reply before giving up.
    #[arg(long, default_value_t = 5.0)]
    pub timeout: f64,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// Replay pace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// This many times the recorded pace (> 0).
    Factor(f64),
    /// Back to back.
    Max,
}

/// A `--speed` that is neither `max` nor a positive number.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("speed {0:?} is neither `max` nor a positive number (1 = as recorded)")]
pub struct BadSpeed(pub String);

impl FromStr for Speed {
    type Err = BadSpeed;
    fn from_str(s: &str) -> Result<Self, BadSpeed> {
        if s == "max" {
            return Ok(Speed::Max);
        }
        match s.parse::<f64>() {
            Ok(f) if f.is_finite() && f > 0.0 => Ok(Speed::Factor(f)),
            _ => Err(BadSpeed(s.to_owned())),
        }
    }
}

/// What a replay found.
#[derive(Debug, Default)]
pub struct ReplayReport {
    /// Frames submitted.
    pub frames: u64,
    /// Replies equal to the recorded ones bit for bit.
    pub matched: u64,
    /// Replies that differ.
    pub differed: u64,
    /// Frames whose reply the recording lacks (the recorder missed it): not compared.
    pub unrecorded: u64,
    /// The first differing frame and how it differs.
    pub first_difference: Option<(u64, ReplyDifference)>,
    /// Round trip (submit to reply) p50 and p99, microseconds.
    pub round_trip_p50_us: f64,
    pub round_trip_p99_us: f64,
    /// Wall time of the whole replay, seconds.
    pub seconds: f64,
}

pub fn run(args: ReplayArgs) -> CliResult {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        return Err(CliError::bad_flag("--timeout", args.timeout, "a positive number of seconds"));
    }
    // The whole file is checked before anything is sent: a damaged one fails here, clearly.
    let recording = Recording::open(&args.input)?;
    let client = args.transport.client("lumen replay")?;
    let report = replay(&recording, &client, args.speed, Duration::from_secs_f64(args.timeout))?;
    println!(
        "lumen replay: {} frames in {:.2} s: {} matched bit for bit, {} differed, {} without a recorded reply; round trip p50 {:.1} us, p99 {:.1} us",
        report.frames, report.seconds, report.matched, report.differed, report.unrecorded, report.round_trip_p50_us, report.round_trip_p99_us
    );
    if let Some((frame, what)) = &report.first_difference {
        println!("lumen replay: first difference at frame {frame}: {what}");
        if args.check {
            return Err(CliError::RepliesDiffer { differed: report.differed, frames: report.frames, path: args.input.clone(), frame: *frame, source: what.clone() });
        }
    }
    Ok(())
}

/// Plays `recording` back through `client` and compares the replies.
pub fn replay(recording: &Recording, client: &lumen_client::Client, speed: Speed, timeout: Duration) -> CliResult<ReplayReport> {
    let mut session = client.open_session(&recording.spec)?;
    let bar = if std::io::stderr().is_terminal() { ProgressBar::with_draw_target(Some(recording.frames), ProgressDrawTarget::stderr()) } else { ProgressBar::hidden() };
    bar.set_style(ProgressStyle::with_template("{bar:40} {pos}/{len} frames {msg}").expect("a valid template"));
    let mut report = ReplayReport::default();
    let mut round_trips: Vec<u32> = Vec::with_capacity(recording.frames as usize);
    let start = Instant::now();
    let mut first_log_time = None;
    for frame in recording.frames()? {
        let frame = frame?;
        if let Speed::Factor(f) = speed {
            let first = *first_log_time.get_or_insert(frame.log_time_ns);
            let due = start + Duration::from_nanos((frame.log_time_ns.saturating_sub(first) as f64 / f) as u64);
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        let buf = session.frame()?;
        // A recorded frame of the wrong size (a faulty client) is replayed as far as it fits,
        // with its own header counts, so the daemon answers it as it did then.
        let n = buf.len().min(frame.state.len());
        buf[..n].copy_from_slice(&frame.state[..n]);
        buf[n..].fill(0.0);
        let rec = frame.header;
        session.submit_with(|h| {
            h.frame = rec.frame;
            h.magic = rec.magic;
            h.version = rec.version;
            h.flags = rec.flags;
            h.floats = rec.floats;
            h.bodies = rec.bodies;
        })?;
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(CliError::NoReply { frame: rec.frame, timeout });
            }
            let reply = match session.contacts(left) {
                Ok(r) => r,
                Err(lumen_client::Error::Timeout(_)) => continue,
                Err(e) => return Err(e.into()),
            };
            if reply.frame() != rec.frame {
                continue; // a late reply to an earlier frame
            }
            round_trips.push((reply.round_trip_us() * 1e3).min(u32::MAX as f64) as u32);
            match recording.replies.get(&rec.frame) {
                None => report.unrecorded += 1,
                Some(recorded) => match compare_replies((reply.header(), reply.contacts()), recorded) {
                    Ok(()) => report.matched += 1,
                    Err(what) => {
                        report.differed += 1;
                        report.first_difference.get_or_insert((rec.frame, what));
                    }
                },
            }
            break;
        }
        report.frames += 1;
        bar.inc(1);
        if report.differed > 0 {
            bar.set_message(format!("{} differ", report.differed));
        }
    }
    bar.finish_and_clear();
    report.seconds = start.elapsed().as_secs_f64();
    round_trips.sort_unstable();
    report.round_trip_p50_us = pick(&round_trips, 0.5);
    report.round_trip_p99_us = pick(&round_trips, 0.99);
    Ok(report)
}
