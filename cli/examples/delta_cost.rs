//! What delta frames cost and save on a recorded colonoscopy: for each pair of consecutive
//! frames of a recording (`lumen demo` writes `run.mcap`), the delta's bytes, the client's
//! encoding time and the daemon's decoding time (read and rebuild on the base).
//!
//! `cargo run --release -p lumen-cli --example delta_cost -- demo/run.mcap`

use lumen_cli::recording::Recording;
use lumen_transport::delta::{Decoder, Encoder};
use std::time::Instant;

fn main() {
    let path = std::env::args().nth(1).expect("usage: delta_cost RECORDING.mcap");
    let rec = Recording::open(std::path::Path::new(&path)).unwrap_or_else(|e| panic!("{e}"));
    let (mut enc, mut dec) = (Encoder::new().unwrap(), Decoder::new().unwrap());
    let (mut bytes, mut encode, mut decode) = (Vec::new(), Vec::new(), Vec::new());
    let mut base: Option<Vec<f32>> = None;
    let mut out = Vec::new();
    let mut full = 0;
    for frame in rec.frames().unwrap() {
        let state = frame.unwrap().state;
        full = 40 + 4 * state.len();
        if let Some(b) = &mut base {
            out.clear();
            let t = Instant::now();
            enc.encode(1, b, &state, &mut out).unwrap();
            encode.push(t.elapsed().as_secs_f64() * 1e6);
            let t = Instant::now();
            dec.read(&out, state.len()).unwrap();
            dec.apply(b);
            decode.push(t.elapsed().as_secs_f64() * 1e6);
            assert!(b.iter().zip(&state).all(|(x, y)| x.to_bits() == y.to_bits()), "a delta rebuilt another state");
            bytes.push((40 + out.len()) as f64);
        }
        base = Some(state);
    }
    let q = |v: &mut Vec<f64>, p: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() as f64 * p) as usize).min(v.len() - 1)]
    };
    println!("{} deltas of a {:.0} KiB frame (zstd level {})", bytes.len(), full as f64 / 1024.0, lumen_transport::delta::LEVEL);
    println!("bytes: median {:.1} KiB, p90 {:.1}, most {:.1}", q(&mut bytes, 0.5) / 1024.0, q(&mut bytes, 0.9) / 1024.0, q(&mut bytes, 1.0) / 1024.0);
    println!("encode: median {:.0} us, p90 {:.0}", q(&mut encode, 0.5), q(&mut encode, 0.9));
    println!("decode: median {:.0} us, p90 {:.0}", q(&mut decode, 0.5), q(&mut decode, 0.9));
}
