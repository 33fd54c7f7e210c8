//! What the Foxglove scene channel costs a recording of the generated colonoscopy (1,250 x 32
//! colon, 160-point scope, the detector's contacts): bytes and the writer's time with and
//! without it, frames logged at 1 kHz (an unpaced physics, `lumen demo`'s rate) and at 60 Hz.
//! Prints the figures of `service/README.md`:
//! `cargo run --release -p lumen-cli --example scene_cost`.

use lumen_cli::foxglove::SceneWriter;
use lumen_cli::recording::{Missed, Writer, WriterOptions};
use lumen_proto::wire::{ContactsHeader, FrameHeader};
use lumen_proto::Contact;

fn temp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("lumen_scene_cost_{}_{name}", std::process::id()))
}

fn main() {
    const N: usize = 600;
    let (spec, states) = lumen_scene::frames::generated(N);
    let mut detector = lumen_detect::Detector::new(&spec.validate().unwrap());
    let replies: Vec<Vec<Contact>> = states.iter().map(|s| detector.detect(s).unwrap().to_vec()).collect();
    let contacts: usize = replies.iter().map(Vec::len).sum();
    println!("{N} frames, {contacts} contacts ({:.1} per reply)", contacts as f64 / N as f64);
    for (rate, step_ns) in [("1 kHz", 1_000_000u64), ("60 Hz", 16_666_667)] {
        // The JSON alone (no MCAP, no file), one reused buffer.
        let (mut sw, mut out, mut bytes) = (SceneWriter::new(&spec), Vec::new(), [0usize; 2]);
        let start = std::time::Instant::now();
        for (k, (s, c)) in states.iter().zip(&replies).enumerate() {
            out.clear();
            let _ = sw.frame(1_000_000_000 + k as u64 * step_ns, s, &mut out);
            bytes[0] += out.len();
            out.clear();
            let _ = sw.contacts(1_000_000_000 + k as u64 * step_ns, c, &mut out);
            bytes[1] += out.len();
        }
        let took = start.elapsed();
        println!("{rate}, the scene's JSON alone: {} bytes of frame updates, {} of contact updates, {:.3} s", bytes[0], bytes[1], took.as_secs_f64());
        for scene in [true, false] {
            let path = temp(&format!("cost_{scene}.mcap"));
            let start = std::time::Instant::now();
            let mut w = Writer::create_with(&path, &spec, 1, "test", WriterOptions { scene }).unwrap();
            for (k, (s, c)) in states.iter().zip(&replies).enumerate() {
                let h = FrameHeader::new(1, k as u64, 1_000_000_000 + k as u64 * step_ns, s.len(), 2);
                w.frame(&h, s, 1).unwrap();
                let mut reply = ContactsHeader::reply_to(&h);
                reply.count = c.len() as u32;
                w.contacts(&reply, c, 1).unwrap();
            }
            let written = w.finish(Missed::default()).unwrap();
            let took = start.elapsed();
            println!(
                "{rate}, scene {}: {} bytes ({:.1} KB per frame), {} scene updates, {:.3} s ({:.0} us per frame and reply)",
                if scene { "on " } else { "off" },
                written.bytes,
                written.bytes as f64 / N as f64 / 1e3,
                written.scene,
                took.as_secs_f64(),
                took.as_secs_f64() * 1e6 / N as f64
            );
            let _ = std::fs::remove_file(&path);
        }
    }
}
