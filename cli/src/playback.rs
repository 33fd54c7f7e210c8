//! A recording held for playback (`lumen view run.mcap`): every frame message kept as it is in
//! the file (a key frame or what changed since the frame before), and the decoded state every
//! [`CHECKPOINT`] frames, so that going to any frame decodes at most `CHECKPOINT - 1` deltas
//! and playing forward decodes one.
//!
//! Memory: about the file's size plus one state per checkpoint (a 1,250-ring, 32-spoke colon
//! is 0.5 MB a state: 8 MB for 1,000 frames).

use crate::recording::{self, BadMessage, RecordedReply, Recording, RecordingError, FRAMES_TOPIC};
use lumen_proto::wire::FrameHeader;
use std::path::Path;
use std::sync::Arc;

/// Frames between two decoded states held in memory.
pub const CHECKPOINT: usize = 64;

/// One frame message of the file.
#[derive(Debug)]
struct Stored {
    log_time_ns: u64,
    bytes: Vec<u8>,
}

/// A recording's frames, ready to be decoded in any order.
#[derive(Debug)]
pub struct Playback {
    /// The recording (spec, session, replies by frame number).
    pub recording: Recording,
    frames: Vec<Stored>,
    /// `checkpoints[k]`: the header and state of frame `k * CHECKPOINT`, and the last frame
    /// recorded whole at or before it (what an anchored key frame is against; shared).
    checkpoints: Vec<(FrameHeader, Vec<f32>, Arc<Vec<f32>>)>,
}

/// Where a player is: the index of the frame `state` holds.
#[derive(Debug, Default)]
pub struct Cursor {
    index: Option<usize>,
    /// The floats of frame `index`.
    pub state: Vec<f32>,
    /// The header of frame `index`.
    pub header: Option<FrameHeader>,
    /// The last frame recorded whole at or before `index`.
    anchor: Vec<f32>,
}

impl Cursor {
    /// The index of the frame held, if any.
    pub fn index(&self) -> Option<usize> {
        self.index
    }
}

impl Playback {
    /// Reads `path` (checked as [`Recording::open`] checks it) and keeps its frames.
    pub fn load(path: &Path) -> Result<Self, RecordingError> {
        let recording = Recording::open(path)?;
        let (mut frames, mut checkpoints, mut state, mut anchor) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut shared = Arc::new(Vec::new());
        for m in recording::messages(path)? {
            let m = m?;
            if m.channel.topic != FRAMES_TOPIC {
                continue;
            }
            let index = frames.len();
            let header = recording::decode_frame(&m.data, &mut state, &mut anchor)
                .map_err(|source| RecordingError::NotLumen { path: path.to_owned(), what: BadMessage::Frame { index: Some(index as u64), sequence: m.sequence, source } })?;
            if index.is_multiple_of(CHECKPOINT) {
                if *shared != anchor {
                    shared = Arc::new(anchor.clone());
                }
                checkpoints.push((header, state.clone(), shared.clone()));
            }
            frames.push(Stored { log_time_ns: m.log_time, bytes: m.data.into_owned() });
        }
        Ok(Self { recording, frames, checkpoints })
    }

    /// Frames in the file.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether the file holds no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The MCAP log time of frame `index` (the client's clock, ns).
    pub fn log_time_ns(&self, index: usize) -> Option<u64> {
        self.frames.get(index).map(|f| f.log_time_ns)
    }

    /// The recorded reply to the frame numbered `frame` (the client's number), if any.
    pub fn reply(&self, frame: u64) -> Option<&RecordedReply> {
        self.recording.replies.get(&frame)
    }

    /// Moves `cursor` to frame `index` (clamped to the last frame): one delta forward from
    /// the frame before, else from the nearest checkpoint at or before it.
    pub fn seek(&self, cursor: &mut Cursor, index: usize) -> Result<(), RecordingError> {
        let Some(last) = self.frames.len().checked_sub(1) else { return Ok(()) };
        let index = index.min(last);
        let from = match cursor.index {
            Some(at) if at <= index && at / CHECKPOINT == index / CHECKPOINT => at + 1,
            Some(at) if at + 1 == index => index,
            _ => {
                // The checkpoint is that frame decoded: a delta is against the frame before, so
                // it is not decoded again.
                let k = index / CHECKPOINT;
                let (header, state, anchor) = &self.checkpoints[k];
                cursor.state.clear();
                cursor.state.extend_from_slice(state);
                cursor.anchor.clear();
                cursor.anchor.extend_from_slice(anchor);
                cursor.header = Some(*header);
                k * CHECKPOINT + 1
            }
        };
        for i in from..=index {
            cursor.header = Some(self.decode(i, &mut cursor.state, &mut cursor.anchor)?);
        }
        cursor.index = Some(index);
        Ok(())
    }

    /// Decodes frame `i` over `state` (the state of frame `i - 1`, or any state if frame `i` is
    /// a key frame) and `anchor` (the last frame recorded whole before it).
    fn decode(&self, i: usize, state: &mut Vec<f32>, anchor: &mut Vec<f32>) -> Result<FrameHeader, RecordingError> {
        let path = &self.recording.path;
        recording::decode_frame(&self.frames[i].bytes, state, anchor)
            .map_err(|source| RecordingError::NotLumen { path: path.clone(), what: BadMessage::Frame { index: Some(i as u64), sequence: 0, source } })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::{Missed, Writer};
    use lumen_proto::{BodySpec, PairSpec, SceneSpec, Shape};

    fn spec() -> SceneSpec {
        SceneSpec::new(vec![BodySpec { name: "scope".into(), shape: Shape::Rod { points: 4, radius: vec![1.0] } }], Vec::<PairSpec>::new())
    }

    fn header(frame: u64, floats: usize) -> FrameHeader {
        FrameHeader::new(9, frame, 1_000_000 * (frame + 1), floats, 1)
    }

    /// Frame `k`'s floats: one point moves every frame, another every tenth.
    fn state(k: u64) -> Vec<f32> {
        let mut s = vec![0.0f32; 12];
        s[0] = k as f32;
        s[7] = (k / 10) as f32;
        s
    }

    #[test]
    fn any_frame_in_any_order_equals_the_frame_recorded() {
        let path = std::env::temp_dir().join(format!("lumen_playback_{}.mcap", std::process::id()));
        // Past the first key frame after the whole one: an anchored key frame at KEY_EVERY.
        let frames = crate::recording::KEY_EVERY + 3 * CHECKPOINT as u64 + 5;
        let mut w = Writer::create(&path, &spec(), 9, "test").unwrap();
        for k in 0..frames {
            w.frame(&header(k, 12), &state(k), 0).unwrap();
        }
        w.finish(Missed::default()).unwrap();
        let p = Playback::load(&path).unwrap();
        assert_eq!(p.len(), frames as usize);
        assert_eq!(p.log_time_ns(3), Some(4_000_000));
        let kind = |i: usize| u32::from_le_bytes(p.frames[i].bytes[40..44].try_into().unwrap());
        let key = crate::recording::KEY_EVERY as usize;
        assert_eq!((kind(0), kind(1), kind(key - 1), kind(key), kind(key + 1)), (0, 3, 3, 4, 3));
        let mut c = Cursor::default();
        // Forward by one, back across checkpoints, forward within one, across the anchored key
        // frame from either side, past the end.
        for i in [0usize, 1, 2, 150, 63, 64, 65, 130, 129, 192, 255, 256, 257, 300, 254, 256, 10_000, 0] {
            p.seek(&mut c, i).unwrap();
            let want = i.min(frames as usize - 1);
            assert_eq!(c.index(), Some(want));
            assert_eq!(c.state, state(want as u64), "frame {i}");
            assert_eq!(c.header.unwrap().frame, want as u64);
        }
        let _ = std::fs::remove_file(&path);
    }
}
