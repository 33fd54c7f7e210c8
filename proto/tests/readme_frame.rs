//! Decodes the frame written by hand in `proto/README.md` (section 5), straight from the
//! document, so the document and the code cannot drift apart.

use lumen_proto::wire::{decode_frame, FrameHeader, FRAME_HEADER_BYTES, FRAME_MAGIC, PROTOCOL_VERSION};
use lumen_proto::{BodySpec, SceneSpec, Shape, StateLayout};

fn readme_hex_frame() -> Vec<u8> {
    let doc = include_str!("../README.md");
    let section = doc.split("## 5.").nth(1).expect("README has a section 5");
    let block = section.split("```").nth(1).expect("section 5 has a code block");
    block.split_whitespace().map(|h| u8::from_str_radix(h, 16).expect("hex byte")).collect()
}

#[test]
fn hand_written_frame_decodes() {
    let bytes = readme_hex_frame();
    assert_eq!(bytes.len(), 64);
    let spec = SceneSpec::new(vec![BodySpec { name: "rod".into(), shape: Shape::Rod { points: 2, radius: vec![1.0] } }], vec![]);
    let layout = StateLayout::of(&spec);
    let mut state = Vec::with_capacity(layout.floats);
    let header = decode_frame(&bytes, 7, &layout, &mut state).expect("the README's frame is valid");
    assert_eq!(header, FrameHeader { magic: FRAME_MAGIC, version: PROTOCOL_VERSION, flags: 0, session: 7, frame: 3, client_time_ns: 1000, floats: 6, bodies: 1 });
    assert_eq!(state, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    // The same header built in code gives the README's first 40 bytes.
    assert_eq!(FrameHeader::new(7, 3, 1000, 6, 1).to_bytes()[..], bytes[..FRAME_HEADER_BYTES]);
    // Claimed for another session, it is refused with the reason.
    let err = decode_frame(&bytes, 8, &layout, &mut state).unwrap_err().1;
    assert_eq!(err.to_string(), "frame names session 7; this is session 8");
}

#[test]
fn section_6_worked_example_is_what_the_code_computes() {
    let doc = include_str!("../README.md");
    let section = doc.split("## 6.").nth(1).expect("README has a section 6");
    let blocks: Vec<&str> = section.split("```").skip(1).step_by(2).map(str::trim).collect();
    let secret = lumen_proto::auth::Secret::parse("000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f").unwrap();
    assert!(section.contains("`000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f`"));
    assert_eq!(blocks[0], secret.close_proof(42));
    assert_eq!(blocks[1], format!("lumen/session/42/client/{}", secret.alive_chunk(42)));
    let frame = readme_hex_frame();
    let tag: String = secret.message_tag(&frame[..FRAME_HEADER_BYTES], frame.len()).iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(blocks[2], tag);
    assert!(secret.verify_close(42, blocks[0]));
    assert!(!secret.verify_close(43, blocks[0]));
}
