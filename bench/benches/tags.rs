//! Criterion benchmark of what ownership costs per zenoh message (issue 16): the tag of a
//! colonoscopy-sized frame (40-byte header + 124,230 floats = 485 KiB, which the client computes
//! and the daemon checks) and of a reply of 160 contacts (the daemon computes, the client
//! checks), with Lumen's tag (BLAKE3 keyed) and, for the choice, HMAC-SHA256 (`ring`).
//!
//! `cargo bench -p lumen-bench --bench tags`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lumen_proto::auth::Secret;
use lumen_proto::wire::{CONTACTS_HEADER_BYTES, CONTACT_BYTES, FRAME_HEADER_BYTES};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let secret = Secret::from_bytes(std::array::from_fn(|i| i as u8 * 17));
    let hmac = ring::hmac::Key::new(ring::hmac::HMAC_SHA256, &[17; 16]);
    let mut g = c.benchmark_group("tag");
    for (name, bytes) in [("frame-485KiB", FRAME_HEADER_BYTES + 4 * 124_230), ("reply-160", CONTACTS_HEADER_BYTES + 160 * CONTACT_BYTES)] {
        let message: Vec<u8> = (0..bytes).map(|i| (i * 31 % 251) as u8).collect();
        let tag = secret.tag([message.as_slice()]);
        g.throughput(Throughput::Bytes(bytes as u64));
        g.bench_function(format!("{name}/blake3-tag"), |b| b.iter(|| secret.tag([black_box(message.as_slice())])));
        g.bench_function(format!("{name}/blake3-verify"), |b| b.iter(|| assert!(secret.verify([black_box(message.as_slice())], &tag))));
        g.bench_function(format!("{name}/hmac-sha256-tag"), |b| b.iter(|| ring::hmac::sign(&hmac, black_box(&message))));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
