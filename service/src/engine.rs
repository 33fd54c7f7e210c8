//! One session's frame processing, the same for both transports: check the frame, detect,
//! build the reply. Allocation-free once the detector has warmed up (error replies format their
//! message into the header's fixed buffer; only the pipeline's own error values allocate).

use crate::registry::Entry;
use lumen_detect::Detector;
use lumen_proto::wire::{ContactsHeader, FrameError, FrameHeader, FLAG_TRUNCATED};
use lumen_proto::{Contact, StateLayout};
use std::sync::Arc;
use std::time::Instant;

/// A session's detector, layout and bookkeeping.
pub struct Engine {
    pub id: u64,
    /// `None`: an echo session (benchmarks): every frame gets an empty `Ok` reply.
    detector: Option<Detector>,
    max_contacts: usize,
    last_frame: Option<u64>,
    pub entry: Arc<Entry>,
}

impl Engine {
    /// An engine for the session in `entry`, whose scene was validated when it opened.
    pub fn new(entry: Arc<Entry>, echo: bool) -> Self {
        let detector = (!echo).then(|| Detector::new(&entry.scene));
        Self { id: entry.info.session, detector, max_contacts: entry.info.max_contacts as usize, last_frame: None, entry }
    }

    /// Where each body's floats go in this session's frames (the scene's own layout).
    pub fn layout(&self) -> &StateLayout {
        self.entry.scene.layout()
    }

    /// Runs one frame: `frame` is the header and floats if they were readable, else the header
    /// as far as it could be read and why it was refused. Returns the reply header and the
    /// contacts to send with it.
    pub fn run(&mut self, frame: Result<(FrameHeader, &[f32]), (FrameHeader, FrameError)>) -> (ContactsHeader, &[Contact]) {
        let (header, state) = match frame {
            Ok((h, s)) => match h.check(self.id, self.entry.scene.layout(), s.len()) {
                Ok(()) => (h, s),
                Err(e) => return (self.refuse(&h, &e), &[]),
            },
            Err((h, e)) => return (self.refuse(&h, &e), &[]),
        };
        let mut reply = ContactsHeader::reply_to(&header);
        reply.skipped = self.skipped(&header);
        if self.detector.is_none() {
            return (reply, &[]);
        }
        // A pipeline panic on some finite but absurd input must not end the session (nor the
        // daemon): it is answered as an internal error and the detector starts afresh.
        let t0 = Instant::now();
        let detector = self.detector.as_mut().expect("checked");
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| detector.detect(state).map(|c| c.len())));
        reply.detect_ns = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        match outcome {
            Ok(Ok(found)) => {
                let contacts = self.detector.as_ref().expect("present").contacts();
                let n = found.min(self.max_contacts);
                if n < found {
                    reply.flags |= FLAG_TRUNCATED;
                }
                reply.count = n as u32;
                (reply, &contacts[..n])
            }
            Ok(Err(e)) => {
                let spec = self.entry.scene.spec();
                reply.set_input_error(&e, |name| spec.body_index(name));
                (reply, &[])
            }
            Err(_) => {
                reply.set_error(lumen_proto::wire::Status::Internal, &"the detector failed on this frame; it was reset and the session goes on");
                self.detector = Some(Detector::new(&self.entry.scene));
                (reply, &[])
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
}
