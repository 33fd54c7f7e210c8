//! What delta frames cost and save on a recorded colonoscopy: for each pair of consecutive
//! frames of a recording (`lumen demo` writes `run.mcap`), the delta's bytes, the client's
//! encoding time and the daemon's decoding time (read and rebuild on the base), for plain and
//! scaled rows side by side (each frame coded both ways, the order alternating).
//!
//! `cargo run --release -p lumen-cli --example delta_cost -- demo/run.mcap`; with `ONLY=plain`
//! or `ONLY=scaled` one coding, `FRAMES=N` the first N frames, `LEVEL=L` zstd level L instead of
//! the wire's.

use lumen_cli::recording::Recording;
use lumen_transport::delta::{Decoder, Encoder, Rows};
use std::time::Instant;

/// One coding's encoder, decoder, the daemon's copy of the base, and its figures.
struct Coding {
    rows: Rows,
    enc: Encoder,
    dec: Decoder,
    base: Vec<f32>,
    bytes: Vec<f64>,
    encode: Vec<f64>,
    decode: Vec<f64>,
}

impl Coding {
    fn new(rows: Rows) -> Self {
        let level = std::env::var("LEVEL").ok().and_then(|l| l.parse().ok()).unwrap_or(lumen_transport::delta::LEVEL);
        let (enc, dec) = (Encoder::with_level(rows, level).unwrap(), Decoder::new().unwrap());
        Self { rows, enc, dec, base: Vec::new(), bytes: Vec::new(), encode: Vec::new(), decode: Vec::new() }
    }

    /// Codes `state` against the base, rebuilds it there, checks it bit for bit.
    fn step(&mut self, state: &[f32], out: &mut Vec<u8>) {
        if self.base.len() != state.len() {
            self.base = state.to_vec();
            return;
        }
        out.clear();
        let t = Instant::now();
        encode_with(&mut self.enc, &self.base, state, out);
        self.encode.push(t.elapsed().as_secs_f64() * 1e6);
        let t = Instant::now();
        decode_with(&mut self.dec, self.rows, out, &mut self.base);
        self.decode.push(t.elapsed().as_secs_f64() * 1e6);
        assert!(self.base.iter().zip(state).all(|(x, y)| x.to_bits() == y.to_bits()), "a delta rebuilt another state");
        self.bytes.push((40 + out.len()) as f64);
    }

    fn report(&mut self, full: usize) {
        let q = |v: &mut Vec<f64>, p: f64| {
            v.sort_by(f64::total_cmp);
            v[((v.len() as f64 * p) as usize).min(v.len() - 1)]
        };
        println!("{:?}: {} deltas of a {:.0} KiB frame (zstd level {})", self.rows, self.bytes.len(), full as f64 / 1024.0, lumen_transport::delta::LEVEL);
        println!("  bytes: median {:.1} KiB, p90 {:.1}, most {:.1}", q(&mut self.bytes, 0.5) / 1024.0, q(&mut self.bytes, 0.9) / 1024.0, q(&mut self.bytes, 1.0) / 1024.0);
        println!("  encode: median {:.0} us, p90 {:.0}", q(&mut self.encode, 0.5), q(&mut self.encode, 0.9));
        println!("  decode: median {:.0} us, p90 {:.0}", q(&mut self.decode, 0.5), q(&mut self.decode, 0.9));
    }
}

/// The client's side, apart (callgrind: `--toggle-collect='*encode_with*'`).
#[inline(never)]
fn encode_with(enc: &mut Encoder, base: &[f32], state: &[f32], out: &mut Vec<u8>) {
    enc.encode(1, base, state, out).unwrap();
}

/// The daemon's side, apart (callgrind: `--toggle-collect='*decode_with*'`).
#[inline(never)]
fn decode_with(dec: &mut Decoder, rows: Rows, out: &[u8], base: &mut [f32]) {
    dec.read(out, base.len(), rows).unwrap();
    dec.apply(base);
}

fn main() {
    let path = std::env::args().nth(1).expect("usage: delta_cost RECORDING.mcap");
    let rec = Recording::open(std::path::Path::new(&path)).unwrap_or_else(|e| panic!("{e}"));
    // ONLY=plain or ONLY=scaled runs one coding (for callgrind); both by default.
    let only = std::env::var("ONLY").ok();
    let mut codings: Vec<Coding> = [Rows::Plain, Rows::Scaled].into_iter().filter(|r| only.as_ref().is_none_or(|o| format!("{r:?}").eq_ignore_ascii_case(o))).map(Coding::new).collect();
    let (mut out, mut full) = (Vec::new(), 0);
    let limit: usize = std::env::var("FRAMES").ok().and_then(|f| f.parse().ok()).unwrap_or(usize::MAX);
    for (k, frame) in rec.frames().unwrap().enumerate().take(limit) {
        let state = frame.unwrap().state;
        full = 40 + 4 * state.len();
        let n = codings.len();
        for i in 0..n {
            codings[(i + k) % n].step(&state, &mut out);
        }
    }
    codings.iter_mut().for_each(|c| c.report(full));
}
