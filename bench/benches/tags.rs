//! Criterion benchmark of what ownership costs per zenoh message: the tag of a
//! colonoscopy-sized frame (40-byte header + 124,230 floats = 485 KiB, which the client computes
//! and the daemon checks) and of a reply of 160 contacts (the daemon computes, the client
//! checks): Lumen's tag (BLAKE3 keyed over the header and length, `header-tag`, and the gate's
//! check, `gate-admit`) beside, for the choice, BLAKE3 and HMAC-SHA256 (`ring`) over every byte.
//!
//! `cargo bench -p lumen-bench --bench tags`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lumen_proto::auth::{Gate, Secret};
use lumen_proto::wire::{CONTACTS_HEADER_BYTES, CONTACT_BYTES, FRAME_HEADER_BYTES};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let secret = Secret::from_bytes(std::array::from_fn(|i| i as u8 * 17));
    let hmac = ring::hmac::Key::new(ring::hmac::HMAC_SHA256, &[17; 16]);
    let mut g = c.benchmark_group("tag");
    for (name, head, bytes) in [("frame-485KiB", FRAME_HEADER_BYTES, FRAME_HEADER_BYTES + 4 * 124_230), ("reply-160", CONTACTS_HEADER_BYTES, CONTACTS_HEADER_BYTES + 160 * CONTACT_BYTES)] {
        let mut message: Vec<u8> = (0..bytes).map(|i| (i * 31 % 251) as u8).collect();
        g.throughput(Throughput::Bytes(bytes as u64));
        g.bench_function(format!("{name}/header-tag"), |b| b.iter(|| secret.message_tag(black_box(&message[..head]), bytes)));
        // The gate's whole check of one genuine message (its frame number goes up each time).
        let mut gate = Gate::new(secret.clone(), head);
        let mut frame = 0u64;
        g.bench_function(format!("{name}/tag-and-admit"), |b| {
            b.iter(|| {
                frame += 1;
                message[16..24].copy_from_slice(&frame.to_le_bytes());
                let tag = secret.message_tag(&message[..head], bytes);
                assert!(gate.admit(black_box(&message[..head]), bytes, &tag));
            })
        });
        let tag = secret.tag([message.as_slice()]);
        g.bench_function(format!("{name}/blake3-tag"), |b| b.iter(|| secret.tag([black_box(message.as_slice())])));
        g.bench_function(format!("{name}/blake3-verify"), |b| b.iter(|| assert!(secret.verify([black_box(message.as_slice())], &tag))));
        g.bench_function(format!("{name}/hmac-sha256-tag"), |b| b.iter(|| ring::hmac::sign(&hmac, black_box(&message))));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
