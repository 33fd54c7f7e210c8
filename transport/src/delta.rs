//! Delta frames: what changed since a base, coded so that a colonoscopy frame travels in a few
//! tens of KiB instead of the whole state (`proto/README.md`, section 2, "Delta frames").
//!
//! A state is a run of rows of 3 floats (every body's points and radial vectors). A delta
//! against a base holds:
//! - a bitmap, one bit per row (bit `r % 8` of byte `r / 8`): the rows whose floats differ
//!   from the base's, bit for bit;
//! - in a scaled delta ([`Rows::Scaled`]), for each changed row a scale `s`, a float coded as
//!   the difference of its bits from those of 1.0: the row is predicted as the base's row times
//!   `s` (a plain delta predicts the base's row itself);
//! - for each float of those rows, in order, the difference of its bits from the prediction's,
//!   `d = new - predicted (mod 2^32)`, zigzag coded, `z = (d << 1) ^ (d >> 31)` (arithmetic
//!   shift): a float that moved a little differs in its low mantissa bits, so `z` is a small
//!   number whichever way it moved;
//! - those numbers split into four byte planes (every low byte, then every second byte, ...):
//!   the high planes are nearly all zero and compress to almost nothing.
//!
//! Why the scale: a wall that gives moves each tip along its own spoke, so a radial vector's
//! three floats change together by one factor. Coded against the base they cost about 13 bits
//! each; coded as the factor and three residuals of a rounding or two they cost about half
//! (the demo's colonoscopies, `docs/measurements.md`). The encoder takes the scale only where it
//! is cheaper (else 1.0, which predicts the base's row exactly), so rows that move otherwise
//! (rod points, control points) lose nothing.
//!
//! The bitmap, the scales' planes and the floats' planes are one zstd frame ([`LEVEL`]).
//! Decoding reverses each step exactly (the prediction is one IEEE-754 single multiplication,
//! the same in every language), so the state rebuilt is the client's bit for bit. zstd over a
//! general-purpose byte coder of our own: it is standard (every language has it), fast, and its
//! worst case on hostile input is bounded by the output buffer we give it.

use lumen_proto::wire::{DeltaHeader, FrameHeader, DELTA_HEADER_BYTES, FLAG_DELTA, FLAG_SCALED};
use std::fmt;

/// The zstd level deltas are written at: -1, zstd's first fast level. On `lumen demo`'s
/// colonoscopy it wrote 5% more bytes than level 1 in three quarters of the time, and decoded
/// in 70% of it (`docs/measurements.md`).
pub const LEVEL: i32 = -1;

/// How a delta's changed rows are coded, as the frame's flags say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rows {
    /// Flag delta alone: each row's floats against the base's.
    Plain,
    /// Flags delta and scaled: a scale a row, then its floats against the base's row times it.
    Scaled,
}

impl Rows {
    /// The coding a delta frame's header announces.
    pub fn of(header: &FrameHeader) -> Self {
        if header.flags & FLAG_SCALED != 0 {
            Rows::Scaled
        } else {
            Rows::Plain
        }
    }

    /// The frame flags of a delta coded this way (keep not included).
    pub fn flags(self) -> u16 {
        match self {
            Rows::Plain => FLAG_DELTA,
            Rows::Scaled => FLAG_DELTA | FLAG_SCALED,
        }
    }

    /// Coded numbers a changed row takes: its scale, if any, and its three floats.
    fn per_row(self) -> usize {
        match self {
            Rows::Plain => 3,
            Rows::Scaled => 4,
        }
    }
}

/// The bits of 1.0, which a scale is coded against (a scale of 1.0 codes as 0).
const ONE: u32 = 0x3f80_0000;

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
    /// A scaled delta's scale for its `index`-th changed row is not a finite float.
    Scale { index: usize, bits: u32 },
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
            DeltaError::Scale { index, bits } => write!(f, "delta's scale of changed row {index} is not finite (bits {bits:#010x})"),
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

/// Reads the `count` zigzag-coded numbers out of their four byte planes into `zs`, one pass
/// that vectorises.
fn unplane(planes: &[u8], count: usize, zs: &mut Vec<u32>) {
    let planes = &planes[..4 * count];
    let (low, rest) = planes.split_at(count);
    let (second, rest) = rest.split_at(count);
    let (third, high) = rest.split_at(count);
    zs.clear();
    zs.extend(low.iter().zip(second).zip(third).zip(high).map(|(((a, b), c), d)| u32::from_le_bytes([*a, *b, *c, *d])));
}

/// Writes `zs` into four byte planes appended to `out`.
fn plane(zs: &[u32], out: &mut Vec<u8>) {
    out.reserve(4 * zs.len());
    for shift in [0, 8, 16, 24] {
        out.extend(zs.iter().map(|z| (z >> shift) as u8));
    }
}

/// The scale a coded number `z` stands for: the float whose bits differ from 1.0's by `z`'s
/// difference.
fn scale_of(z: u32) -> f32 {
    f32::from_bits(ONE.wrapping_add(unzigzag(z)))
}

/// Rebuilds, in `state`, each row the bitmap `map` marks: its prediction (the row itself, or
/// times its scale from `scales` when given and not 1.0) plus the zigzag-coded differences
/// `zs`, three a row; saves what it overwrites in `undo` when given. Plain and scaled rows
/// are separate loops, so that no row asks which it is.
fn apply(map: &[u8], scales: Option<&[u32]>, zs: &[u32], state: &mut [f32], mut undo: Option<&mut Vec<u32>>) {
    let state = bits_mut(state);
    let mut zs = zs.chunks_exact(3);
    let mut rebuild = |r: usize, scale: u32| {
        let row: &mut [u32; 3] = (&mut state[3 * r..3 * r + 3]).try_into().expect("a row of 3");
        if let Some(u) = undo.as_deref_mut() {
            u.extend_from_slice(row);
        }
        let p = if scale != 0 { scaled_row(row, scale) } else { *row };
        let z = zs.next().expect("three coded numbers a marked row");
        *row = [p[0].wrapping_add(unzigzag(z[0])), p[1].wrapping_add(unzigzag(z[1])), p[2].wrapping_add(unzigzag(z[2]))];
    };
    match scales {
        None => for_marked(map, |r| rebuild(r, 0)),
        Some(scales) => {
            let mut scales = scales.iter();
            for_marked(map, |r| rebuild(r, *scales.next().expect("a scale a marked row")));
        }
    }
}

/// How many rows the bitmap `map` marks, counted eight bytes at a time: without a popcount
/// instruction in the baseline x86-64 a byte's count costs nearly what a word's does.
fn marked_count(map: &[u8]) -> usize {
    let (words, tail) = map.as_chunks::<8>();
    words.iter().map(|w| u64::from_le_bytes(*w).count_ones() as usize).sum::<usize>() + tail.iter().map(|b| b.count_ones() as usize).sum::<usize>()
}

/// Calls `f` with each row the bitmap `map` marks, in order, reading it eight bytes at a time
/// (most words of a delta's bitmap are zero).
#[inline(always)]
fn for_marked(map: &[u8], mut f: impl FnMut(usize)) {
    let (words, tail) = map.as_chunks::<8>();
    let mut each = |at: usize, mut marks: u64| {
        while marks != 0 {
            f(at + marks.trailing_zeros() as usize);
            marks &= marks - 1;
        }
    };
    for (i, w) in words.iter().enumerate() {
        each(64 * i, u64::from_le_bytes(*w));
    }
    for (i, &b) in tail.iter().enumerate() {
        each(64 * words.len() + 8 * i, b as u64);
    }
}

/// The bits of the float `v` times `s`: the prediction's one IEEE-754 single multiplication.
#[inline(always)]
fn times(v: u32, s: f32) -> u32 {
    (f32::from_bits(v) * s).to_bits()
}

/// The bits of `row` times the scale coded `z`.
#[inline(always)]
fn scaled_row(row: &[u32], z: u32) -> [u32; 3] {
    let s = scale_of(z);
    [times(row[0], s), times(row[1], s), times(row[2], s)]
}

/// Bits a coded number needs, the encoder's measure of what a row costs.
#[inline(always)]
fn bits_of(z: u32) -> u32 {
    32 - z.leading_zeros()
}

/// How to code the changed row `new` against `base`: its scale's code (0 for none) and its
/// residuals. The scale is the ratio of the row's largest float to the base's, in single
/// precision: a row that only lengthens or shortens then misses by a rounding or two in each
/// float. It is taken where it is finite and the row codes in fewer bits with it (three times
/// the widest residual, plus the scale's) than without.
#[inline(always)]
fn code_row(b: &[u32], n: &[u32], scaled: bool) -> (u32, [u32; 3]) {
    let plain = [zigzag(n[0].wrapping_sub(b[0])), zigzag(n[1].wrapping_sub(b[1])), zigzag(n[2].wrapping_sub(b[2]))];
    if !scaled {
        return (0, plain);
    }
    // The largest magnitude: the bits without the sign compare as the magnitudes do.
    let m = [b[0] & 0x7fff_ffff, b[1] & 0x7fff_ffff, b[2] & 0x7fff_ffff];
    let k01 = if m[1] > m[0] { 1 } else { 0 };
    let k = if m[2] > m[k01] { 2 } else { k01 };
    let s = f32::from_bits(n[k]) / f32::from_bits(b[k]);
    let z = zigzag(s.to_bits().wrapping_sub(ONE));
    let r = [zigzag(n[0].wrapping_sub(times(b[0], s))), zigzag(n[1].wrapping_sub(times(b[1], s))), zigzag(n[2].wrapping_sub(times(b[2], s)))];
    // Selected by a mask, not a branch: the choice flips from row to row.
    let take = s.is_finite() & (z != 0) & (bits_of(z) + 3 * bits_of(r[0] | r[1] | r[2]) < 3 * bits_of(plain[0] | plain[1] | plain[2]));
    let mask = 0u32.wrapping_sub(take as u32);
    (z & mask, [(r[0] & mask) | (plain[0] & !mask), (r[1] & mask) | (plain[1] & !mask), (r[2] & mask) | (plain[2] & !mask)])
}

/// Whether two blocks of eight rows differ anywhere: XOR and OR over fixed-size arrays, which
/// unroll into a few vector instructions, rather than a memcmp call per block.
#[inline(always)]
fn differ(a: &[u32; 24], b: &[u32; 24]) -> bool {
    let mut acc = 0;
    for i in 0..24 {
        acc |= a[i] ^ b[i];
    }
    acc != 0
}

/// Writes deltas; keeps its buffers and zstd context from one frame to the next.
pub struct Encoder {
    compressor: zstd::bulk::Compressor<'static>,
    rows: Rows,
    scales: Vec<u32>,
    zs: Vec<u32>,
    raw: Vec<u8>,
    packed: Vec<u8>,
}

impl Encoder {
    /// An encoder of scaled deltas ([`Rows::Scaled`]) at [`LEVEL`].
    pub fn new() -> Result<Self, DeltaError> {
        Self::with_rows(Rows::Scaled)
    }

    /// An encoder of deltas coded as `rows` says, at [`LEVEL`].
    pub fn with_rows(rows: Rows) -> Result<Self, DeltaError> {
        Self::with_level(rows, LEVEL)
    }

    /// An encoder of deltas coded as `rows` says, at zstd level `level` (any level decodes the
    /// same; `cli/examples/delta_cost.rs` compares their bytes and times with `LEVEL=`).
    pub fn with_level(rows: Rows, level: i32) -> Result<Self, DeltaError> {
        let compressor = zstd::bulk::Compressor::new(level).map_err(DeltaError::Zstd)?;
        Ok(Self { compressor, rows, scales: Vec::new(), zs: Vec::new(), raw: Vec::new(), packed: Vec::new() })
    }

    /// How this encoder codes rows; its frames carry `rows().flags()`.
    pub fn rows(&self) -> Rows {
        self.rows
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
        self.scales.clear();
        self.zs.clear();
        let scaled = self.rows == Rows::Scaled;
        // Eight rows (one bitmap byte, 24 floats) at a time: most are unchanged, and a block of
        // a fixed size compares in a few vector instructions.
        let (new, old) = (bits(state), bits(base));
        let whole = new.len() / 24 * 24;
        for (byte_at, (n8, o8)) in new[..whole].chunks_exact(24).zip(old[..whole].chunks_exact(24)).enumerate() {
            let (n8, o8): (&[u32; 24], &[u32; 24]) = (n8.try_into().expect("24 floats"), o8.try_into().expect("24 floats"));
            if differ(n8, o8) {
                self.raw[byte_at] = self.code_block(n8, o8, scaled);
            }
        }
        if whole < new.len() {
            self.raw[whole / 24] = self.code_block(&new[whole..], &old[whole..], scaled);
        }
        plane(&self.scales, &mut self.raw);
        plane(&self.zs, &mut self.raw);
        // Into a buffer of its own (zstd fills its spare capacity), not a zeroed tail of `out`.
        self.packed.clear();
        self.packed.reserve(zstd::zstd_safe::compress_bound(self.raw.len()));
        let encoded = self.compressor.compress_to_buffer(&self.raw, &mut self.packed).map_err(DeltaError::Zstd)?;
        let header = DeltaHeader { base: base_frame, changed: (self.zs.len() / 3) as u32, encoded: encoded as u32 };
        out.extend_from_slice(&header.to_bytes());
        out.extend_from_slice(&self.packed);
        Ok(header)
    }

    /// Codes the changed rows among up to eight rows `new` against `old`; returns their marks.
    #[inline(always)]
    fn code_block(&mut self, new: &[u32], old: &[u32], scaled: bool) -> u8 {
        let mut mark = 0u8;
        for (r, (n, o)) in new.chunks_exact(3).zip(old.chunks_exact(3)).enumerate() {
            if n != o {
                mark |= 1 << r;
                let (z, r) = code_row(o, n, scaled);
                if scaled {
                    self.scales.push(z);
                }
                self.zs.extend(r);
            }
        }
        mark
    }

    /// Turns `base`, the base of the last [`Encoder::encode`], into the state it encoded: a
    /// client's copy of the daemon's base follows a kept delta without copying the whole state.
    pub fn apply_last(&self, base: &mut [f32]) {
        let scales = (self.rows == Rows::Scaled).then_some(&self.scales[..]);
        apply(&self.raw[..bitmap_bytes(base.len() / 3)], scales, &self.zs, base, None);
    }
}

/// Reads deltas and applies them to a base in place, keeping what it overwrote so that a frame
/// that is not kept leaves the base as it was.
pub struct Decoder {
    decompressor: zstd::bulk::Decompressor<'static>,
    raw: Vec<u8>,
    coding: Rows,
    scales: Vec<u32>,
    zs: Vec<u32>,
    rows: usize,
    count: usize,
    undo: Vec<u32>,
}

impl Decoder {
    /// A decoder with empty buffers.
    pub fn new() -> Result<Self, DeltaError> {
        Ok(Self {
            decompressor: zstd::bulk::Decompressor::new().map_err(DeltaError::Zstd)?,
            raw: Vec::new(),
            coding: Rows::Plain,
            scales: Vec::new(),
            zs: Vec::new(),
            rows: 0,
            count: 0,
            undo: Vec::new(),
        })
    }

    /// Reads the delta `body` (everything after the frame header; up to 3 bytes of padding
    /// after the zstd frame are ignored, as iceoryx2 carries whole floats), its rows coded as
    /// `coding` says, for a state of `floats` floats, checking every count and scale. Nothing is
    /// applied yet.
    pub fn read(&mut self, body: &[u8], floats: usize, coding: Rows) -> Result<DeltaHeader, DeltaError> {
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
        let expected = bitmap + 4 * coding.per_row() * header.changed as usize;
        self.raw.clear();
        self.raw.reserve_exact(expected);
        // zstd fills the spare capacity: a frame that would decompress past it fails here,
        // within the buffer, and one that stops elsewhere than `expected` fails below.
        let got = self.decompressor.decompress_to_buffer(&coded[..encoded], &mut self.raw).map_err(DeltaError::Zstd)?;
        if got != expected {
            return Err(DeltaError::Size { expected, got });
        }
        // Every set bit counts, those past the last row too: they are refused even where the
        // count agrees (applying them would write past the state).
        let set = marked_count(&self.raw[..bitmap]);
        let past_end = !rows.is_multiple_of(8) && self.raw[bitmap - 1] >> (rows % 8) != 0;
        if set != header.changed as usize || past_end {
            return Err(DeltaError::Bitmap { changed: header.changed, set, rows });
        }
        self.scales.clear();
        if coding == Rows::Scaled {
            unplane(&self.raw[bitmap..], header.changed as usize, &mut self.scales);
            if let Some((index, z)) = self.scales.iter().enumerate().find(|(_, z)| !scale_of(**z).is_finite()) {
                return Err(DeltaError::Scale { index, bits: scale_of(*z).to_bits() });
            }
        }
        self.rows = rows;
        self.coding = coding;
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
        let (scales, at) = match self.coding {
            Rows::Plain => (None, bitmap),
            Rows::Scaled => (Some(&self.scales[..]), bitmap + 4 * self.scales.len()),
        };
        unplane(&self.raw[at..], self.count, &mut self.zs);
        apply(&self.raw[..bitmap], scales, &self.zs, state, Some(&mut self.undo));
    }

    /// Puts back in `state` what the last [`Decoder::apply`] overwrote.
    pub fn undo(&mut self, state: &mut [f32]) {
        let mut old = self.undo.iter();
        let state = bits_mut(state);
        for_marked(&self.raw[..bitmap_bytes(self.rows)], |r| {
            for v in &mut state[3 * r..3 * r + 3] {
                *v = *old.next().expect("one saved value per changed float");
            }
        });
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
        assert_eq!(d.read(&out[1..], 300, Rows::Scaled).unwrap(), h);
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
        assert_eq!(d.read(&padded, 300, Rows::Scaled).unwrap(), h);
        let mut same = Vec::new();
        assert_eq!(Encoder::new().unwrap().encode(1, &base, &base, &mut same).unwrap().changed, 0);
        assert_eq!(d.read(&same, 300, Rows::Scaled).unwrap().changed, 0);
    }

    #[test]
    fn every_row_is_found_in_whole_blocks_and_in_the_last_part_block() {
        // 70 rows: eight whole blocks of eight and a block of six, a bitmap of one 64-bit word
        // and a byte; each row changed alone, and all of them at once.
        let base: Vec<f32> = (0..210).map(|i| 1.0 + i as f32).collect();
        let (mut enc, mut dec) = (Encoder::new().unwrap(), Decoder::new().unwrap());
        let mut all = base.clone();
        for row in 0..70 {
            let mut new = base.clone();
            new[3 * row + 1] += 0.5;
            all[3 * row + 1] += 0.5;
            let mut out = Vec::new();
            assert_eq!(enc.encode(0, &base, &new, &mut out).unwrap().changed, 1, "row {row}");
            dec.read(&out, 210, Rows::Scaled).unwrap();
            let mut state = base.clone();
            dec.apply(&mut state);
            assert_eq!(state, new, "row {row}");
            dec.undo(&mut state);
            assert_eq!(state, base, "row {row} undone");
        }
        let mut out = Vec::new();
        assert_eq!(enc.encode(0, &base, &all, &mut out).unwrap().changed, 70);
        dec.read(&out, 210, Rows::Plain).unwrap_err();
        dec.read(&out, 210, Rows::Scaled).unwrap();
        let mut state = base.clone();
        dec.apply(&mut state);
        assert_eq!(state, all);
    }

    #[test]
    fn damaged_deltas_are_refused_with_their_cause() {
        let (base, new) = states();
        let mut good = Vec::new();
        let h = Encoder::new().unwrap().encode(7, &base, &new, &mut good).unwrap();
        let mut d = Decoder::new().unwrap();
        assert!(matches!(d.read(&good[..10], 300, Rows::Scaled), Err(DeltaError::TooShort { got: 10 })));
        assert!(matches!(d.read(&good[..good.len() - 1], 300, Rows::Scaled), Err(DeltaError::Length { .. })));
        let mut long = good.clone();
        long.extend([0; 4]);
        assert!(matches!(d.read(&long, 300, Rows::Scaled), Err(DeltaError::Length { .. })));
        let too_many = DeltaHeader { changed: 101, ..h };
        let mut bad = good.clone();
        bad[..16].copy_from_slice(&too_many.to_bytes());
        assert!(matches!(d.read(&bad, 300, Rows::Scaled), Err(DeltaError::Rows { changed: 101, rows: 100 })));
        // One more row announced than coded: the frame decompresses short of it.
        bad[..16].copy_from_slice(&DeltaHeader { changed: 5, ..h }.to_bytes());
        assert!(matches!(d.read(&bad, 300, Rows::Scaled), Err(DeltaError::Size { .. }) | Err(DeltaError::Zstd(_))));
        // Fewer announced than coded: more bytes than the buffer holds.
        bad[..16].copy_from_slice(&DeltaHeader { changed: 3, ..h }.to_bytes());
        assert!(d.read(&bad, 300, Rows::Scaled).is_err());
        // Garbage where the zstd frame was.
        let mut junk = good.clone();
        for b in &mut junk[16..] {
            *b ^= 0x5A;
        }
        assert!(matches!(d.read(&junk, 300, Rows::Scaled), Err(DeltaError::Zstd(_))));
        // A bitmap that disagrees with its count: recoded by hand.
        let mut raw = vec![0u8; 13];
        raw[0] = 0b11;
        raw.extend([0u8; 12]);
        let z = zstd::bulk::compress(&raw, 1).unwrap();
        let mut lie = DeltaHeader { base: 7, changed: 1, encoded: z.len() as u32 }.to_bytes().to_vec();
        lie.extend(&z);
        assert!(matches!(d.read(&lie, 300, Rows::Plain), Err(DeltaError::Bitmap { changed: 1, set: 2, rows: 100 })));
        // A row past the end of a state of 98 rows (bits 98, 99 of the last byte).
        let mut raw = vec![0u8; 13];
        raw[12] = 0b100;
        raw.extend([0u8; 12]);
        let z = zstd::bulk::compress(&raw, 1).unwrap();
        let mut past = DeltaHeader { base: 7, changed: 1, encoded: z.len() as u32 }.to_bytes().to_vec();
        past.extend(&z);
        assert!(matches!(d.read(&past, 294, Rows::Plain), Err(DeltaError::Bitmap { changed: 1, set: 1, rows: 98 })));
        assert!(matches!(Encoder::new().unwrap().encode(0, &base, &new[..299], &mut Vec::new()), Err(DeltaError::Shape { .. })));
    }

    /// Radial vectors of a wall that gives: every row lengthens or shortens by its own factor.
    fn lengthened(rows: usize) -> (Vec<f32>, Vec<f32>) {
        let base: Vec<f32> = (0..3 * rows).map(|i| 12.0 + (i as f32 * 0.71).sin() * 9.0).collect();
        let new = base.chunks(3).enumerate().flat_map(|(r, v)| {
            let f = 1.0 + 3e-4 * ((r as f64) * 0.13 + 0.5).sin();
            v.iter().map(move |x| (*x as f64 * f) as f32)
        });
        let new: Vec<f32> = new.collect();
        (base, new)
    }

    fn rebuilt(coding: Rows, base: &[f32], new: &[f32]) -> usize {
        let mut out = Vec::new();
        let h = Encoder::with_rows(coding).unwrap().encode(1, base, new, &mut out).unwrap();
        let mut d = Decoder::new().unwrap();
        d.read(&out, base.len(), coding).unwrap();
        let mut state = base.to_vec();
        d.apply(&mut state);
        assert!(state.iter().zip(new).all(|(a, b)| a.to_bits() == b.to_bits()), "{coding:?}");
        assert_eq!(h.changed as usize, base.len() / 3);
        out.len()
    }

    #[test]
    fn a_row_that_only_lengthens_costs_its_scale_and_a_rounding() {
        let (base, new) = lengthened(4000);
        let (plain, scaled) = (rebuilt(Rows::Plain, &base, &new), rebuilt(Rows::Scaled, &base, &new));
        assert!(10 * scaled < 7 * plain, "scaled {scaled} bytes, plain {plain}");
        // Rows that move every which way (rod points) keep the plain coding, at a scale of 1.0
        // each that zstd all but erases.
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut noise = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let moved: Vec<f32> = base.iter().map(|x| x + 1e-2 * noise()).collect();
        let (plain, scaled) = (rebuilt(Rows::Plain, &base, &moved), rebuilt(Rows::Scaled, &base, &moved));
        assert!(scaled <= plain + plain / 50, "scaled {scaled} bytes, plain {plain}");
    }

    #[test]
    fn a_row_without_a_scale_beside_one_with_a_scale() {
        // Row 0 moves on its own (scale code 0, its base's floats predict it), row 1 doubles
        // (scale 2.0, its differences are zeros).
        let (base, new) = ([1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0], [1.5f32, 2.0, 3.0, 8.0, 10.0, 12.0]);
        let mut raw = vec![0b11u8];
        plane(&[0, zigzag(2f32.to_bits().wrapping_sub(ONE))], &mut raw);
        plane(&[zigzag(1.5f32.to_bits().wrapping_sub(1f32.to_bits())), 0, 0, 0, 0, 0], &mut raw);
        let z = zstd::bulk::compress(&raw, 1).unwrap();
        let mut delta = DeltaHeader { base: 1, changed: 2, encoded: z.len() as u32 }.to_bytes().to_vec();
        delta.extend(&z);
        let mut d = Decoder::new().unwrap();
        d.read(&delta, 6, Rows::Scaled).unwrap();
        let mut state = base;
        d.apply(&mut state);
        assert_eq!(state, new);
        // This encoder writes the same bytes.
        let mut out = Vec::new();
        Encoder::new().unwrap().encode(1, &base, &new, &mut out).unwrap();
        assert_eq!(zstd::bulk::decompress(&out[DELTA_HEADER_BYTES..], 64).unwrap(), raw);
    }

    #[test]
    fn a_scale_that_is_not_finite_is_refused() {
        // One changed row of 3: its scale codes infinity.
        let mut raw = vec![0b1u8];
        plane(&[zigzag(f32::INFINITY.to_bits().wrapping_sub(ONE))], &mut raw);
        plane(&[0, 0, 0], &mut raw);
        let z = zstd::bulk::compress(&raw, 1).unwrap();
        let mut delta = DeltaHeader { base: 7, changed: 1, encoded: z.len() as u32 }.to_bytes().to_vec();
        delta.extend(&z);
        let mut d = Decoder::new().unwrap();
        assert!(matches!(d.read(&delta, 9, Rows::Scaled), Err(DeltaError::Scale { index: 0, bits: 0x7f80_0000 })));
        // The same bytes read as a plain delta are the wrong size.
        assert!(matches!(d.read(&delta, 9, Rows::Plain), Err(DeltaError::Size { .. }) | Err(DeltaError::Zstd(_))));
    }
}
