//! One session's frame processing, the same for both transports: check the frame, rebuild a
//! delta frame's state on the session's base, detect, build the reply, keep the base.
//! Allocation-free once the detector and the base have warmed up (error replies format their
//! message into the header's fixed buffer; only the pipeline's own error values allocate).

use crate::registry::Entry;
use lumen_detect::Detector;
use lumen_proto::wire::{ContactsHeader, FrameError, FrameHeader, Status, FLAG_TRUNCATED};
use lumen_proto::{Contact, StateLayout};
use lumen_transport::delta::{Decoder, Rows};
use std::sync::Arc;
use std::time::Instant;

/// A session's detector, layout and bookkeeping.
pub struct Engine {
    pub id: u64,
    /// `None`: an echo session (benchmarks): every frame gets an empty `Ok` reply.
    detector: Option<Detector>,
    max_contacts: usize,
    last_frame: Option<u64>,
    /// The state of the newest frame flagged keep and answered with status 0, and its number:
    /// what delta frames are made against.
    base: Vec<f32>,
    base_frame: Option<u64>,
    /// Made at the first delta frame: a session of full frames never pays for it.
    decoder: Option<Decoder>,
    pub entry: Arc<Entry>,
}

impl Engine {
    /// An engine for the session in `entry`, whose scene was validated when it opened.
    pub fn new(entry: Arc<Entry>, echo: bool) -> Self {
        let detector = (!echo).then(|| Detector::new(&entry.scene));
        Self { id: entry.info.session, detector, max_contacts: entry.info.max_contacts as usize, last_frame: None, base: Vec::new(), base_frame: None, decoder: None, entry }
    }

    /// Where each body's floats go in this session's frames (the scene's own layout).
    pub fn layout(&self) -> &StateLayout {
        self.entry.scene.layout()
    }

    /// Runs one full frame: `frame` is the header and floats if they were readable, else the
    /// header as far as it could be read and why it was refused. Returns the reply header and
    /// the contacts to send with it. A frame flagged keep and answered with status 0 becomes the
    /// session's base (a copy of its floats).
    pub fn run(&mut self, frame: Result<(FrameHeader, &[f32]), (FrameHeader, FrameError)>) -> (ContactsHeader, &[Contact]) {
        let (header, state) = match frame {
            Ok((h, s)) if !h.is_delta() => match h.check(self.id, self.entry.scene.layout(), s.len()) {
                Ok(()) => (h, s),
                Err(e) => return (self.refuse(&h, &e), &[]),
            },
            Ok((h, _)) => {
                let mut reply = self.refuse(&h, &FrameError::Flags { got: h.flags });
                reply.set_error(Status::Malformed, &"a delta frame was read as a full one (a daemon bug)");
                return (reply, &[]);
            }
            Err((h, e)) => return (self.refuse(&h, &e), &[]),
        };
        let mut reply = ContactsHeader::reply_to(&header);
        reply.skipped = self.skipped(&header);
        let n = Self::detect(&mut self.detector, &self.entry, self.max_contacts, state, &mut reply);
        if reply.status == 0 && header.keeps() {
            self.base.clear();
            self.base.extend_from_slice(state);
            self.base_frame = Some(header.frame);
        }
        (reply, self.contacts(n))
    }

    /// Runs one delta frame: `body` is everything after its header (the delta header and the
    /// coded rows). The state is rebuilt on the base in place; unless the frame is kept (flag
    /// keep, status 0) the base is put back as it was. With `whole`, a frame rebuilt is also
    /// written there as a full frame message (flags 0), for observers; left empty otherwise.
    pub fn run_delta(&mut self, header: FrameHeader, body: &[u8], whole: Option<&mut Vec<u8>>) -> (ContactsHeader, &[Contact]) {
        let floats = self.entry.scene.layout().floats;
        if let Err(e) = header.check(self.id, self.entry.scene.layout(), header.floats as usize) {
            return (self.refuse(&header, &e), &[]);
        }
        let mut reply = ContactsHeader::reply_to(&header);
        reply.skipped = self.skipped(&header);
        if self.decoder.is_none() {
            match Decoder::new() {
                Ok(d) => self.decoder = Some(d),
                Err(e) => {
                    reply.set_error(Status::Internal, &format_args!("no delta decoder: {e}"));
                    return (reply, &[]);
                }
            }
        }
        let decoder = self.decoder.as_mut().expect("made above");
        let delta = match decoder.read(body, floats, Rows::of(&header)) {
            Ok(d) => d,
            Err(e) => {
                reply.set_error(Status::BadDelta, &e);
                return (reply, &[]);
            }
        };
        if self.base_frame != Some(delta.base) || self.base.len() != floats {
            match self.base_frame {
                Some(held) => reply.set_error(Status::NoBase, &format_args!("delta against frame {}; the session's base is frame {held}: send a full frame", delta.base)),
                None => reply.set_error(Status::NoBase, &format_args!("delta against frame {}; the session holds no base (keep a full frame first)", delta.base)),
            }
            return (reply, &[]);
        }
        decoder.apply(&mut self.base);
        if let Some(out) = whole {
            out.clear();
            lumen_proto::wire::encode_frame(&FrameHeader { flags: 0, ..header }, &self.base, out);
        }
        let n = Self::detect(&mut self.detector, &self.entry, self.max_contacts, &self.base, &mut reply);
        let decoder = self.decoder.as_mut().expect("made above");
        if reply.status == 0 && header.keeps() {
            self.base_frame = Some(header.frame);
        } else {
            decoder.undo(&mut self.base);
        }
        (reply, self.contacts(n))
    }

    /// The first `n` contacts of the last detection.
    fn contacts(&self, n: usize) -> &[Contact] {
        match &self.detector {
            Some(d) if n > 0 => &d.contacts()[..n],
            _ => &[],
        }
    }

    /// Detects `state` into `reply` (status, count, timing); returns the contacts to send.
    fn detect(detector: &mut Option<Detector>, entry: &Entry, max_contacts: usize, state: &[f32], reply: &mut ContactsHeader) -> usize {
        let Some(det) = detector.as_mut() else { return 0 };
        // A pipeline panic on some finite but absurd input must not end the session (nor the
        // daemon): it is answered as an internal error and the detector starts afresh.
        let t0 = Instant::now();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| det.detect(state).map(|c| c.len())));
        reply.detect_ns = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        match outcome {
            Ok(Ok(found)) => {
                let n = found.min(max_contacts);
                if n < found {
                    reply.flags |= FLAG_TRUNCATED;
                }
                reply.count = n as u32;
                n
            }
            Ok(Err(e)) => {
                let spec = entry.scene.spec();
                reply.set_input_error(&e, |name| spec.body_index(name));
                0
            }
            Err(_) => {
                reply.set_error(Status::Internal, &"the detector failed on this frame; it was reset and the session goes on");
                *detector = Some(Detector::new(&entry.scene));
                0
            }
        }
    }

    fn refuse(&mut self, h: &FrameHeader, e: &FrameError) -> ContactsHeader {
        // Answered, if with an error: not skipped; a number beyond the range counts for nothing.
        if h.magic == lumen_proto::wire::FRAME_MAGIC && h.session == self.id && h.frame <= lumen_proto::wire::MAX_FRAME_NUMBER {
            self.last_frame = Some(h.frame);
        }
        let mut reply = ContactsHeader::reply_to(h);
        reply.session = self.id;
        reply.set_frame_error(e);
        reply
    }

    /// Frames skipped between the previous frame and this one (newest-wins).
    fn skipped(&mut self, h: &FrameHeader) -> u32 {
        let skipped = match self.last_frame {
            Some(last) if h.frame > last.saturating_add(1) => (h.frame - last - 1).min(u32::MAX as u64) as u32,
            _ => 0,
        };
        self.last_frame = Some(h.frame);
        skipped
    }

    /// Records a sent reply; `service` is the time from seeing the frame to the reply sent.
    pub fn record(&self, reply: &ContactsHeader, service: std::time::Duration) {
        let mut s = self.entry.stats.lock().expect("stats lock");
        s.frames += 1;
        s.skipped += reply.skipped as u64;
        if reply.status == 0 {
            s.contacts_last = reply.count;
            s.contacts_sum += reply.count as u64;
            s.detect.push(reply.detect_ns as u64);
        } else {
            s.bad_frames += 1;
        }
        s.service.push(service.as_nanos() as u64);
    }

    /// Periodic bookkeeping (frame rate).
    pub fn tick(&self) {
        self.entry.stats.lock().expect("stats lock").tick(Instant::now());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registry::Registry;
    use lumen_proto::session::{ControlReply, ControlRequest, Transport};
    use lumen_proto::wire::{FrameError, Status};

    fn engine() -> Engine {
        let reg = Registry::new(crate::config::Limits::default());
        let spec = lumen_scene::frames::spec();
        let req = ControlRequest::Open { version: 1, spec, client: "t".into(), echo: false, alive: String::new() };
        let mut entry = None;
        let r = crate::control::handle(&reg, Transport::Iceoryx2, &crate::access::Requester::Anyone, req, |p| {
            entry = Some(p.entry);
            Ok(())
        });
        assert!(matches!(r, ControlReply::Opened(_)));
        Engine::new(entry.unwrap(), false)
    }

    #[test]
    fn absurd_and_bad_frames_get_replies_and_good_ones_still_work() {
        let mut e = engine();
        let floats = e.layout().floats;
        let mut state = vec![0.0f32; floats];
        lumen_scene::frames::write_state(0, &mut state);
        let id = e.id;
        let h = |n| FrameHeader::new(id, n, 0, floats, 2);
        let (good, contacts) = e.run(Ok((h(0), &state)));
        assert_eq!((good.status, good.frame), (0, 0));
        let n_good = contacts.len();
        assert!(n_good > 0);
        // Finite but absurd coordinates: refused as out of range, naming where, never a panic
        // nor an answer with infinite depths.
        let huge: Vec<f32> = state.iter().map(|v| v * 1e30).collect();
        let (r, c) = e.run(Ok((h(1), &huge)));
        assert_eq!((r.status(), r.error_body, c.len()), (Some(Status::OutOfRange), 0, 0));
        let (r, _) = e.run(Ok((h(2), &state[1..])));
        assert_eq!(r.status(), Some(Status::BadLength));
        let (r, _) = e.run(Err((FrameHeader::default(), FrameError::TooShort { got: 3 })));
        assert_eq!((r.status(), r.session), (Some(Status::Malformed), id));
        // Frame 5 after frame 2: two skipped (3 and 4), and the same contacts as frame 0.
        let (r, c) = e.run(Ok((h(5), &state)));
        assert_eq!((r.status, r.skipped, c.len()), (0, 2, n_good));
    }

    #[test]
    fn delta_frames_rebuild_the_state_on_the_kept_base_and_never_damage_it() {
        use lumen_proto::wire::{FLAG_DELTA, FLAG_KEEP, FLAG_SCALED};
        // The encoder writes scaled deltas: every delta frame here carries both flags.
        const FLAG_DELTA_SCALED: u16 = FLAG_DELTA | FLAG_SCALED;
        let mut e = engine();
        let mut fresh = engine();
        let floats = e.layout().floats;
        let id = e.id;
        let state = |k: u64| {
            let mut s = vec![0.0f32; floats];
            lumen_scene::frames::write_state(k, &mut s);
            s
        };
        let h = |n, flags| FrameHeader { flags, ..FrameHeader::new(id, n, 0, floats, 2) };
        let mut enc = lumen_transport::delta::Encoder::new().unwrap();
        let delta = |enc: &mut lumen_transport::delta::Encoder, base_frame, base: &[f32], new: &[f32]| {
            let mut out = Vec::new();
            enc.encode(base_frame, base, new, &mut out).unwrap();
            out
        };
        // Before any kept frame there is no base.
        let d = delta(&mut enc, 0, &state(0), &state(1));
        assert_eq!(e.run_delta(h(0, FLAG_DELTA_SCALED), &d, None).0.status(), Some(Status::NoBase));
        // Frame 1 full and kept; frame 2 a kept delta on it; frame 3 an unkept delta on 2; frame
        // 4 again on 2 (3 was not kept): each answered as the full frame is by a fresh engine.
        assert_eq!(e.run(Ok((h(1, FLAG_KEEP), &state(1)))).0.status, 0);
        let check = |e: &mut Engine, fresh: &mut Engine, n: u64, flags: u16, body: &[u8]| {
            let (r, c) = e.run_delta(h(n, FLAG_DELTA_SCALED | flags), body, None);
            let (r, c) = (r, c.to_vec());
            let own = FrameHeader { session: fresh.id, ..h(n, 0) };
            let (f, fc) = fresh.run(Ok((own, &state(n))));
            assert_eq!((r.status, r.count, f.status), (0, f.count, 0), "frame {n}: {}", r.message());
            assert!(f.count > 0, "frame {n}");
            assert_eq!(format!("{c:?}"), format!("{fc:?}"), "frame {n}");
        };
        check(&mut e, &mut fresh, 2, FLAG_KEEP, &delta(&mut enc, 1, &state(1), &state(2)));
        check(&mut e, &mut fresh, 3, 0, &delta(&mut enc, 2, &state(2), &state(3)));
        let stale = delta(&mut enc, 1, &state(1), &state(4));
        let (r, _) = e.run_delta(h(4, FLAG_DELTA_SCALED | FLAG_KEEP), &stale, None);
        assert_eq!(r.status(), Some(Status::NoBase));
        assert!(r.message().contains("the session's base is frame 2"), "{}", r.message());
        check(&mut e, &mut fresh, 5, 0, &delta(&mut enc, 2, &state(2), &state(5)));
        // Damaged deltas and a delta to a non-finite state: refused, the base as it was.
        let good = delta(&mut enc, 2, &state(2), &state(6));
        let (r, _) = e.run_delta(h(6, FLAG_DELTA_SCALED | FLAG_KEEP), &good[..good.len() - 3], None);
        assert_eq!(r.status(), Some(Status::BadDelta), "{}", r.message());
        let mut nan = state(6);
        nan[7] = f32::NAN;
        let (r, _) = e.run_delta(h(7, FLAG_DELTA_SCALED | FLAG_KEEP), &delta(&mut enc, 2, &state(2), &nan), None);
        assert_eq!(r.status(), Some(Status::NonFinite));
        check(&mut e, &mut fresh, 8, FLAG_KEEP, &delta(&mut enc, 2, &state(2), &state(8)));
        check(&mut e, &mut fresh, 9, 0, &delta(&mut enc, 8, &state(8), &state(9)));
        // Written whole for observers: the full frame of state 10, flags 0.
        let mut whole = Vec::new();
        assert_eq!(e.run_delta(h(10, FLAG_DELTA_SCALED), &delta(&mut enc, 8, &state(8), &state(10)), Some(&mut whole)).0.status, 0);
        let mut full = Vec::new();
        lumen_proto::wire::encode_frame(&h(10, 0), &state(10), &mut full);
        assert!(whole == full);
        // A delta whose header says another float count is refused before it is read.
        let (r, _) = e.run_delta(FrameHeader { floats: 3, ..h(11, FLAG_DELTA_SCALED) }, &good, None);
        assert_eq!(r.status(), Some(Status::BadLength));
    }
}
