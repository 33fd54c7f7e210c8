//! Delta frames: what changed since a base, coded so that a colonoscopy frame travels in a few
//! tens of KiB instead of the whole state (`proto/README.md`, section 2, "Delta frames").
//!
//! A state is a run of rows of 3 floats (every body's points and radial vectors). A delta
//! against a base holds:
//! - a bitmap, one bit per row (bit `r % 8` of byte `r / 8`): the rows whose floats differ
//!   from the base's, bit for bit;
//! - for each float of those rows, in order, the difference of its bits from the base's,
//!   `d = new - base (mod 2^32)`, zigzag coded, `z = (d << 1) ^ (d >> 31)` (arithmetic shift):
//!   a float that moved a little differs in its low mantissa bits, so `z` is a small number
//!   whichever way it moved;
//! - those `z` split into four byte planes (every low byte, then every second byte, ...): the
//!   high planes are nearly all zero and compress to almost nothing.
//!
//! The bitmap and the planes are one zstd frame ([`LEVEL`]). Decoding reverses each step exactly,
//! so the state rebuilt is the client's bit for bit. zstd over a general-purpose byte coder of
//! our own: it is standard (every language has it), fast, and its worst case on hostile input is
//! bounded by the output buffer we give it.

use lumen_proto::wire::{DeltaHeader, DELTA_HEADER_BYTES};
use std::fmt;

/// The zstd level deltas are written at: -1, zstd's first fast level. On `lumen demo`'s
/// colonoscopy it wrote 5% more bytes than level 1 in three quarters of the time, and decoded
/// in 70% of it (`docs/measurements.md`).
pub const LEVEL: i32 = -1;

/// Why a delta could not be made or read.
#[derive(Debug)]
pub enum DeltaError {
    /// Base and state differ in length, or are not whole rows of 3 floats.
    Shape { base: usize, state: usize },
    /// Fewer bytes than the delta header.
    TooShort { got: usize },
    /// The bytes after the header are not the `encoded` bytes it announces.
    Length { encoded: u32, got: usize },
    /// More changed rows than the state has.
    Rows { changed: u32, rows: usize },
    /// The zstd frame does not decompress (corrupted, or larger than the rows it announces).
    Zstd(std::io::Error),
    /// The zstd frame decompressed to another size than the bitmap and rows announced.
    Size { expected: usize, got: usize },
    /// The bitmap's set bits are not the announced changed rows, or mark rows past the state's
    /// `rows`.
    Bitmap { changed: u32, set: usize, rows: usize },
}

impl fmt::Display for DeltaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeltaError::Shape { base, state } => write!(f, "a delta needs a base and a state of the same whole rows of 3 floats; got {base} and {state} floats"),
            DeltaError::TooShort { got } => write!(f, "delta of {got} bytes is shorter than its {DELTA_HEADER_BYTES}-byte delta header"),
            DeltaError::Length { encoded, got } => write!(f, "delta header announces {encoded} coded bytes but {got} follow"),
            DeltaError::Rows { changed, rows } => write!(f, "delta announces {changed} changed rows; the state has {rows}"),
            DeltaError::Zstd(e) => write!(f, "delta's zstd frame does not decompress: {e}"),
            DeltaError::Size { expected, got } => write!(f, "delta decompressed to {got} bytes; its bitmap and rows need {expected}"),
            DeltaError::Bitmap { changed, set, rows } => write!(f, "delta's bitmap marks {set} rows; its header announces {changed}, all among the state's {rows}"),
        }
    }
}

impl std::error::Error for DeltaError {}

/// Bytes of the bitmap of a state of `rows` rows.
fn bitmap_bytes(rows: usize) -> usize {
    rows.div_ceil(8)
}

/// The bits of each float, as the codec compares and subtracts them.
fn bits(v: &[f32]) -> &[u32] {
    bytemuck::cast_slice(v)
}

fn bits_mut(v: &mut [f32]) -> &mut [u32] {
    bytemuck::cast_slice_mut(v)
}

fn zigzag(d: u32) -> u32 {
    let d = d as i32;
    ((d << 1) ^ (d >> 31)) as u32
}

fn unzigzag(z: u32) -> u32 {
    (z >> 1) ^ 0u32.wrapping_sub(z & 1)
}

/// Reads the `count` zigzag-coded differences out of their four byte planes into `zs`, one
/// pass that vectorises.
fn unplane(planes: &[u8], count: usize, zs: &mut Vec<u32>) {
    let (low, rest) = planes.split_at(count);
    let (second, rest) = rest.split_at(count);
    let (third, high) = rest.split_at(count);
    zs.clear();
    zs.extend(low.iter().zip(second).zip(third).zip(high).map(|(((a, b), c), d)| u32::from_le_bytes([*a, *b, *c, *d])));
}

/// Adds the zigzag-coded differences `zs`, three per row the bitmap `map` marks, to `state`,
/// saving what it overwrites in `undo` when given.
fn apply(map: &[u8], zs: &[u32], state: &mut [f32], mut undo: Option<&mut Vec<u32>>) {
    let state = bits_mut(state);
    let mut zs = zs.chunks_exact(3);
    for r in marked_rows(map) {
        let (row, z) = (&mut state[3 * r..3 * r + 3], zs.next().expect("three zs per marked row"));
        if let Some(u) = undo.as_deref_mut() {
            u.extend_from_slice(row);
        }
        for (v, z) in row.iter_mut().zip(z) {
            *v = v.wrapping_add(unzigzag(*z));
        }
    }
}

/// Whether two runs of float bits differ anywhere: one pass of XOR and OR, which vectorises,
/// rather than a memcmp call per run.
fn differ(a: &[u32], b: &[u32]) -> bool {
    a.iter().zip(b).fold(0, |acc, (x, y)| acc | (x ^ y)) != 0
}

/// The rows a bitmap marks, in order.
fn marked_rows(map: &[u8]) -> impl Iterator<Item = usize> + '_ {
    map.iter().enumerate().flat_map(|(byte_at, &byte)| {
        let mut marks = byte;
        std::iter::from_fn(move || {
            (marks != 0).then(|| {
                let r = byte_at * 8 + marks.trailing_zeros() as usize;
                marks &= marks - 1;
                r
            })
        })
    })
}

/// Writes deltas; keeps its buffers and zstd context from one frame to the next.
pub struct Encoder {
    compressor: zstd::bulk::Compressor<'static>,
    zs: Vec<u32>,
    raw: Vec<u8>,
}

impl Encoder {
    /// An encoder at [`LEVEL`].
    pub fn new() -> Result<Self, DeltaError> {
        Ok(Self { compressor: zstd::bulk::Compressor::new(LEVEL).map_err(DeltaError::Zstd)?, zs: Vec::new(), raw: Vec::new() })
    }

    /// Appends to `out` the delta of `state` against `base` (the state of frame `base_frame`):
    /// the [`DeltaHeader`]'s 16 bytes, then the zstd frame. Returns the header.
    pub fn encode(&mut self, base_frame: u64, base: &[f32], state: &[f32], out: &mut Vec<u8>) -> Result<DeltaHeader, DeltaError> {
        if base.len() != state.len() || !state.len().is_multiple_of(3) {
            return Err(DeltaError::Shape { base: base.len(), state: state.len() });
        }
        let rows = state.len() / 3;
        let bitmap = bitmap_bytes(rows);
        self.raw.clear();
        self.raw.resize(bitmap, 0);
        self.zs.clear();
        // Eight rows (one bitmap byte) at a time: most are unchanged.
        let (new, old) = (bits(state), bits(base));
        for (byte_at, (n8, o8)) in new.chunks(24).zip(old.chunks(24)).enumerate() {
            if !differ(n8, o8) {
                continue;
            }
            let mut mark = 0u8;
            for (r, (n, o)) in n8.chunks_exact(3).zip(o8.chunks_exact(3)).enumerate() {
                if n != o {
                    mark |= 1 << r;
                    self.zs.extend([zigzag(n[0].wrapping_sub(o[0])), zigzag(n[1].wrapping_sub(o[1])), zigzag(n[2].wrapping_sub(o[2]))]);
                }
            }
            self.raw[byte_at] = mark;
        }
        let count = self.zs.len();
        self.raw.resize(bitmap + 4 * count, 0);
        let (low, rest) = self.raw[bitmap..].split_at_mut(count);
        let (second, rest) = rest.split_at_mut(count);
        let (third, high) = rest.split_at_mut(count);
        for ((((z, a), b), c), d) in self.zs.iter().zip(low).zip(second).zip(third).zip(high) {
            [*a, *b, *c, *d] = z.to_le_bytes();
        }
        let at = out.len();
        out.resize(at + DELTA_HEADER_BYTES + zstd::zstd_safe::compress_bound(self.raw.len()), 0);
        let encoded = self.compressor.compress_to_buffer(&self.raw, &mut out[at + DELTA_HEADER_BYTES..]).map_err(DeltaError::Zstd)?;
        out.truncate(at + DELTA_HEADER_BYTES + encoded);
        let header = DeltaHeader { base: base_frame, changed: (count / 3) as u32, encoded: encoded as u32 };
        out[at..at + DELTA_HEADER_BYTES].copy_from_slice(&header.to_bytes());
        Ok(header)
    }

    /// Turns `base`, the base of the last [`Encoder::encode`], into the state it encoded: a
    /// client's copy of the daemon's base follows a kept delta without copying the whole state.
    pub fn apply_last(&self, base: &mut [f32]) {
        apply(&self.raw[..bitmap_bytes(base.len() / 3)], &self.zs, base, None);
    }
}

/// Reads deltas and applies them to a base in place, keeping what it overwrote so that a frame
/// that is not kept leaves the base as it was.
pub struct Decoder {
    decompressor: zstd::bulk::Decompressor<'static>,
    raw: Vec<u8>,
    zs: Vec<u32>,
    rows: usize,
    count: usize,
    undo: Vec<u32>,
}

impl Decoder {
    /// A decoder with empty buffers.
    pub fn new() -> Result<Self, DeltaError> {
        Ok(Self { decompressor: zstd::bulk::Decompressor::new().map_err(DeltaError::Zstd)?, raw: Vec::new(), zs: Vec::new(), rows: 0, count: 0, undo: Vec::new() })
    }

    /// Reads the delta `body` (everything after the frame header; up to 3 bytes of padding
    /// after the zstd frame are ignored, as iceoryx2 carries whole floats) for a state of
    /// `floats` floats, checking every count. Nothing is applied yet.
    pub fn read(&mut self, body: &[u8], floats: usize) -> Result<DeltaHeader, DeltaError> {
        self.count = 0;
        let header = DeltaHeader::read(body).ok_or(DeltaError::TooShort { got: body.len() })?;
        let coded = &body[DELTA_HEADER_BYTES..];
        let encoded = header.encoded as usize;
        if coded.len() < encoded || coded.len() - encoded > 3 {
            return Err(DeltaError::Length { encoded: header.encoded, got: coded.len() });
        }
        let rows = floats / 3;
        if header.changed as usize > rows {
            return Err(DeltaError::Rows { changed: header.changed, rows });
        }
        let bitmap = bitmap_bytes(rows);
        let expected = bitmap + 12 * header.changed as usize;
        self.raw.clear();
        self.raw.resize(expected, 0);
        // A frame that would decompress past `expected` fails here, within the buffer.
        let got = self.decompressor.decompress_to_buffer(&coded[..encoded], &mut self.raw[..]).map_err(DeltaError::Zstd)?;
        if got != expected {
            return Err(DeltaError::Size { expected, got });
        }
        // Every set bit counts, those past the last row too: they are refused even where the
        // count agrees (applying them would write past the state).
        let set: usize = self.raw[..bitmap].iter().map(|b| b.count_ones() as usize).sum();
        let past_end = !rows.is_multiple_of(8) && self.raw[bitmap - 1] >> (rows % 8) != 0;
        if set != header.changed as usize || past_end {
            return Err(DeltaError::Bitmap { changed: header.changed, set, rows });
        }
        self.rows = rows;
        self.count = 3 * header.changed as usize;
        Ok(header)
    }

    /// Applies the delta last read to `state`, the base it was made against, so that it holds
    /// the new state; what it overwrote is kept for [`Decoder::undo`].
    pub fn apply(&mut self, state: &mut [f32]) {
        debug_assert_eq!(state.len(), 3 * self.rows);
        self.undo.clear();
        self.undo.reserve(self.count);
        let bitmap = bitmap_bytes(self.rows);
        unplane(&self.raw[bitmap..], self.count, &mut self.zs);
        apply(&self.raw[..bitmap], &self.zs, state, Some(&mut self.undo));
    }

    /// Puts back in `state` what the last [`Decoder::apply`] overwrote.
    pub fn undo(&mut self, state: &mut [f32]) {
        let mut old = self.undo.iter();
        let state = bits_mut(state);
        for r in marked_rows(&self.raw[..bitmap_bytes(self.rows)]) {
            for v in &mut state[3 * r..3 * r + 3] {
                *v = *old.next().expect("one saved value per changed float");
            }
        }
        self.undo.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn states() -> (Vec<f32>, Vec<f32>) {
        let base: Vec<f32> = (0..300).map(|i| (i as f32 * 0.37).sin() * 40.0).collect();
        let mut new = base.clone();
        // A little and a lot, of either sign, a sign flip, a NaN pattern, the last row.
        new[4] += 1e-4;
        new[5] -= 3e-3;
        new[30] = -new[30];
        new[150] = f32::from_bits(0x7fc0_0001);
        new[299] = 1e9;
        (base, new)
    }

    #[test]
    fn a_delta_rebuilds_the_state_bit_for_bit_and_undo_restores_the_base() {
        let (base, new) = states();
        let mut out = vec![0xAB];
        let h = Encoder::new().unwrap().encode(7, &base, &new, &mut out).unwrap();
        assert_eq!((h.base, h.changed, out.len()), (7, 4, 1 + DELTA_HEADER_BYTES + h.encoded as usize));
        let mut d = Decoder::new().unwrap();
        assert_eq!(d.read(&out[1..], 300).unwrap(), h);
        let mut state = base.clone();
        d.apply(&mut state);
        assert!(state.iter().zip(&new).all(|(a, b)| a.to_bits() == b.to_bits()));
        d.undo(&mut state);
        assert!(state.iter().zip(&base).all(|(a, b)| a.to_bits() == b.to_bits()));
        let mut enc = Encoder::new().unwrap();
        enc.encode(7, &base, &new, &mut Vec::new()).unwrap();
        enc.apply_last(&mut state);
        assert!(state.iter().zip(&new).all(|(a, b)| a.to_bits() == b.to_bits()));
        // Padding to whole floats is ignored; an unchanged state is a delta of no rows.
        let mut padded = out[1..].to_vec();
        padded.extend([0, 0, 0]);
        assert_eq!(d.read(&padded, 300).unwrap(), h);
        let mut same = Vec::new();
        assert_eq!(Encoder::new().unwrap().encode(1, &base, &base, &mut same).unwrap().changed, 0);
        assert_eq!(d.read(&same, 300).unwrap().changed, 0);
    }

    #[test]
    fn damaged_deltas_are_refused_with_their_cause() {
        let (base, new) = states();
        let mut good = Vec::new();
        let h = Encoder::new().unwrap().encode(7, &base, &new, &mut good).unwrap();
        let mut d = Decoder::new().unwrap();
        assert!(matches!(d.read(&good[..10], 300), Err(DeltaError::TooShort { got: 10 })));
        assert!(matches!(d.read(&good[..good.len() - 1], 300), Err(DeltaError::Length { .. })));
        let mut long = good.clone();
        long.extend([0; 4]);
        assert!(matches!(d.read(&long, 300), Err(DeltaError::Length { .. })));
        let too_many = DeltaHeader { changed: 101, ..h };
        let mut bad = good.clone();
        bad[..16].copy_from_slice(&too_many.to_bytes());
        assert!(matches!(d.read(&bad, 300), Err(DeltaError::Rows { changed: 101, rows: 100 })));
        // One more row announced than coded: the frame decompresses short of it.
        bad[..16].copy_from_slice(&DeltaHeader { changed: 5, ..h }.to_bytes());
        assert!(matches!(d.read(&bad, 300), Err(DeltaError::Size { .. }) | Err(DeltaError::Zstd(_))));
        // Fewer announced than coded: more bytes than the buffer holds.
        bad[..16].copy_from_slice(&DeltaHeader { changed: 3, ..h }.to_bytes());
        assert!(d.read(&bad, 300).is_err());
        // Garbage where the zstd frame was.
        let mut junk = good.clone();
        for b in &mut junk[16..] {
            *b ^= 0x5A;
        }
        assert!(matches!(d.read(&junk, 300), Err(DeltaError::Zstd(_))));
        // A bitmap that disagrees with its count: recoded by hand.
        let mut raw = vec![0u8; 13];
        raw[0] = 0b11;
        raw.extend([0u8; 12]);
        let z = zstd::bulk::compress(&raw, 1).unwrap();
        let mut lie = DeltaHeader { base: 7, changed: 1, encoded: z.len() as u32 }.to_bytes().to_vec();
        lie.extend(&z);
        assert!(matches!(d.read(&lie, 300), Err(DeltaError::Bitmap { changed: 1, set: 2, rows: 100 })));
        // A row past the end of a state of 98 rows (bits 98, 99 of the last byte).
        let mut raw = vec![0u8; 13];
        raw[12] = 0b100;
        raw.extend([0u8; 12]);
        let z = zstd::bulk::compress(&raw, 1).unwrap();
        let mut past = DeltaHeader { base: 7, changed: 1, encoded: z.len() as u32 }.to_bytes().to_vec();
        past.extend(&z);
        assert!(matches!(d.read(&past, 294), Err(DeltaError::Bitmap { changed: 1, set: 1, rows: 98 })));
        assert!(matches!(Encoder::new().unwrap().encode(0, &base, &new[..299], &mut Vec::new()), Err(DeltaError::Shape { .. })));
    }
}
