//! What each topic of a recording costs on disk: its messages' bytes, and the bytes of an MCAP
//! holding that topic alone with the recorder's options (zstd chunks), per recorded frame; the
//! frames also by kind (whole, delta, anchored key frame), before the chunks' zstd, and the scene
//! by the updates that carry the colon and those that do not.
//!
//! `cargo run --release -p lumen-cli --example topic_cost -- demo/run.mcap`

use std::collections::BTreeMap;
use std::io::Cursor;

fn main() {
    let path = std::env::args().nth(1).expect("a recording: topic_cost RUN.MCAP");
    let bytes = std::fs::read(&path).expect("the recording");
    let mut topics: BTreeMap<String, Vec<mcap::Message>> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a message");
        topics.entry(m.channel.topic.clone()).or_default().push(m);
    }
    let frames = topics.get(lumen_cli::recording::FRAMES_TOPIC).map_or(1, Vec::len).max(1);
    println!("{path}: {} bytes, {frames} frames, {:.1} KB a frame", bytes.len(), bytes.len() as f64 / frames as f64 / 1e3);
    println!("| topic | messages | message bytes | alone, zstd chunks | KB a frame |");
    println!("|---|---:|---:|---:|---:|");
    for (topic, messages) in &topics {
        let raw: usize = messages.iter().map(|m| m.data.len()).sum();
        let whole = alone(topic, messages.iter());
        println!("| {topic} | {} | {raw} | {whole} | {:.2} |", messages.len(), whole as f64 / frames as f64 / 1e3);
        if topic == lumen_cli::recording::SCENE_TOPIC {
            // The updates that carry the colon (a tube's triangles), and the others.
            let (colon, other): (Vec<_>, Vec<_>) = messages.iter().partition(|m| m.data.windows(6).any(|w| w == b"\"tube/"));
            for (what, part) in [("with the colon", colon), ("without it", other)] {
                let n = part.len();
                let bytes = alone(topic, part.into_iter());
                println!("|   {what} | {n} | | {bytes} | {:.1} KB an update |", bytes as f64 / n.max(1) as f64 / 1e3);
            }
        }
        if topic == lumen_cli::recording::FRAMES_TOPIC {
            // By kind (the u32 after the 40-byte header): key frames, deltas.
            let mut kinds: BTreeMap<u32, (usize, usize)> = BTreeMap::new();
            for m in messages {
                let k = m.data.get(40..44).map_or(u32::MAX, |w| u32::from_le_bytes(w.try_into().unwrap()));
                let e = kinds.entry(k).or_default();
                (e.0, e.1) = (e.0 + 1, e.1 + m.data.len());
            }
            for (k, (n, b)) in kinds {
                println!("|   kind {k} | {n} | {b} | | {:.2} (uncompressed) |", b as f64 / frames as f64 / 1e3);
            }
        }
    }
}

/// Bytes of an MCAP holding `messages` alone on one channel `topic`, with the recorder's options
/// (zstd chunks).
fn alone<'a>(topic: &str, messages: impl Iterator<Item = &'a mcap::Message<'a>>) -> usize {
    let options = mcap::WriteOptions::new().compression(Some(mcap::Compression::Zstd));
    let mut w = options.create(Cursor::new(Vec::new())).expect("a writer");
    let mut channels = BTreeMap::new();
    for m in messages {
        let ch = *channels.entry(m.channel.id).or_insert_with(|| w.add_channel(0, topic, &m.channel.message_encoding, &BTreeMap::new()).expect("a channel"));
        let header = mcap::records::MessageHeader { channel_id: ch, sequence: m.sequence, log_time: m.log_time, publish_time: m.publish_time };
        w.write_to_known_channel(&header, &m.data).expect("a message");
    }
    w.finish().expect("finished");
    w.into_inner().into_inner().len()
}
