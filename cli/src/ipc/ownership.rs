//! What session ownership costs a zenoh round trip, timed in this process on the run's own frame
//! (`proto/README.md`, section 6): the client tags its frame, the daemon's gate admits it, the
//! daemon tags its reply, the client's gate admits that. The same functions the client and the
//! daemon call ([`Secret::message_tag`], [`admit_parts`]), on the same bytes, without the
//! network: the round trips themselves move by far more than this from run to run.

use lumen_proto::auth::{Gate, Secret};
use lumen_proto::wire::{encode_contacts, encode_frame, ContactsHeader, FrameHeader, CONTACTS_HEADER_BYTES, FRAME_HEADER_BYTES};
use lumen_proto::Contact;
use lumen_transport::net::admit_parts;
use serde::Serialize;
use std::sync::Mutex;
use std::time::Instant;

/// Round trips timed per batch (a batch's mean is one sample: single calls are too short for
/// the clock).
const BATCH: usize = 1000;

/// The ownership work of one round trip.
#[derive(Debug, Clone, Serialize)]
pub struct Ownership {
    /// Bytes of the frame and of the reply tagged and checked.
    pub frame_bytes: usize,
    pub reply_bytes: usize,
    /// Median and p99 over batches of the mean time of one round trip's work, microseconds.
    pub p50_us: f64,
    pub p99_us: f64,
    pub batches: usize,
}

/// Times `batches` batches of the ownership work of a round trip whose frame carries `state`
/// and whose reply carries `contacts` records.
pub fn measure(state: &[f32], bodies: usize, contacts: usize, batches: usize) -> Ownership {
    let secret = Secret::from_bytes(std::array::from_fn(|i| (i as u8).wrapping_mul(29)));
    let mut frame = Vec::new();
    encode_frame(&FrameHeader::new(1, 0, 0, state.len(), bodies), state, &mut frame);
    let mut reply = Vec::new();
    encode_contacts(&mut ContactsHeader::reply_to(&FrameHeader::new(1, 0, 0, state.len(), bodies)), &vec![Contact::default(); contacts], &mut reply);
    let (daemon_gate, client_gate) = (Mutex::new(Gate::new(secret.clone(), FRAME_HEADER_BYTES)), Mutex::new(Gate::new(secret.clone(), CONTACTS_HEADER_BYTES)));
    let mut means = Vec::with_capacity(batches);
    let mut n = 0u64;
    for _ in 0..batches {
        let t0 = Instant::now();
        for _ in 0..BATCH {
            n += 1;
            // Each round trip's frame number goes up, as the gates require.
            frame[16..24].copy_from_slice(&n.to_le_bytes());
            reply[16..24].copy_from_slice(&n.to_le_bytes());
            let tag = secret.message_tag(&frame[..FRAME_HEADER_BYTES], frame.len());
            assert!(admit_parts(&daemon_gate, [frame.as_slice()], frame.len(), &tag), "the daemon's gate admits the owner's frame");
            let tag = secret.message_tag(&reply[..CONTACTS_HEADER_BYTES], reply.len());
            assert!(admit_parts(&client_gate, [reply.as_slice()], reply.len(), &tag), "the client's gate admits the daemon's reply");
        }
        means.push(t0.elapsed().as_nanos() as u64 / BATCH as u64);
    }
    Ownership { frame_bytes: frame.len(), reply_bytes: reply.len(), p50_us: super::quantile_us(&mut means, 0.5), p99_us: super::quantile_us(&mut means, 0.99), batches }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_round_trips_ownership_work_is_timed_on_the_frame_given() {
        let o = super::measure(&vec![1.0; 1000], 2, 10, 3);
        assert_eq!((o.frame_bytes, o.reply_bytes, o.batches), (40 + 4000, 256 + 880, 3));
        assert!(o.p50_us > 0.0 && o.p50_us <= o.p99_us, "{o:?}");
    }
}
