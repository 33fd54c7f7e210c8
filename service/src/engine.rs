//! One session's frame processing, the same for both transports: check the frame, detect,
//! build the reply. Allocation-free once the detector has warmed up (error replies format their
//! message into the header's fixed buffer; only the pipeline's own error values allocate).

use crate::registry::Entry;
use lumen_detect::Detector;
use lumen_proto::wire::{ContactsHeader, FrameError, FrameHeader, FLAG_TRUNCATED};
use lumen_proto::{Contact, SceneSpec, StateLayout};
use std::sync::Arc;
use std::time::Instant;

/// A session's detector, layout and bookkeeping.
pub struct Engine {
    pub id: u64,
    pub layout: StateLayout,
    spec: SceneSpec,
    /// `None`: an echo session (benchmarks): every frame gets an empty `Ok` reply.
    detector: Option<Detector>,
    max_contacts: usize,
    last_frame: Option<u64>,
    pub entry: Arc<Entry>,
}

impl Engine {
    /// An engine for the session in `entry` (its spec was validated when it opened).
    pub fn new(entry: Arc<Entry>, echo: bool) -> Result<Self, lumen_proto::SpecError> {
        let spec = entry.info.spec.clone();
        let detector = if echo { None } else { Some(Detector::new(&spec)?) };
        Ok(Self { id: entry.info.session, layout: StateLayout::of(&spec), spec, detector, max_contacts: entry.info.max_contacts as usize, last_frame: None, entry })
    }

    /// Runs one frame: `frame` is the header and floats if they were readable, else the header
    /// as far as it could be read and why it was refused. Returns the reply header and the
    /// contacts to send with it.
    pub fn run(&mut self, frame: Result<(FrameHeader, &[f32]), (FrameHeader, FrameError)>) -> (ContactsHeader, &[Contact]) {
        let (header, state) = match frame {
            Ok((h, s)) => match h.check(self.id, &self.layout, s.len()) {
                Ok(()) => (h, s),
                Err(e) => return (self.refuse(&h, &e), &[]),
            },
            Err((h, e)) => return (self.refuse(&h, &e), &[]),
        };
        let mut reply = ContactsHeader::reply_to(&header);
        reply.skipped = self.skipped(&header);
        let Some(detector) = self.detector.as_mut() else { return (reply, &[]) };
        let t0 = Instant::now();
        let result = detector.detect(state);
        reply.detect_ns = t0.elapsed().as_nanos().min(u32::MAX as u128) as u32;
        match result {
            Ok(contacts) => {
                let n = contacts.len().min(self.max_contacts);
                if n < contacts.len() {
                    reply.flags |= FLAG_TRUNCATED;
                }
                reply.count = n as u32;
                (reply, &contacts[..n])
            }
            Err(e) => {
                let spec = &self.spec;
                reply.set_input_error(&e, |name| spec.body_index(name));
                (reply, &[])
            }
        }
    }

    fn refuse(&mut self, h: &FrameHeader, e: &FrameError) -> ContactsHeader {
        let mut reply = ContactsHeader::reply_to(h);
        reply.session = self.id;
        reply.set_frame_error(e);
        reply
    }

    /// Frames skipped between the previous frame and this one (newest-wins).
    fn skipped(&mut self, h: &FrameHeader) -> u32 {
        let skipped = match self.last_frame {
            Some(last) if h.frame > last + 1 => (h.frame - last - 1).min(u32::MAX as u64) as u32,
            _ => 0,
        };
        self.last_frame = Some(h.frame);
        skipped
    }

    /// Records a sent reply; `received` is when the daemon saw the frame.
    pub fn record(&self, reply: &ContactsHeader, received: Instant) {
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
        s.service.push(received.elapsed().as_nanos() as u64);
    }

    /// Periodic bookkeeping (frame rate).
    pub fn tick(&self) {
        self.entry.stats.lock().expect("stats lock").tick(Instant::now());
    }
}
