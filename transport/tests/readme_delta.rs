//! The worked examples of `proto/README.md`, section 2, "Delta frames": the plain delta's 78 bytes
//! decode to the state it names, and this encoder's zstd frame holds the 13 bytes it lists; the
//! scaled delta's 17 bytes rebuild the lengthened row, and this encoder writes them.

use lumen_proto::wire::{DeltaHeader, FrameHeader, FLAG_DELTA, FLAG_KEEP, FLAG_SCALED, FRAME_HEADER_BYTES};
use lumen_transport::delta::{Decoder, Encoder, Rows};

/// The bytes of the README's example, as printed there.
fn readme_bytes() -> Vec<u8> {
    block_after("The 78 bytes on\nzenoh:")
}

/// The hexadecimal bytes of the first fenced block after `heading` in the README.
fn block_after(heading: &str) -> Vec<u8> {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../proto/README.md")).unwrap();
    let start = text.find(heading).expect("the example's heading");
    let block = text[start..].split("```").nth(1).expect("its fenced block");
    block.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

#[test]
fn the_readmes_delta_decodes_to_the_state_it_names() {
    let bytes = readme_bytes();
    assert_eq!(bytes.len(), 78);
    let header = FrameHeader::read(&bytes).unwrap();
    assert_eq!((header.session, header.frame, header.client_time_ns, header.floats, header.bodies), (7, 4, 1000, 6, 1));
    assert_eq!(header.flags, FLAG_DELTA | FLAG_KEEP);
    let mut d = Decoder::new().unwrap();
    let delta = d.read(&bytes[FRAME_HEADER_BYTES..], 6, Rows::of(&header)).unwrap();
    assert_eq!((delta.base, delta.changed, delta.encoded), (3, 1, 22));
    let mut state = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0];
    d.apply(&mut state);
    assert_eq!(state, [1.0, 2.0, 3.0, 4.0, 5.5, 6.0]);
    // The zstd frame holds the 13 bytes the README lists.
    let raw = zstd::bulk::decompress(&bytes[56..], 64).unwrap();
    assert_eq!(raw, [0x02, 0, 0, 0, 0, 0, 0, 0, 0x20, 0, 0, 0, 0]);
    // This encoder writes the same message.
    let mut out = FrameHeader { flags: FLAG_DELTA | FLAG_KEEP, ..FrameHeader::new(7, 4, 1000, 6, 1) }.to_bytes().to_vec();
    Encoder::with_rows(Rows::Plain).unwrap().encode(3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &[1.0, 2.0, 3.0, 4.0, 5.5, 6.0], &mut out).unwrap();
    assert_eq!(zstd::bulk::decompress(&out[56..], 64).unwrap(), raw);
    assert_eq!(out[..56], bytes[..56]);
}

#[test]
fn the_readmes_scaled_delta_rebuilds_the_lengthened_row() {
    let raw = block_after("17 bytes, and the header's flags are 7");
    assert_eq!(raw.len(), 17);
    assert_eq!(FLAG_DELTA | FLAG_KEEP | FLAG_SCALED, 7);
    let coded = zstd::bulk::compress(&raw, 3).unwrap();
    let mut body = DeltaHeader { base: 3, changed: 1, encoded: coded.len() as u32 }.to_bytes().to_vec();
    body.extend(&coded);
    let header = FrameHeader { flags: 7, ..FrameHeader::new(7, 4, 1000, 6, 1) };
    let mut d = Decoder::new().unwrap();
    d.read(&body, 6, Rows::of(&header)).unwrap();
    let mut state = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0];
    d.apply(&mut state);
    assert_eq!(state, [1.0, 2.0, 3.0, 6.0, 7.5, 9.0]);
    // This encoder chooses the same scale and writes the same bytes.
    let mut out = Vec::new();
    let mut enc = Encoder::new().unwrap();
    assert_eq!(enc.rows().flags() | FLAG_KEEP, 7);
    enc.encode(3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &[1.0, 2.0, 3.0, 6.0, 7.5, 9.0], &mut out).unwrap();
    assert_eq!(zstd::bulk::decompress(&out[16..], 64).unwrap(), raw);
}
