//! The worked example of `proto/README.md`, section 2, "Delta frames": its 78 bytes decode to the
//! state it names, and this encoder's zstd frame holds the 13 bytes it lists.

use lumen_proto::wire::{FrameHeader, FLAG_DELTA, FLAG_KEEP, FRAME_HEADER_BYTES};
use lumen_transport::delta::{Decoder, Encoder};

/// The bytes of the README's example, as printed there.
fn readme_bytes() -> Vec<u8> {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../proto/README.md")).unwrap();
    let start = text.find("The 78 bytes on\nzenoh:").expect("the example's heading");
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
    let delta = d.read(&bytes[FRAME_HEADER_BYTES..], 6).unwrap();
    assert_eq!((delta.base, delta.changed, delta.encoded), (3, 1, 22));
    let mut state = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0];
    d.apply(&mut state);
    assert_eq!(state, [1.0, 2.0, 3.0, 4.0, 5.5, 6.0]);
    // The zstd frame holds the 13 bytes the README lists.
    let raw = zstd::bulk::decompress(&bytes[56..], 64).unwrap();
    assert_eq!(raw, [0x02, 0, 0, 0, 0, 0, 0, 0, 0x20, 0, 0, 0, 0]);
    // This encoder writes the same message.
    let mut out = FrameHeader { flags: FLAG_DELTA | FLAG_KEEP, ..FrameHeader::new(7, 4, 1000, 6, 1) }.to_bytes().to_vec();
    Encoder::new().unwrap().encode(3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &[1.0, 2.0, 3.0, 4.0, 5.5, 6.0], &mut out).unwrap();
    assert_eq!(zstd::bulk::decompress(&out[56..], 64).unwrap(), raw);
    assert_eq!(out[..56], bytes[..56]);
}
