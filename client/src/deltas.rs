//! The client's side of delta frames over zenoh (`proto/README.md`, section 2, "Delta frames"):
//! which base the daemon holds, and whether the next frame goes whole or as what changed.
//!
//! Every frame is flagged keep. A frame goes as a delta against the base (the newest kept frame
//! whose status-0 reply came back) when no other kept frame awaits its reply and the delta is
//! smaller than the whole frame; otherwise whole. While a kept frame waits for its reply, its
//! state is held (a whole frame's as a copy, a delta's as the encoder's last delta): when the
//! reply says 0 it becomes the base. A reply that says the daemon
//! has no such base, or a later frame's reply first (the kept frame was skipped or lost), makes
//! the next frame whole: the daemon's base is then not known.

use lumen_proto::wire::{encode_frame, FrameHeader, Status, FLAG_KEEP, FRAME_HEADER_BYTES};
use lumen_transport::delta::{DeltaError, Encoder};

/// How a session's frames went out.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameCounts {
    /// Frames sent whole.
    pub full: u64,
    /// Frames sent as a delta.
    pub delta: u64,
    /// Bytes of every frame message sent (headers included).
    pub bytes: u64,
    /// Bytes of the newest frame message sent.
    pub last_bytes: u64,
}

/// The base a session's deltas are made against, and the kept frame awaiting its reply.
pub(crate) struct Deltas {
    /// Whether deltas are sent at all (zenoh sessions: on unless turned off).
    pub(crate) on: bool,
    encoder: Option<Encoder>,
    base: Vec<f32>,
    base_frame: Option<u64>,
    /// The kept frame awaiting its reply, and how to make it the base when the reply says 0.
    pending: Option<(u64, Pending)>,
    pending_state: Vec<f32>,
    pub(crate) counts: FrameCounts,
}

/// Where a kept frame's state is while its reply is awaited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// Copied whole into `pending_state` (a whole frame).
    Whole,
    /// In the encoder's last delta, against the base (applied to it on the reply).
    Delta,
}

impl Deltas {
    pub(crate) fn new(on: bool) -> Self {
        Self { on, encoder: None, base: Vec::new(), base_frame: None, pending: None, pending_state: Vec::new(), counts: FrameCounts::default() }
    }

    /// Forgets the base (a reopened session: the new one holds none).
    pub(crate) fn reset(&mut self) {
        self.base_frame = None;
        self.pending = None;
    }

    /// Notes a reply to frame `frame` with status `status`, whether or not it is returned.
    pub(crate) fn answered(&mut self, frame: u64, status: u16) {
        if status == Status::NoBase as u16 {
            self.base_frame = None;
        }
        match self.pending {
            Some((p, how)) if frame == p => {
                if status == 0 {
                    match how {
                        Pending::Whole => std::mem::swap(&mut self.base, &mut self.pending_state),
                        Pending::Delta => self.encoder.as_ref().expect("a delta was encoded").apply_last(&mut self.base),
                    }
                    self.base_frame = Some(p);
                }
                self.pending = None;
            }
            Some((p, _)) if frame > p => {
                // Its reply never came (skipped, lost, or dropped unread): kept or not, unknown.
                self.pending = None;
                self.base_frame = None;
            }
            _ => {}
        }
    }

    /// Writes the message of frame `header` holding `state` into `out` (emptied first): a delta
    /// when one can go, else the whole frame; `header.flags` says which. A header the caller
    /// flagged itself goes whole as it is.
    pub(crate) fn write(&mut self, header: &mut FrameHeader, state: &[f32], out: &mut Vec<u8>) -> Result<(), DeltaError> {
        out.clear();
        if !self.on || header.flags != 0 {
            encode_frame(header, state, out);
            self.sent(out.len(), false);
            return Ok(());
        }
        let full = FRAME_HEADER_BYTES + 4 * state.len();
        if self.pending.is_none() {
            if let Some(base_frame) = self.base_frame.filter(|_| self.base.len() == state.len()) {
                out.resize(FRAME_HEADER_BYTES, 0);
                let encoder = match &mut self.encoder {
                    Some(e) => e,
                    None => self.encoder.insert(Encoder::new()?),
                };
                encoder.encode(base_frame, &self.base, state, out)?;
                if out.len() < full {
                    header.flags = encoder.rows().flags() | FLAG_KEEP;
                    out[..FRAME_HEADER_BYTES].copy_from_slice(&header.to_bytes());
                    // No whole copy: the encoder holds what changed until the reply comes
                    // (no other delta is encoded while this one waits).
                    self.pending = Some((header.frame, Pending::Delta));
                    self.sent(out.len(), true);
                    return Ok(());
                }
                out.clear();
            }
            header.flags = FLAG_KEEP;
            self.keep(header.frame, state);
        }
        encode_frame(header, state, out);
        self.sent(out.len(), false);
        Ok(())
    }

    fn keep(&mut self, frame: u64, state: &[f32]) {
        self.pending = Some((frame, Pending::Whole));
        self.pending_state.clear();
        self.pending_state.extend_from_slice(state);
    }

    fn sent(&mut self, bytes: usize, delta: bool) {
        let c = &mut self.counts;
        if delta {
            c.delta += 1;
        } else {
            c.full += 1;
        }
        c.bytes += bytes as u64;
        c.last_bytes = bytes as u64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumen_proto::wire::{FLAG_DELTA, FLAG_SCALED};

    #[test]
    fn frames_go_whole_until_a_kept_one_is_answered_then_as_deltas() {
        let mut d = Deltas::new(true);
        let state = |k: u32| (0..3000).map(|i| if i < 30 { (i + k) as f32 } else { i as f32 }).collect::<Vec<f32>>();
        let h = |n| FrameHeader::new(1, n, 0, 3000, 1);
        let send = |d: &mut Deltas, n: u64, k: u32| {
            let (mut header, mut out) = (h(n), Vec::new());
            d.write(&mut header, &state(k), &mut out).unwrap();
            (header.flags, out.len())
        };
        // Whole and kept; while its reply is out, whole and not kept.
        assert_eq!(send(&mut d, 0, 0), (FLAG_KEEP, 12_040));
        assert_eq!(send(&mut d, 1, 1), (0, 12_040));
        d.answered(0, 0);
        let (flags, bytes) = send(&mut d, 2, 2);
        assert_eq!(flags, FLAG_DELTA | FLAG_SCALED | FLAG_KEEP);
        assert!(bytes < 200, "{bytes} bytes for 10 changed rows");
        d.answered(2, 0);
        assert_eq!(send(&mut d, 3, 3).0, FLAG_DELTA | FLAG_SCALED | FLAG_KEEP);
        // Its reply is an error: the base stays frame 2, the next delta is against it.
        d.answered(3, Status::NonFinite as u16);
        assert_eq!(send(&mut d, 4, 4).0, FLAG_DELTA | FLAG_SCALED | FLAG_KEEP);
        // A later frame answered first: frame 4's fate unknown, so whole again.
        d.answered(5, 0);
        assert_eq!(send(&mut d, 6, 6).0, FLAG_KEEP);
        d.answered(6, 0);
        assert_eq!(send(&mut d, 7, 7).0, FLAG_DELTA | FLAG_SCALED | FLAG_KEEP);
        // The daemon has no such base: whole again.
        d.answered(7, Status::NoBase as u16);
        assert_eq!(send(&mut d, 8, 8).0, FLAG_KEEP);
        // Turned off, or a header flagged by the caller: whole, untouched.
        d.answered(8, 0);
        let (mut own, mut out) = (FrameHeader { flags: 4, ..h(9) }, Vec::new());
        d.write(&mut own, &state(9), &mut out).unwrap();
        assert_eq!((own.flags, out[6]), (4, 4));
        d.on = false;
        assert_eq!(send(&mut d, 10, 10).0, 0);
        assert_eq!((d.counts.delta, d.counts.full), (4, 6));
    }
}
