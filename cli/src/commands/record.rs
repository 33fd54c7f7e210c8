//! `lumen record SESSION -o run.mcap`: an observer writing a session's frames and replies to an
//! MCAP file (see [`crate::recording`]) until the session ends or SIGINT / SIGTERM arrives; the
//! file is finished either way.
//!
//! Two threads: the observer's loop only copies each frame and reply into a queue (over
//! iceoryx2 a frame must be taken before 16 more come, over zenoh before the next, or it is
//! gone), and a writer thread codes and writes them, so a frame that takes long to write holds
//! up no receiving.

use super::transport::TransportArgs;
use super::CliResult;
use crate::recording::{wall_ns, Missed, RecordingError, Writer, WriterOptions};
use clap::Args;
use lumen_client::{Error, Observed};
use lumen_proto::wire::{ContactsHeader, FrameHeader};
use lumen_proto::Contact;
use lumen_service::daemon::{block_termination_signals, wait_signal};
use std::io::Write;
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::{Duration, Instant};

#[derive(Debug, Args)]
pub struct RecordArgs {
    /// The session to record (its id, as `lumen status` lists it).
    pub session: u64,
    /// The MCAP file to write (replaced if it exists).
    #[arg(long, short, value_name = "FILE")]
    pub output: PathBuf,
    /// Leave out the `/lumen/scene` channel (Foxglove's `foxglove.SceneUpdate`: the scope every
    /// frame, the colon at most once a second, the contacts of every reply, for Foxglove's or
    /// Lichtblick's 3D panel); the frames, replies and replay do not need it.
    #[arg(long)]
    pub no_scene: bool,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// How often the loop looks for SIGINT / SIGTERM while frames keep coming.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Frames and replies the queue to the writer holds: a colon-sized frame is 0.5 MB, so 64 frames
/// and their replies 31 MB, time to ride out a slow write (a zstd chunk, a disk stall) at 1 kHz.
const QUEUE: usize = 128;

/// What the observer's loop hands the writer.
enum Item {
    Frame(FrameHeader, Vec<f32>, u64),
    Reply(Box<ContactsHeader>, Vec<Contact>, u64),
}

/// The writer thread: writes what comes until the queue closes, handing frame buffers back for
/// reuse; returns the writer to finish, or the first error (the file is finished anyway).
fn write_queue(mut writer: Writer, items: mpsc::Receiver<Item>, spare: mpsc::Sender<Vec<f32>>) -> (Writer, Result<(), RecordingError>) {
    for item in items {
        let written = match item {
            Item::Frame(header, state, at) => {
                let r = writer.frame(&header, &state, at);
                let _ = spare.send(state);
                r
            }
            Item::Reply(header, contacts, at) => writer.contacts(&header, &contacts, at),
        };
        if let Err(e) = written {
            return (writer, Err(e));
        }
    }
    (writer, Ok(()))
}

pub fn run(args: RecordArgs) -> CliResult {
    // Before any client thread exists, so that every thread inherits the blocked set.
    block_termination_signals();
    let client = args.transport.client("lumen record")?;
    let mut observer = client.observe(args.session)?;
    observer.every_frame();
    let info = observer.info().clone();
    let options = WriterOptions { scene: !args.no_scene };
    let writer = Writer::create_with(&args.output, &info.spec, info.session, &info.transport.to_string(), options)?;
    // One line on stdout once observing: scripts and tests wait for it.
    println!("lumen record: recording session {} to {}", info.session, args.output.display());
    let _ = std::io::stdout().flush();
    let (to_writer, items) = mpsc::sync_channel::<Item>(QUEUE);
    let (spare_tx, spare) = mpsc::channel::<Vec<f32>>();
    let writing = std::thread::Builder::new()
        .name("record-writer".into())
        .spawn(move || write_queue(writer, items, spare_tx))
        .map_err(|source| crate::error::CliError::ThreadSpawn { name: "recording's writer", source })?;
    let mut gaps = Gaps::default();
    let mut last_signal_look = Instant::now();
    let outcome: Result<String, Error> = loop {
        if last_signal_look.elapsed() >= SIGNAL_POLL {
            last_signal_look = Instant::now();
            if let Some(sig) = wait_signal(Duration::ZERO) {
                break Ok(format!("signal {sig}"));
            }
        }
        let item = match observer.next(SIGNAL_POLL) {
            Ok(Observed::Frame { header, state }) => {
                gaps.frame(header.frame);
                let mut buf = spare.try_recv().unwrap_or_default();
                buf.clear();
                buf.extend_from_slice(state);
                Item::Frame(*header, buf, wall_ns())
            }
            Ok(Observed::Contacts(reply)) => {
                gaps.reply(reply.frame(), reply.header().skipped);
                Item::Reply(Box::new(*reply.header()), reply.contacts().to_vec(), wall_ns())
            }
            Err(Error::Timeout(_)) => continue,
            Err(Error::SessionEnded(_)) => break Ok("session ended".into()),
            Err(e) => break Err(e),
        };
        // Closed only when the writer failed: its error is reported below.
        if to_writer.send(item).is_err() {
            break Ok("the writer stopped".into());
        }
    };
    drop(to_writer);
    let (writer, wrote) = writing.join().map_err(|_| crate::error::CliError::ThreadPanicked { name: "recording's writer" })?;
    // Finish the file before reporting any error: what was recorded stays readable.
    let written = writer.finish(gaps.missed)?;
    wrote?;
    let why = outcome?;
    println!(
        "lumen record: {why}; {} frames, {} replies, {} contacts, {} scene updates, missed {} frames and {} replies, {} bytes in {}",
        written.frames,
        written.replies,
        written.contacts,
        written.scene,
        gaps.missed.frames,
        gaps.missed.replies,
        written.bytes,
        args.output.display()
    );
    if gaps.missed != Missed::default() {
        eprintln!(
            "lumen record: the recorder fell behind and missed {} frames and {} replies; drive the session more slowly (wait for each reply) for a complete recording",
            gaps.missed.frames, gaps.missed.replies
        );
    }
    Ok(())
}

/// Frame numbers the observer jumped over: a recorder that falls behind (16 frames over iceoryx2,
/// one over zenoh) loses frames; they are counted, never silently dropped.
#[derive(Debug, Default)]
struct Gaps {
    last_frame: Option<u64>,
    last_reply: Option<u64>,
    missed: Missed,
}

impl Gaps {
    fn frame(&mut self, n: u64) {
        if let Some(last) = self.last_frame {
            // A lower number means the client restarted its count (a reopened session): not a loss.
            self.missed.frames += n.saturating_sub(last + 1);
        }
        self.last_frame = Some(n);
    }

    /// `skipped`: frames the daemon itself did not answer (newest wins), not the recorder's loss.
    fn reply(&mut self, n: u64, skipped: u32) {
        if let Some(last) = self.last_reply {
            self.missed.replies += n.saturating_sub(last + 1).saturating_sub(skipped as u64);
        }
        self.last_reply = Some(n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_jumps_but_not_daemon_skips_or_restarts() {
        let mut g = Gaps::default();
        for n in [5, 6, 9, 10, 0, 1] {
            g.frame(n);
        }
        assert_eq!(g.missed.frames, 2); // 7 and 8
        for (n, skipped) in [(5, 0), (6, 0), (9, 2), (12, 0)] {
            g.reply(n, skipped);
        }
        assert_eq!(g.missed.replies, 2); // 7, 8 skipped by the daemon; 10, 11 lost
    }
}
