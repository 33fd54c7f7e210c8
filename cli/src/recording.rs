//! Recordings of a session in MCAP (the robotics log format: `mcap` tools, Foxglove): the
//! scene spec, then every reply as the bytes it has on the wire (its contacts' bytes reordered
//! into planes, [`to_planes`]), and every frame as its wire header and what changed since the
//! frame recorded before it, coded as a delta frame is on the wire (`lumen_transport::delta`;
//! the first frame whole, and every [`KEY_EVERY`] frames a key frame coded against that first
//! one). MCAP's chunks are zstd-compressed. A colonoscopy frame moves the scope and a few
//! thousand wall tips: this keeps a recording to about ten kilobytes a frame instead of the
//! whole colon. Reading restores each frame's and reply's exact bytes; recordings of the older
//! codings read as before.
//!
//! - [`Writer`]: what `lumen record` writes through (one frame / reply at a time).
//! - [`Recording`]: a recording read back and checked ([`Recording::open`]), its replies by
//!   frame number, its frames streamed ([`Recording::frames`]).
//! - [`compare_replies`]: whether a reply equals a recorded one bit for bit, and if not, where.
//!
//! Layout (see `service/README.md`, "Recording format"):
//!
//! | topic | message encoding | schema | message |
//! |---|---|---|---|
//! | `/lumen/spec` | `json` | `jsonschema` | the [`SceneSpec`], once, first |
//! | `/lumen/frames` | `lumen-frame-delta` | `lumen.Frame` (text) | `FrameHeader` (40 bytes), then the first frame whole (`u32` 0, `floats` x f32), a delta against the frame before (`u32` 3, then a scaled delta frame's payload: the 16-byte delta header and its zstd frame) or a key frame coded the same against the first frame (`u32` 4); files before it wrote key frames whole, `u32` 2 and a plain delta's payload, or `u32` 1, `u32` runs, per run `u32` start, `u32` len, len x f32 |
//! | `/lumen/contacts` | `lumen-contacts-planes` | `lumen.Contacts` (text) | `ContactsHeader` (256 bytes) + `count` x 88-byte `Contact` as byte planes ([`to_planes`]; older files `lumen-repr-c`, the wire bytes) |
//! | `/lumen/summary` | `json` | `jsonschema` | counts and what the recorder missed, once, last |
//! | `/lumen/scene` | `json` | `foxglove.SceneUpdate`, `jsonschema` (Foxglove's own schema) | at most 60 a second of log time, the scope as a line and the reply's contacts as arrows, and the colon as triangles on the first frame and then at most once a second (see [`crate::foxglove`]); left out by `lumen record --no-scene` ([`WriterOptions`]) |
//!
//! The scene channel is for viewers (Foxglove, Lichtblick: the 3D panel draws it with no
//! plugin); [`Recording::open`] and replays skip it, and everything they read is in the others.
//!
//! All little-endian, as in `proto/README.md`. `log_time` is the client's `client_time_ns`
//! (its own clock, nanoseconds) or, when the client left it 0, the receive time; `publish_time`
//! is the recorder's receive time (nanoseconds since the Unix epoch). The spec channel's metadata
//! names the session and transport. The same facts are also MCAP metadata records (`lumen`,
//! first, and `lumen.summary`, on finishing) for tools that show metadata.

use crate::foxglove::{SceneWriter, SCENE_UPDATE, SCENE_UPDATE_SCHEMA};
use lumen_proto::wire::{self, ContactsHeader, FrameHeader, CONTACT_BYTES};
use lumen_proto::{Contact, SceneSpec};
use lumen_transport::delta::{Decoder, DeltaError, Encoder, Rows};
use mcap::records::{MessageHeader, Metadata};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

/// Topic of the scene spec (JSON, one message).
pub const SPEC_TOPIC: &str = "/lumen/spec";
/// Topic of the frames (wire bytes).
pub const FRAMES_TOPIC: &str = "/lumen/frames";
/// Topic of the replies (wire bytes).
pub const CONTACTS_TOPIC: &str = "/lumen/contacts";
/// Topic of the counts written on finishing (JSON, one message, last).
pub const SUMMARY_TOPIC: &str = "/lumen/summary";
/// Topic of the scene for viewers: `foxglove.SceneUpdate` as JSON ([`crate::foxglove`]).
pub const SCENE_TOPIC: &str = "/lumen/scene";
/// Message and schema encoding of replies: the `#[repr(C)]` little-endian bytes of
/// `proto/README.md`.
pub const WIRE_ENCODING: &str = "lumen-repr-c";
/// Message encoding of replies: the wire bytes with the contacts' bytes as planes
/// ([`to_planes`]); files before it wrote [`WIRE_ENCODING`], the wire bytes as they are.
pub const PLANES_ENCODING: &str = "lumen-contacts-planes";
/// Message encoding of frames: the wire header, then the floats whole or as changed runs.
pub const FRAME_ENCODING: &str = "lumen-frame-delta";
/// A key frame (every float) at least this often, so a damaged message costs at most this many
/// frames and a reader can start at any key frame.
pub const KEY_EVERY: u64 = 256;
/// The MCAP header's profile.
pub const PROFILE: &str = "lumen";
/// Name of the metadata record holding the spec and session, written first.
pub const METADATA: &str = "lumen";
/// Name of the metadata record holding the counts, written on finishing.
pub const SUMMARY_METADATA: &str = "lumen.summary";

/// Schema text of [`FRAMES_TOPIC`]: the byte layout, for people and tools that list schemas.
pub const FRAME_SCHEMA: &str = "\
lumen.Frame v3, little-endian: the frame of proto/README.md section 2, its floats delta-coded.
FrameHeader (40 bytes): 0 u32 magic 'LMNF' | 4 u16 version | 6 u16 flags | 8 u64 session |
16 u64 frame | 24 u64 client_time_ns | 32 u32 floats | 36 u32 bodies
then u32 kind: 0 = key frame, followed by floats x f32: every body's state in spec order (tube:
per ring its control point x y z then its radial vectors x y z; rod: x y z per point), mm;
3 = delta against the message before on this topic, followed by a scaled delta frame's payload
as proto/README.md section 2 ('Delta frames') gives it (flags delta and scaled): u64 base,
u32 changed rows, u32 encoded, then one zstd frame of the changed rows' bitmap, their scales'
byte planes and their floats' byte planes;
4 = an anchored key frame: the same, against the last key frame of kind 0 on this topic (the
recording's first message) instead of the message before;
2 (earlier v3 files) = the same as 3 with a plain delta (flag delta alone: no scales);
1 (v2 files) = delta, followed by u32 runs, then per run u32 start, u32 len, len x f32: the
floats [start, start + len) that differ from the message before; the others are as there.
The first message is a key frame of kind 0, and a key frame (kind 4; earlier files kind 0)
comes at least every 256: a reader starts at any key frame with the first message alone.
";

/// Schema text of [`CONTACTS_TOPIC`].
pub const CONTACTS_SCHEMA: &str = "\
lumen.Contacts v2, little-endian, the bytes of proto/README.md section 3:
ContactsHeader (256 bytes): 0 u32 magic 'LMNC' | 4 u16 version | 6 u16 status | 8 u64 session |
16 u64 frame | 24 u64 client_time_ns | 32 u32 detect_ns | 36 u32 count | 40 u32 skipped |
44 u32 error_body | 48 u32 error_index | 52 u32 error_spoke | 56 u16 message_len | 58 u16 flags |
60 u8[196] message
then the count contacts of 88 bytes each as planes (message encoding lumen-contacts-planes): byte j
of contact i at 256 + j * count + i, so that like bytes of every contact lie together for the
chunk's zstd (files before it, message encoding lumen-repr-c: the contacts one after another,
contact i's byte j at 256 + 88 * i + j). A Contact: 0 u16 pair | 2 u8 kind | 3 u8 flags | 4 u16 body_a | 6 u16 body_b |
8 u32 sample | 12 u32 segment_a | 16 f32 param_a | 20 u32 index_b | 24 u32 spoke_b | 28 f32 param_b |
32 f32[4] weights_b | 48 f32[3] point_a | 60 f32[3] point_b | 72 f32[3] normal | 84 f32 depth
";

const SUMMARY_JSON_SCHEMA: &str =
    r#"{"title":"lumen.Summary","description":"Counts of a finished recording (decimal strings): frames, replies, contacts, missed_frames, missed_replies","type":"object"}"#;
const SPEC_JSON_SCHEMA: &str = r#"{"title":"lumen.SceneSpec","description":"The scene spec of proto/README.md section 1 (bodies, pairs, precision, alpha, margin)","type":"object"}"#;

/// What went wrong with a recording; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file could not be opened, created or written.
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    /// The MCAP writer failed (disk full, ...).
    #[error("{}: writing MCAP: {source}", path.display())]
    Write { path: PathBuf, source: mcap::McapError },
    /// Not an MCAP file at all (wrong magic, empty, garbage).
    #[error("{} is not a readable MCAP file: {source}", path.display())]
    NotMcap { path: PathBuf, source: mcap::McapError },
    /// An MCAP file that ends or breaks after `messages` good messages (a recorder killed with
    /// SIGKILL, a partial copy).
    #[error("{} is cut short or damaged after {messages} messages ({source}); was the recorder killed before it finished the file?", path.display())]
    Truncated { path: PathBuf, messages: u64, source: mcap::McapError },
    /// A frame could not be delta-coded (the zstd context could not be made or failed).
    #[error("{}: coding a frame: {source}", path.display())]
    Delta { path: PathBuf, source: DeltaError },
    /// A valid MCAP file that is not a Lumen recording, or holds a message that is not what its
    /// topic says.
    #[error("{} is not a usable Lumen recording: {what}", path.display())]
    NotLumen {
        path: PathBuf,
        #[source]
        what: BadMessage,
    },
}

/// Why a file is not a usable Lumen recording (inside [`RecordingError::NotLumen`]).
#[derive(Debug, thiserror::Error)]
pub enum BadMessage {
    /// No spec message at all.
    #[error("no {SPEC_TOPIC} message (was it written by `lumen record`?)")]
    NoSpec,
    /// The spec message is not a scene spec.
    #[error("its {SPEC_TOPIC} message is not a scene spec: {0}")]
    Spec(#[source] serde_json::Error),
    /// The summary message is not a map of counts.
    #[error("its {SUMMARY_TOPIC} message is not a map of counts: {0}")]
    Summary(#[source] serde_json::Error),
    /// A frame message does not decode (`index`: its place among the frames, where counted).
    #[error("frame message {}(sequence {sequence}): {source}", index.map_or(String::new(), |i| format!("{i} ")))]
    Frame { index: Option<u64>, sequence: u32, source: FrameDecodeError },
    /// A reply message does not decode.
    #[error("reply message (sequence {sequence}): {source}")]
    Reply { sequence: u32, source: wire::ContactsDecodeError },
}

/// Why a frame message does not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameDecodeError {
    /// Its header.
    #[error(transparent)]
    Header(#[from] wire::FrameError),
    /// The message ends inside a 4-byte word.
    #[error("the message ends inside a word")]
    CutWord,
    /// A key frame whose floats are not the header's count.
    #[error("key frame of {bytes} bytes for {floats} floats")]
    KeyFrameLength { bytes: usize, floats: usize },
    /// A coded delta (kind 2, 3 or 4) that does not decode.
    #[error("{0}")]
    Delta(String),
    /// A delta whose frame before has another size (or is missing).
    #[error("a delta for {floats} floats after a frame of {before} (no key frame before it)")]
    DeltaWithoutKey { floats: usize, before: usize },
    /// A run of a delta past the frame's end.
    #[error("a run of {len} floats at {start}, beyond the frame's {floats}")]
    RunBeyond { start: usize, len: usize, floats: usize },
    /// Bytes left after the last run of a delta.
    #[error("{0} bytes after the last run")]
    Trailing(usize),
    /// An anchored key frame (kind 4) with no whole frame of its size before it.
    #[error("an anchored key frame for {floats} floats after a whole frame of {anchor} (none before it)")]
    AnchoredWithoutWhole { floats: usize, anchor: usize },
    /// Neither key (0 or 4) nor delta (1, 2 or 3).
    #[error("unknown frame kind {0} (0 or 4 key, 1, 2 or 3 delta)")]
    UnknownKind(u32),
}

/// How a replayed reply differs from the recorded one ([`compare_replies`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ReplyDifference {
    #[error("status {got} ({got_message}), recorded {recorded} ({recorded_message})")]
    Status { got: u16, got_message: String, recorded: u16, recorded_message: String },
    #[error("error location or message differs: {got:?} vs recorded {recorded:?}")]
    Error { got: String, recorded: String },
    #[error("flags {got:#x}, recorded {recorded:#x}")]
    Flags { got: u16, recorded: u16 },
    #[error("{got} contacts, recorded {recorded}")]
    Count { got: usize, recorded: usize },
    #[error("contact {index} differs: depth {got_depth} at {got_point:?}, recorded depth {recorded_depth} at {recorded_point:?}")]
    Contact { index: usize, got_depth: f32, got_point: [f32; 3], recorded_depth: f32, recorded_point: [f32; 3] },
}

/// Counts of a finished recording.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Written {
    /// Frames written.
    pub frames: u64,
    /// Replies written.
    pub replies: u64,
    /// Contact records in all replies.
    pub contacts: u64,
    /// Messages on [`SCENE_TOPIC`] (0 without the scene).
    pub scene: u64,
    /// File size in bytes.
    pub bytes: u64,
}

/// What a recorder did not see, stored in the file's summary metadata.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Missed {
    /// Frame numbers the recorder never saw between two it did (it fell behind).
    pub frames: u64,
    /// Replies it never saw, beyond the frames the daemon itself skipped.
    pub replies: u64,
}

/// What a [`Writer`] writes beyond the frames, replies, spec and summary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriterOptions {
    /// The [`SCENE_TOPIC`] channel for viewers (on by default).
    pub scene: bool,
}

impl Default for WriterOptions {
    fn default() -> Self {
        Self { scene: true }
    }
}

/// The scene channel of a writer: its id, the builder and the message buffer it reuses.
struct SceneChannel {
    channel: u16,
    writer: SceneWriter,
    buf: Vec<u8>,
}

/// Writes a recording: [`Writer::create`], then [`Writer::frame`] / [`Writer::contacts`] as
/// they come, then [`Writer::finish`] (without it the file has no summary and readers call it
/// cut short).
pub struct Writer {
    path: PathBuf,
    mcap: mcap::Writer<BufWriter<File>>,
    frames_channel: u16,
    contacts_channel: u16,
    summary_channel: u16,
    last_log_time: u64,
    sequence: u32,
    written: Written,
    buf: Vec<u8>,
    /// A reply's wire bytes, before [`to_planes`].
    wire: Vec<u8>,
    /// The last recorded frame's floats, what the next delta is against, and its number.
    last: Vec<f32>,
    last_frame: u64,
    /// The last frame recorded whole, what the next key frame is coded against, and its number.
    anchor: Vec<f32>,
    anchor_frame: u64,
    encoder: Encoder,
    since_key: u64,
    scene: Option<SceneChannel>,
}

impl Writer {
    /// Creates `path` (replacing it) and writes the header, schemas, channels, the `lumen`
    /// metadata and the spec message. `transport` is only informative (`iceoryx2`, `zenoh`).
    /// With the default [`WriterOptions`]: the scene channel too.
    pub fn create(path: &Path, spec: &SceneSpec, session: u64, transport: &str) -> Result<Self, RecordingError> {
        Self::create_with(path, spec, session, transport, WriterOptions::default())
    }

    /// [`Writer::create`] with the channels `options` choose.
    pub fn create_with(path: &Path, spec: &SceneSpec, session: u64, transport: &str, options: WriterOptions) -> Result<Self, RecordingError> {
        let io = |source| RecordingError::Io { path: path.to_owned(), source };
        let file = File::create(path).map_err(io)?;
        let wr = |source| RecordingError::Write { path: path.to_owned(), source };
        let encoder = Encoder::new().map_err(|source| RecordingError::Delta { path: path.to_owned(), source })?;
        // zstd chunks: Foxglove, Lichtblick and the `mcap` tools read them (the frames inside
        // are zstd already; the replies and the scene compress several times over).
        let mcap_options = mcap::WriteOptions::new().profile(PROFILE).library(concat!("lumen/", env!("CARGO_PKG_VERSION"))).compression(Some(mcap::Compression::Zstd));
        let mut mcap = mcap_options.create(BufWriter::new(file)).map_err(wr)?;
        let spec_json = serde_json::to_string(spec).expect("a SceneSpec always serialises");
        let mut meta = BTreeMap::new();
        meta.insert("spec".to_owned(), spec_json.clone());
        meta.insert("session".to_owned(), session.to_string());
        meta.insert("transport".to_owned(), transport.to_owned());
        meta.insert("protocol_version".to_owned(), wire::PROTOCOL_VERSION.to_string());
        meta.insert("lumen_version".to_owned(), env!("CARGO_PKG_VERSION").to_owned());
        mcap.write_metadata(&Metadata { name: METADATA.to_owned(), metadata: meta }).map_err(wr)?;
        let none = BTreeMap::new();
        let spec_schema = mcap.add_schema("lumen.SceneSpec", "jsonschema", SPEC_JSON_SCHEMA.as_bytes()).map_err(wr)?;
        let mut channel_meta = BTreeMap::new();
        channel_meta.insert("session".to_owned(), session.to_string());
        channel_meta.insert("transport".to_owned(), transport.to_owned());
        let spec_channel = mcap.add_channel(spec_schema, SPEC_TOPIC, "json", &channel_meta).map_err(wr)?;
        let summary_schema = mcap.add_schema("lumen.Summary", "jsonschema", SUMMARY_JSON_SCHEMA.as_bytes()).map_err(wr)?;
        let summary_channel = mcap.add_channel(summary_schema, SUMMARY_TOPIC, "json", &none).map_err(wr)?;
        let frame_schema = mcap.add_schema("lumen.Frame", FRAME_ENCODING, FRAME_SCHEMA.as_bytes()).map_err(wr)?;
        let frames_channel = mcap.add_channel(frame_schema, FRAMES_TOPIC, FRAME_ENCODING, &none).map_err(wr)?;
        let contacts_schema = mcap.add_schema("lumen.Contacts", WIRE_ENCODING, CONTACTS_SCHEMA.as_bytes()).map_err(wr)?;
        let contacts_channel = mcap.add_channel(contacts_schema, CONTACTS_TOPIC, PLANES_ENCODING, &none).map_err(wr)?;
        let scene = if options.scene {
            let schema = mcap.add_schema(SCENE_UPDATE, "jsonschema", SCENE_UPDATE_SCHEMA.as_bytes()).map_err(wr)?;
            let channel = mcap.add_channel(schema, SCENE_TOPIC, "json", &none).map_err(wr)?;
            Some(SceneChannel { channel, writer: SceneWriter::new(spec), buf: Vec::new() })
        } else {
            None
        };
        // The spec message is stamped 0: it holds before every frame, whatever the client's clock.
        let now = wall_ns();
        mcap.write_to_known_channel(&MessageHeader { channel_id: spec_channel, sequence: 0, log_time: 0, publish_time: now }, spec_json.as_bytes()).map_err(wr)?;
        Ok(Self {
            path: path.to_owned(),
            mcap,
            frames_channel,
            contacts_channel,
            summary_channel,
            last_log_time: 0,
            sequence: 1,
            written: Written::default(),
            buf: Vec::new(),
            wire: Vec::new(),
            last: Vec::new(),
            last_frame: 0,
            anchor: Vec::new(),
            anchor_frame: 0,
            encoder,
            since_key: 0,
            scene,
        })
    }

    /// Appends one frame as it was on the wire; `receive_ns` is when the recorder got it
    /// (nanoseconds since the Unix epoch, see [`wall_ns`]).
    pub fn frame(&mut self, header: &FrameHeader, state: &[f32], receive_ns: u64) -> Result<(), RecordingError> {
        // Whole rows only are delta-coded (a state always is; anything else goes whole).
        let whole = self.anchor.len() != state.len() || !state.len().is_multiple_of(3);
        let key = whole || self.since_key + 1 >= KEY_EVERY;
        self.since_key = if key { 0 } else { self.since_key + 1 };
        let coding = match (whole, key) {
            (true, _) => Coding::Whole,
            (false, true) => Coding::Anchored,
            (false, false) => Coding::Delta,
        };
        self.buf.clear();
        encode_frame_message(header, (&mut self.last, self.last_frame), (&mut self.anchor, &mut self.anchor_frame), state, coding, &mut self.encoder, &mut self.buf)
            .map_err(|source| RecordingError::Delta { path: self.path.clone(), source })?;
        self.last_frame = header.frame;
        self.put(self.frames_channel, header.client_time_ns, receive_ns, false)?;
        self.written.frames += 1;
        if let Some(scene) = &mut self.scene {
            scene.buf.clear();
            let channel = scene.channel;
            if scene.writer.frame(log_time(header.client_time_ns, receive_ns), state, &mut scene.buf).is_some() {
                self.put(channel, header.client_time_ns, receive_ns, true)?;
                self.written.scene += 1;
            }
        }
        Ok(())
    }

    /// Appends one reply as it was on the wire.
    pub fn contacts(&mut self, header: &ContactsHeader, contacts: &[Contact], receive_ns: u64) -> Result<(), RecordingError> {
        self.wire.clear();
        let mut h = *header;
        wire::encode_contacts(&mut h, contacts, &mut self.wire);
        self.buf.clear();
        to_planes(&self.wire, &mut self.buf);
        self.put(self.contacts_channel, header.client_time_ns, receive_ns, false)?;
        self.written.replies += 1;
        self.written.contacts += contacts.len() as u64;
        if let Some(scene) = &mut self.scene {
            scene.buf.clear();
            if scene.writer.contacts(log_time(header.client_time_ns, receive_ns), contacts, &mut scene.buf) {
                let channel = scene.channel;
                self.put(channel, header.client_time_ns, receive_ns, true)?;
                self.written.scene += 1;
            }
        }
        Ok(())
    }

    /// Writes the message in `self.buf` (`scene`: in the scene channel's buffer).
    fn put(&mut self, channel_id: u16, client_ns: u64, receive_ns: u64, scene: bool) -> Result<(), RecordingError> {
        let log_time = log_time(client_ns, receive_ns);
        self.last_log_time = self.last_log_time.max(log_time);
        let header = MessageHeader { channel_id, sequence: self.sequence, log_time, publish_time: receive_ns };
        self.sequence = self.sequence.wrapping_add(1);
        let data = match (&self.scene, scene) {
            (Some(s), true) => &s.buf[..],
            _ => &self.buf[..],
        };
        self.mcap.write_to_known_channel(&header, data).map_err(|source| RecordingError::Write { path: self.path.clone(), source })
    }

    /// What has been written so far (bytes: 0 until finished).
    pub fn written(&self) -> Written {
        self.written
    }

    /// Writes the `lumen.summary` metadata (counts, `missed`), the MCAP summary and footer, and
    /// flushes the file to disk.
    pub fn finish(mut self, missed: Missed) -> Result<Written, RecordingError> {
        let wr = |path: &Path, source| RecordingError::Write { path: path.to_owned(), source };
        let mut meta = BTreeMap::new();
        meta.insert("frames".to_owned(), self.written.frames.to_string());
        meta.insert("replies".to_owned(), self.written.replies.to_string());
        meta.insert("contacts".to_owned(), self.written.contacts.to_string());
        meta.insert("scene".to_owned(), self.written.scene.to_string());
        meta.insert("missed_frames".to_owned(), missed.frames.to_string());
        meta.insert("missed_replies".to_owned(), missed.replies.to_string());
        let json = serde_json::to_vec(&meta).expect("a map of strings serialises");
        let header = MessageHeader { channel_id: self.summary_channel, sequence: self.sequence, log_time: self.last_log_time, publish_time: wall_ns() };
        self.mcap.write_to_known_channel(&header, &json).map_err(|e| wr(&self.path, e))?;
        self.mcap.write_metadata(&Metadata { name: SUMMARY_METADATA.to_owned(), metadata: meta }).map_err(|e| wr(&self.path, e))?;
        self.mcap.finish().map_err(|e| wr(&self.path, e))?;
        let file = self.mcap.into_inner().into_inner().map_err(|e| RecordingError::Io { path: self.path.clone(), source: e.into_error() })?;
        let io = |source| RecordingError::Io { path: self.path.clone(), source };
        file.sync_all().map_err(io)?;
        self.written.bytes = file.metadata().map_err(io)?.len();
        Ok(self.written)
    }
}

/// A message's `log_time`: the client's timestamp, or the receive time where the client left it 0.
fn log_time(client_ns: u64, receive_ns: u64) -> u64 {
    if client_ns != 0 {
        client_ns
    } else {
        receive_ns
    }
}

/// Nanoseconds since the Unix epoch (the recorder's `publish_time`).
pub fn wall_ns() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

/// One recorded frame.
#[derive(Debug, Clone)]
pub struct RecordedFrame {
    pub header: FrameHeader,
    /// The floats as sent, in the spec's layout (millimetres).
    pub state: Vec<f32>,
    /// MCAP `log_time`: the client's timestamp, nanoseconds.
    pub log_time_ns: u64,
}

/// One recorded reply.
#[derive(Debug, Clone)]
pub struct RecordedReply {
    pub header: ContactsHeader,
    pub contacts: Vec<Contact>,
}

/// A recording read back: spec, session, replies by frame number; frames are streamed by
/// [`Recording::frames`] (they can be large).
#[derive(Debug)]
pub struct Recording {
    pub path: PathBuf,
    /// The scene of the recorded session.
    pub spec: SceneSpec,
    /// The recorded session's id.
    pub session: u64,
    /// Number of frames in the file.
    pub frames: u64,
    /// The replies, by the frame they answer (the last one if a number repeats).
    pub replies: HashMap<u64, RecordedReply>,
    /// What the recorder reported missing; `None` if the file has no summary message.
    pub missed: Option<Missed>,
}

impl Recording {
    /// Reads `path` through once, checking every message: a file that is not MCAP, is cut short,
    /// lacks the spec, or holds a frame / reply that does not decode is refused with an error
    /// naming the problem.
    pub fn open(path: &Path) -> Result<Self, RecordingError> {
        let not_lumen = |what: BadMessage| RecordingError::NotLumen { path: path.to_owned(), what };
        let mut spec: Option<SceneSpec> = None;
        let (mut frames, mut replies) = (0u64, HashMap::new());
        let (mut session, mut missed) = (0u64, None);
        let (mut decoded, mut state, mut anchor, mut wire_bytes) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for message in messages(path)? {
            let m = message?;
            match m.channel.topic.as_str() {
                SPEC_TOPIC => {
                    let s = serde_json::from_slice(&m.data).map_err(|e| not_lumen(BadMessage::Spec(e)))?;
                    spec = Some(s);
                    session = m.channel.metadata.get("session").and_then(|v| v.parse().ok()).unwrap_or(0);
                }
                SUMMARY_TOPIC => {
                    let map: BTreeMap<String, String> = serde_json::from_slice(&m.data).map_err(|e| not_lumen(BadMessage::Summary(e)))?;
                    let get = |k: &str| map.get(k).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
                    missed = Some(Missed { frames: get("missed_frames"), replies: get("missed_replies") });
                }
                FRAMES_TOPIC => {
                    decode_frame(&m.data, &mut state, &mut anchor).map_err(|source| not_lumen(BadMessage::Frame { index: Some(frames), sequence: m.sequence, source }))?;
                    frames += 1;
                }
                CONTACTS_TOPIC => {
                    let bytes = match m.channel.message_encoding.as_str() {
                        PLANES_ENCODING => {
                            from_planes(&m.data, &mut wire_bytes);
                            &wire_bytes[..]
                        }
                        _ => &m.data[..],
                    };
                    let h = wire::decode_contacts(bytes, &mut decoded).map_err(|source| not_lumen(BadMessage::Reply { sequence: m.sequence, source }))?;
                    replies.insert(h.frame, RecordedReply { header: h, contacts: std::mem::take(&mut decoded) });
                }
                _ => {}
            }
        }
        let spec = spec.ok_or_else(|| not_lumen(BadMessage::NoSpec))?;
        Ok(Self { path: path.to_owned(), spec, session, frames, replies, missed })
    }

    /// The frames in file order, read one at a time.
    pub fn frames(&self) -> Result<impl Iterator<Item = Result<RecordedFrame, RecordingError>>, RecordingError> {
        let path = self.path.clone();
        let (mut state, mut anchor) = (Vec::new(), Vec::new());
        Ok(messages(&self.path)?.filter_map(move |m| match m {
            Err(e) => Some(Err(e)),
            Ok(m) if m.channel.topic == FRAMES_TOPIC => Some(
                decode_frame(&m.data, &mut state, &mut anchor)
                    .map(|header| RecordedFrame { header, state: state.clone(), log_time_ns: m.log_time })
                    .map_err(|source| RecordingError::NotLumen { path: path.clone(), what: BadMessage::Frame { index: None, sequence: m.sequence, source } }),
            ),
            Ok(_) => None,
        }))
    }
}

/// Every message of the file, an error (and nothing more) where reading fails.
pub(crate) fn messages(path: &Path) -> Result<impl Iterator<Item = Result<mcap::Message<'static>, RecordingError>>, RecordingError> {
    let file = File::open(path).map_err(|source| RecordingError::Io { path: path.to_owned(), source })?;
    let path = path.to_owned();
    let mut count = 0u64;
    Ok(mcap::io::MessageReader::new(BufReader::new(file)).map(move |m| match m {
        Ok(m) => {
            count += 1;
            Ok(m)
        }
        Err(source @ mcap::McapError::BadMagic) if count == 0 => Err(RecordingError::NotMcap { path: path.clone(), source }),
        Err(source @ (mcap::McapError::UnexpectedEof | mcap::McapError::Parse(_))) if count == 0 && is_short_or_not_mcap(&path) => Err(RecordingError::NotMcap { path: path.clone(), source }),
        Err(source) => Err(RecordingError::Truncated { path: path.clone(), messages: count, source }),
    }))
}

/// Whether the file does not even start with the MCAP magic.
fn is_short_or_not_mcap(path: &Path) -> bool {
    let mut head = [0u8; 8];
    match File::open(path).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head)) {
        Ok(()) => head != mcap::MAGIC,
        Err(_) => true,
    }
}

/// How a frame message is coded ([`encode_frame_message`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Coding {
    /// Every float (kind 0); it becomes the anchor.
    Whole,
    /// A delta against the anchor (kind 4): a key frame that needs no message but the anchor.
    Anchored,
    /// A delta against the frame before (kind 3, or 2 for plain rows).
    Delta,
}

/// Appends the frame message of `header` and `state`, coded as `coding` says against `last`
/// (the floats of the message before, and its frame number) or `anchor` (the last whole frame's
/// floats and number); `last` becomes `state`, and `anchor` too where it is written whole.
fn encode_frame_message(
    header: &FrameHeader,
    last: (&mut Vec<f32>, u64),
    anchor: (&mut Vec<f32>, &mut u64),
    state: &[f32],
    coding: Coding,
    encoder: &mut Encoder,
    out: &mut Vec<u8>,
) -> Result<(), DeltaError> {
    let (last, last_frame) = last;
    out.extend_from_slice(&header.to_bytes());
    match coding {
        Coding::Whole => {
            out.extend_from_slice(&0u32.to_le_bytes());
            state.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
            anchor.0.clear();
            anchor.0.extend_from_slice(state);
            *anchor.1 = header.frame;
            last.clear();
            last.extend_from_slice(state);
        }
        Coding::Anchored => {
            out.extend_from_slice(&4u32.to_le_bytes());
            encoder.encode(*anchor.1, anchor.0, state, out)?;
            last.clear();
            last.extend_from_slice(state);
        }
        Coding::Delta => {
            out.extend_from_slice(&(if encoder.rows() == Rows::Scaled { 3u32 } else { 2 }).to_le_bytes());
            encoder.encode(last_frame, last, state, out)?;
            encoder.apply_last(last);
        }
    }
    Ok(())
}

thread_local! {
    /// The decoder of coded deltas (kind 2 or 3), kept from one frame to the next.
    static DECODER: std::cell::RefCell<Option<Decoder>> = const { std::cell::RefCell::new(None) };
}

/// Decodes a frame message into its header and `state` (which holds the frame decoded before
/// it on the topic, and becomes this one's floats); `anchor` holds the last whole frame decoded
/// (what an anchored key frame is against), and becomes this one's floats if it is whole.
pub(crate) fn decode_frame(bytes: &[u8], state: &mut Vec<f32>, anchor: &mut Vec<f32>) -> Result<FrameHeader, FrameDecodeError> {
    let header = FrameHeader::read(bytes)?;
    let mut r = Words(&bytes[wire::FRAME_HEADER_BYTES..]);
    let floats = header.floats as usize;
    match r.u32()? {
        0 => {
            let body = r.0;
            if body.len() != 4 * floats {
                return Err(FrameDecodeError::KeyFrameLength { bytes: body.len(), floats });
            }
            state.clear();
            state.extend(body.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])));
            anchor.clear();
            anchor.extend_from_slice(state);
        }
        1 => {
            if state.len() != floats {
                return Err(FrameDecodeError::DeltaWithoutKey { floats, before: state.len() });
            }
            for _ in 0..r.u32()? {
                let (start, len) = (r.u32()? as usize, r.u32()? as usize);
                if start.checked_add(len).is_none_or(|end| end > floats) {
                    return Err(FrameDecodeError::RunBeyond { start, len, floats });
                }
                for v in &mut state[start..start + len] {
                    *v = f32::from_bits(r.u32()?);
                }
            }
            if !r.0.is_empty() {
                return Err(FrameDecodeError::Trailing(r.0.len()));
            }
        }
        kind @ (2..=4) => {
            let coding = if kind == 2 { Rows::Plain } else { Rows::Scaled };
            if kind == 4 {
                if anchor.len() != floats {
                    return Err(FrameDecodeError::AnchoredWithoutWhole { floats, anchor: anchor.len() });
                }
                state.clear();
                state.extend_from_slice(anchor);
            }
            if state.len() != floats {
                return Err(FrameDecodeError::DeltaWithoutKey { floats, before: state.len() });
            }
            DECODER.with(|d| {
                let mut d = d.borrow_mut();
                let decoder = match &mut *d {
                    Some(x) => x,
                    None => d.insert(Decoder::new().map_err(|e| FrameDecodeError::Delta(e.to_string()))?),
                };
                decoder.read(r.0, floats, coding).map_err(|e| FrameDecodeError::Delta(e.to_string()))?;
                decoder.apply(state);
                Ok::<(), FrameDecodeError>(())
            })?;
        }
        k => return Err(FrameDecodeError::UnknownKind(k)),
    }
    Ok(header)
}

/// A reply's wire bytes (`ContactsHeader`, then `count` contacts of [`CONTACT_BYTES`]) with
/// the contacts' bytes as planes: byte `j` of contact `i` at `256 + j * count + i`. Like bytes
/// of every contact (a flag, the high byte of a coordinate) then lie together, and the chunk's
/// zstd makes a recorded reply about a third smaller than as it is on the wire. A body that is
/// not whole contacts is copied as it is (and refused by the reader as on the wire).
pub fn to_planes(wire: &[u8], out: &mut Vec<u8>) {
    transpose(wire, out, true);
}

/// The wire bytes of a reply [`to_planes`] wrote.
pub fn from_planes(planes: &[u8], out: &mut Vec<u8>) {
    transpose(planes, out, false);
}

/// The header as it is, then the body as an `n x 88` byte matrix transposed (`forth`) or back.
fn transpose(bytes: &[u8], out: &mut Vec<u8>, forth: bool) {
    out.clear();
    let split = wire::CONTACTS_HEADER_BYTES.min(bytes.len());
    let (head, body) = bytes.split_at(split);
    out.extend_from_slice(head);
    if !body.len().is_multiple_of(CONTACT_BYTES) {
        out.extend_from_slice(body);
        return;
    }
    let n = body.len() / CONTACT_BYTES;
    out.resize(split + body.len(), 0);
    let dst = &mut out[split..];
    for i in 0..n {
        for j in 0..CONTACT_BYTES {
            let (contact, plane) = (i * CONTACT_BYTES + j, j * n + i);
            if forth {
                dst[plane] = body[contact];
            } else {
                dst[contact] = body[plane];
            }
        }
    }
}

/// Little-endian `u32`s read off the front of a byte slice.
struct Words<'a>(&'a [u8]);

impl Words<'_> {
    fn u32(&mut self) -> Result<u32, FrameDecodeError> {
        let (w, rest) = self.0.split_first_chunk::<4>().ok_or(FrameDecodeError::CutWord)?;
        self.0 = rest;
        Ok(u32::from_le_bytes(*w))
    }
}

/// `Ok(())` if a reply equals the recorded one bit for bit in everything the frame determines
/// (status, error location and message, flags, every contact's bytes), else the first
/// difference. Session, frame, timestamps, `detect_ns` and `skipped` are not compared: they
/// belong to the run, not to the frame.
pub fn compare_replies(got: (&ContactsHeader, &[Contact]), recorded: &RecordedReply) -> Result<(), ReplyDifference> {
    let (h, contacts) = got;
    let r = &recorded.header;
    if h.status != r.status {
        return Err(ReplyDifference::Status { got: h.status, got_message: h.message().to_owned(), recorded: r.status, recorded_message: r.message().to_owned() });
    }
    if (h.error_body, h.error_index, h.error_spoke) != (r.error_body, r.error_index, r.error_spoke) || h.message() != r.message() {
        return Err(ReplyDifference::Error { got: h.message().to_owned(), recorded: r.message().to_owned() });
    }
    if h.flags != r.flags {
        return Err(ReplyDifference::Flags { got: h.flags, recorded: r.flags });
    }
    if contacts.len() != recorded.contacts.len() {
        return Err(ReplyDifference::Count { got: contacts.len(), recorded: recorded.contacts.len() });
    }
    let (mut a, mut b) = (Vec::with_capacity(CONTACT_BYTES), Vec::with_capacity(CONTACT_BYTES));
    for (i, (x, y)) in contacts.iter().zip(&recorded.contacts).enumerate() {
        a.clear();
        b.clear();
        wire::encode_contact(x, &mut a);
        wire::encode_contact(y, &mut b);
        if a != b {
            return Err(ReplyDifference::Contact { index: i, got_depth: x.depth, got_point: x.point_a, recorded_depth: y.depth, recorded_point: y.point_a });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(frame: u64, floats: usize) -> FrameHeader {
        FrameHeader::new(7, frame, 0, floats, 1)
    }

    /// Frame `h` whole (`key`) or as a delta against `last`.
    fn message(h: &FrameHeader, last: &mut Vec<f32>, state: &[f32], key: bool) -> Vec<u8> {
        let mut out = Vec::new();
        let coding = if key { Coding::Whole } else { Coding::Delta };
        encode_frame_message(h, (last, h.frame.saturating_sub(1)), (&mut Vec::new(), &mut 0), state, coding, &mut Encoder::new().unwrap(), &mut out).unwrap();
        out
    }

    #[test]
    fn deltas_restore_every_bit_and_stay_small() {
        let mut anchor = Vec::new();
        // Sparse changes, runs at both ends, a gap of one unchanged float inside a run, and
        // values only bits tell apart (NaN payloads, -0.0).
        let mut state: Vec<f32> = (0..1002).map(|i| i as f32 * 0.5).collect();
        let mut last = Vec::new();
        let mut decoded = Vec::new();
        let key = message(&header(0, 1002), &mut last, &state, true);
        decode_frame(&key, &mut decoded, &mut anchor).unwrap();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&decoded), bits(&state));
        for f in 1..20u64 {
            state[0] = f as f32;
            state[999] = -0.0;
            state[500] = f32::from_bits(0x7fc0_0000 | f as u32);
            state[502] = f as f32 * 3.0;
            state[(f as usize * 37) % 1000] += 1.0;
            let m = message(&header(f, 1002), &mut last, &state, false);
            assert!(m.len() < wire::FRAME_HEADER_BYTES + 4 + 16 + 120, "{} bytes", m.len());
            let h = decode_frame(&m, &mut decoded, &mut anchor).unwrap();
            assert_eq!(h.frame, f);
            assert_eq!(bits(&decoded), bits(&state), "frame {f}");
        }
        // An unchanged frame is a delta of no rows: a few bytes of zstd.
        let m = message(&header(20, 1002), &mut last, &state, false);
        assert!(m.len() < wire::FRAME_HEADER_BYTES + 4 + 16 + 40, "{} bytes", m.len());
        // A coded delta cut short or corrupted is named.
        let m = message(&header(21, 1002), &mut last, &state, false);
        let err = decode_frame(&m[..m.len() - 3], &mut decoded, &mut anchor).unwrap_err().to_string();
        assert!(err.contains("coded bytes"), "{err}");
    }

    #[test]
    fn deltas_are_written_scaled_and_earlier_plain_ones_still_read() {
        let mut anchor = Vec::new();
        let base: Vec<f32> = (0..300).map(|i| 10.0 + i as f32 * 0.25).collect();
        let lengthened: Vec<f32> = base.iter().map(|v| v * 1.001).collect();
        let kind = |m: &[u8]| u32::from_le_bytes(m[wire::FRAME_HEADER_BYTES..wire::FRAME_HEADER_BYTES + 4].try_into().unwrap());
        let (mut last, mut decoded) = (Vec::new(), Vec::new());
        decode_frame(&message(&header(0, 300), &mut last, &base, true), &mut decoded, &mut anchor).unwrap();
        let scaled = message(&header(1, 300), &mut last.clone(), &lengthened, false);
        assert_eq!(kind(&scaled), 3);
        let mut plain = Vec::new();
        encode_frame_message(&header(1, 300), (&mut last, 0), (&mut Vec::new(), &mut 0), &lengthened, Coding::Delta, &mut Encoder::with_rows(Rows::Plain).unwrap(), &mut plain).unwrap();
        assert_eq!(kind(&plain), 2);
        assert!(scaled.len() < plain.len(), "scaled {} bytes, plain {}", scaled.len(), plain.len());
        for m in [&scaled, &plain] {
            let mut state = decoded.clone();
            decode_frame(m, &mut state, &mut anchor).unwrap();
            assert!(state.iter().zip(&lengthened).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
    }

    #[test]
    fn broken_frame_messages_are_named() {
        let mut anchor = Vec::new();
        let state = vec![1.0f32; 10];
        let mut last = Vec::new();
        let key = message(&header(0, 10), &mut last, &state, true);
        let mut decoded = Vec::new();
        // An anchored key frame with no whole frame before it.
        let mut anchored = Vec::new();
        let six = vec![2.0f32; 12];
        encode_frame_message(&header(5, 12), (&mut six.clone(), 4), (&mut six.clone(), &mut 0), &six, Coding::Anchored, &mut Encoder::new().unwrap(), &mut anchored).unwrap();
        assert!(decode_frame(&anchored, &mut decoded, &mut anchor).unwrap_err().to_string().contains("anchored key frame for 12 floats"));
        // A delta with nothing before it (the run-coded kind of older files).
        let mut delta = header(1, 10).to_bytes().to_vec();
        delta.extend_from_slice(&1u32.to_le_bytes());
        delta.extend_from_slice(&0u32.to_le_bytes());
        assert!(decode_frame(&delta, &mut decoded, &mut anchor).unwrap_err().to_string().contains("no key frame"));
        decode_frame(&key, &mut decoded, &mut anchor).unwrap();
        // A run beyond the frame, a cut message, an unknown kind, a short key frame.
        let mut beyond = header(1, 10).to_bytes().to_vec();
        for w in [1u32, 1, 8, 3, 0, 0, 0] {
            beyond.extend_from_slice(&w.to_le_bytes());
        }
        assert!(decode_frame(&beyond, &mut decoded, &mut anchor).unwrap_err().to_string().contains("beyond"));
        assert!(decode_frame(&beyond[..beyond.len() - 2], &mut decoded, &mut anchor).is_err());
        let mut kind = header(1, 10).to_bytes().to_vec();
        kind.extend_from_slice(&9u32.to_le_bytes());
        assert!(decode_frame(&kind, &mut decoded, &mut anchor).unwrap_err().to_string().contains("unknown frame kind 9"));
        assert!(decode_frame(&key[..key.len() - 4], &mut decoded, &mut anchor).unwrap_err().to_string().contains("key frame"));
    }

    fn spec() -> SceneSpec {
        use lumen_proto::{BodySpec, Shape};
        SceneSpec::new(vec![BodySpec { name: "scope".into(), shape: Shape::Rod { points: 4, radius: vec![1.0] } }], Vec::<lumen_proto::PairSpec>::new())
    }

    /// Reply `k`: `k % 5` contacts whose every field differs from contact to contact.
    fn reply(k: u64) -> (ContactsHeader, Vec<Contact>) {
        let h = ContactsHeader::reply_to(&FrameHeader::new(7, k, 1_000 * (k + 1), 12, 1));
        let c = |i: u32| {
            let f = (k * 7 + i as u64) as f32;
            Contact {
                pair: i as u16,
                kind: (i % 3) as u8,
                flags: i as u8,
                body_a: 0,
                body_b: 1,
                sample: i * 9,
                segment_a: i,
                param_a: 0.25,
                index_b: 100 + i,
                spoke_b: i % 32,
                param_b: 0.5,
                weights_b: [0.1, 0.2, 0.3, 0.4],
                point_a: [f, -f, 0.5 * f],
                point_b: [f + 0.1, 3.0, -2.0],
                normal: [0.6, 0.8, 0.0],
                depth: -0.01 * f,
            }
        };
        (h, (0..(k % 5) as u32).map(c).collect())
    }

    #[test]
    fn replies_are_written_as_planes_and_read_back_exactly_and_older_files_still_read() {
        for n in [0usize, 1, 3, 64] {
            let wire_bytes: Vec<u8> = (0..wire::CONTACTS_HEADER_BYTES + n * CONTACT_BYTES).map(|i| (i * 31 % 251) as u8).collect();
            let (mut planes, mut back) = (Vec::new(), Vec::new());
            to_planes(&wire_bytes, &mut planes);
            assert_eq!(planes.len(), wire_bytes.len());
            if n > 1 {
                assert_ne!(planes, wire_bytes);
                // Byte 2 (the kind) of contact 1 is in plane 2.
                assert_eq!(planes[wire::CONTACTS_HEADER_BYTES + 2 * n + 1], wire_bytes[wire::CONTACTS_HEADER_BYTES + CONTACT_BYTES + 2]);
            }
            from_planes(&planes, &mut back);
            assert_eq!(back, wire_bytes, "{n} contacts");
        }
        let dir = std::env::temp_dir().join(format!("lumen_recording_planes_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (new, old) = (dir.join("planes.mcap"), dir.join("repr-c.mcap"));
        let mut w = Writer::create_with(&new, &spec(), 7, "test", WriterOptions { scene: false }).unwrap();
        for k in 0..12 {
            let (h, c) = reply(k);
            w.contacts(&h, &c, 1).unwrap();
        }
        w.finish(Missed::default()).unwrap();
        // The same replies as an older recorder wrote them: the wire bytes as they are.
        let mut m = mcap::WriteOptions::new().create(BufWriter::new(File::create(&old).unwrap())).unwrap();
        let none = BTreeMap::new();
        let spec_channel = m.add_channel(0, SPEC_TOPIC, "json", &none).unwrap();
        let contacts_channel = m.add_channel(0, CONTACTS_TOPIC, WIRE_ENCODING, &none).unwrap();
        m.write_to_known_channel(&MessageHeader { channel_id: spec_channel, sequence: 0, log_time: 0, publish_time: 0 }, serde_json::to_string(&spec()).unwrap().as_bytes()).unwrap();
        for k in 0..12 {
            let (mut h, c) = reply(k);
            let mut b = Vec::new();
            wire::encode_contacts(&mut h, &c, &mut b);
            m.write_to_known_channel(&MessageHeader { channel_id: contacts_channel, sequence: k as u32 + 1, log_time: k, publish_time: 0 }, &b).unwrap();
        }
        m.finish().unwrap();
        drop(m);
        for path in [&new, &old] {
            let r = Recording::open(path).unwrap();
            assert_eq!(r.replies.len(), 12);
            for k in 0..12 {
                let (h, c) = reply(k);
                compare_replies((&h, &c), &r.replies[&k]).unwrap_or_else(|e| panic!("{}: reply {k}: {e}", path.display()));
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
