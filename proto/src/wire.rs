//! The per-frame messages, byte for byte: a frame (header + flat `f32` state) from a client to
//! the daemon, and a contacts reply (header + [`Contact`] records) back.
//!
//! Both headers are `#[repr(C)]`, little-endian, with no implicit padding; `proto/README.md`
//! gives every offset. On iceoryx2 the header travels as the sample's user header and the
//! floats / contacts as its payload slice; on zenoh one message holds the header's bytes
//! followed by the payload's bytes. The bytes are the same either way.
//!
//! Everything here is plain computation on bytes: decoding never panics, whatever it is given.

use crate::contact::Contact;
use crate::error::InputError;
use crate::state::StateLayout;
use std::fmt;

/// Version of the frame and contacts layouts (and of the control messages).
pub const PROTOCOL_VERSION: u16 = 1;

/// The largest frame number a frame may carry, 2^53 - 1 (safe in JSON doubles, as session ids
/// are; 285,000 years at 1 kHz). A frame numbered beyond it is answered with status 1 and
/// changes nothing: numbers go up from 0, and one at the top of the range would leave none
/// above it for the frames after (over zenoh a frame must be numbered above every one before).
pub const MAX_FRAME_NUMBER: u64 = 9_007_199_254_740_991;

/// `FrameHeader::magic`: the bytes `L M N F` read as a little-endian `u32`.
pub const FRAME_MAGIC: u32 = u32::from_le_bytes(*b"LMNF");
/// `ContactsHeader::magic`: the bytes `L M N C` read as a little-endian `u32`.
pub const CONTACTS_MAGIC: u32 = u32::from_le_bytes(*b"LMNC");
/// Size of [`FrameHeader`] in bytes.
pub const FRAME_HEADER_BYTES: usize = 40;
/// Size of [`ContactsHeader`] in bytes.
pub const CONTACTS_HEADER_BYTES: usize = 256;
/// Size of one [`Contact`] in bytes.
pub const CONTACT_BYTES: usize = 88;
/// Capacity of [`ContactsHeader::message`] in bytes.
pub const MESSAGE_BYTES: usize = 196;
/// `ContactsHeader::error_*` value meaning "does not apply".
pub const NO_INDEX: u32 = u32::MAX;
/// `ContactsHeader::flags` bit: more contacts were found than the session's capacity
/// (`SessionInfo::max_contacts`); the first `count` are sent.
pub const FLAG_TRUNCATED: u16 = 1;
/// `FrameHeader::flags` bit: the frame carries what changed since a base frame (a
/// [`DeltaHeader`] and its coded rows) instead of every float.
pub const FLAG_DELTA: u16 = 1;
/// `FrameHeader::flags` bit: keep this frame's state as the session's base once it is answered
/// with status 0 (the daemon holds one base; a newer kept frame replaces it).
pub const FLAG_KEEP: u16 = 2;
/// `FrameHeader::flags` bit, with [`FLAG_DELTA`] only: each changed row of the delta also
/// carries a scale, and its floats are coded against the base's row times that scale (a radial
/// vector that only lengthens or shortens costs its scale and a few bits).
pub const FLAG_SCALED: u16 = 4;
/// The frame flags version 1 defines; any other bit, or [`FLAG_SCALED`] without
/// [`FLAG_DELTA`], is refused as malformed.
pub const FRAME_FLAGS: u16 = FLAG_DELTA | FLAG_KEEP | FLAG_SCALED;
/// Size of [`DeltaHeader`] in bytes (after the frame header of a delta frame).
pub const DELTA_HEADER_BYTES: usize = 16;

/// Header of one frame: who sends it, which frame it is, and how many floats follow.
///
/// The floats that follow are the whole scene state in the layout of
/// [`crate::state`]: every body's control points and radial vectors in spec order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(C)]
pub struct FrameHeader {
    /// [`FRAME_MAGIC`].
    pub magic: u32,
    /// [`PROTOCOL_VERSION`].
    pub version: u16,
    /// [`FLAG_DELTA`], [`FLAG_KEEP`] and [`FLAG_SCALED`]; other bits are reserved (0).
    pub flags: u16,
    /// The session id from the open reply.
    pub session: u64,
    /// Frame number chosen by the client (normally counting up from 0); echoed in the reply.
    pub frame: u64,
    /// The client's own timestamp in nanoseconds (any clock); echoed untouched in the reply.
    pub client_time_ns: u64,
    /// Number of `f32` values that follow; must equal the spec's state size.
    pub floats: u32,
    /// Number of bodies the client wrote; must equal the spec's body count.
    pub bodies: u32,
}

/// What the daemon made of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum Status {
    /// Contacts computed; `count` of them follow.
    Ok = 0,
    /// Not a frame: the magic is wrong, reserved header flags are set, or the frame number is
    /// beyond [`MAX_FRAME_NUMBER`].
    Malformed = 1,
    /// The header's version is not [`PROTOCOL_VERSION`].
    BadVersion = 2,
    /// The header names another session.
    BadSession = 3,
    /// The number of floats (header or payload) does not match the spec's state size.
    BadLength = 4,
    /// The header's body count does not match the spec.
    BadCounts = 5,
    /// A coordinate is NaN or infinite; `error_body`, `error_index`, `error_spoke` say where.
    NonFinite = 6,
    /// Reserved, never sent: a tube ring that is not star-shaped is still answered, its
    /// contacts flagged `FLAG_NOT_STAR`.
    NotStarShaped = 7,
    /// The daemon could not answer this frame (out of shared memory); the session goes on.
    Internal = 8,
    /// A value's magnitude is beyond `limits::MAX_COORDINATE` (1e9; `error_body`,
    /// `error_index`, `error_spoke` say where), or a contact came out non-finite (`error_body`
    /// is the rod, `error_index` its sample): nothing non-finite is ever sent.
    OutOfRange = 9,
    /// A delta frame names a base the session does not hold (never kept, or replaced by a
    /// newer kept frame, or the daemon restarted): nothing was detected; send a full frame.
    NoBase = 10,
    /// A delta frame that does not decode (cut short, corrupted, counts that disagree):
    /// nothing was detected and the base is unchanged.
    BadDelta = 11,
}

impl Status {
    /// The status of a `u16` from the wire, if known.
    pub fn from_u16(v: u16) -> Option<Self> {
        use Status::*;
        Some(match v {
            0 => Ok,
            1 => Malformed,
            2 => BadVersion,
            3 => BadSession,
            4 => BadLength,
            5 => BadCounts,
            6 => NonFinite,
            7 => NotStarShaped,
            8 => Internal,
            9 => OutOfRange,
            10 => NoBase,
            11 => BadDelta,
            _ => return None,
        })
    }
}

/// Header of one contacts reply.
#[derive(Clone, Copy, PartialEq, Eq)]
#[repr(C)]
pub struct ContactsHeader {
    /// [`CONTACTS_MAGIC`].
    pub magic: u32,
    /// [`PROTOCOL_VERSION`].
    pub version: u16,
    /// [`Status`] as `u16`.
    pub status: u16,
    /// The session id.
    pub session: u64,
    /// The frame this answers (0 if the frame was too malformed to read it).
    pub frame: u64,
    /// The frame's `client_time_ns`, echoed.
    pub client_time_ns: u64,
    /// Time spent in detection, nanoseconds (0 on error).
    pub detect_ns: u32,
    /// Number of [`Contact`] records that follow.
    pub count: u32,
    /// Frames of this session the daemon skipped (a newer one had arrived) since the previous
    /// reply.
    pub skipped: u32,
    /// Body index of a bad value, or [`NO_INDEX`].
    pub error_body: u32,
    /// Control point / ring of a bad value, or [`NO_INDEX`].
    pub error_index: u32,
    /// Radial vector of a bad value, or [`NO_INDEX`] for a control point.
    pub error_spoke: u32,
    /// Bytes of `message` in use.
    pub message_len: u16,
    /// `FLAG_*` bits.
    pub flags: u16,
    /// UTF-8 text saying what was wrong (status != Ok); unused bytes are 0.
    pub message: [u8; MESSAGE_BYTES],
}

const _: () = assert!(std::mem::size_of::<FrameHeader>() == FRAME_HEADER_BYTES);
const _: () = assert!(std::mem::align_of::<FrameHeader>() == 8);
const _: () = assert!(std::mem::size_of::<ContactsHeader>() == CONTACTS_HEADER_BYTES);
const _: () = assert!(std::mem::align_of::<ContactsHeader>() == 8);
const _: () = assert!(std::mem::size_of::<Contact>() == CONTACT_BYTES);

impl Default for ContactsHeader {
    fn default() -> Self {
        Self {
            magic: CONTACTS_MAGIC,
            version: PROTOCOL_VERSION,
            status: Status::Ok as u16,
            session: 0,
            frame: 0,
            client_time_ns: 0,
            detect_ns: 0,
            count: 0,
            skipped: 0,
            error_body: NO_INDEX,
            error_index: NO_INDEX,
            error_spoke: NO_INDEX,
            message_len: 0,
            flags: 0,
            message: [0; MESSAGE_BYTES],
        }
    }
}

impl fmt::Debug for ContactsHeader {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ContactsHeader")
            .field("status", &Status::from_u16(self.status).ok_or(self.status))
            .field("session", &self.session)
            .field("frame", &self.frame)
            .field("client_time_ns", &self.client_time_ns)
            .field("detect_ns", &self.detect_ns)
            .field("count", &self.count)
            .field("skipped", &self.skipped)
            .field("flags", &self.flags)
            .field("message", &self.message())
            .finish()
    }
}

/// Why a frame was refused before detection ran.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// Fewer bytes than a header.
    TooShort { got: usize },
    /// Wrong magic number.
    Magic { got: u32 },
    /// Wrong protocol version.
    Version { got: u16 },
    /// Reserved header flags set (version 1 defines [`FRAME_FLAGS`]).
    Flags { got: u16 },
    /// A frame number beyond [`MAX_FRAME_NUMBER`].
    FrameNumber { got: u64 },
    /// Another session's frame.
    Session { expected: u64, got: u64 },
    /// Header or payload float count differs from the spec's state size.
    Floats { expected: usize, header: usize, payload: usize },
    /// Header body count differs from the spec.
    Bodies { expected: usize, got: usize },
    /// Payload bytes are not a whole number of floats.
    Ragged { bytes: usize },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            FrameError::TooShort { got } => write!(f, "frame of {got} bytes is shorter than its {FRAME_HEADER_BYTES}-byte header"),
            FrameError::Magic { got } => write!(f, "frame magic is {got:#010x}; expected {FRAME_MAGIC:#010x} (\"LMNF\")"),
            FrameError::Version { got } => write!(f, "frame version {got}; this daemon speaks version {PROTOCOL_VERSION}"),
            FrameError::Flags { got } => write!(f, "frame flags are {got:#06x}; version {PROTOCOL_VERSION} defines only bit 0 (delta), bit 1 (keep) and bit 2 (scaled, with delta only)"),
            FrameError::FrameNumber { got } => write!(f, "frame number {got} is beyond {MAX_FRAME_NUMBER} (2^53 - 1): number frames 0, 1, 2, ..."),
            FrameError::Session { expected, got } => write!(f, "frame names session {got}; this is session {expected}"),
            FrameError::Floats { expected, header, payload } => {
                write!(f, "frame holds {payload} floats (header says {header}); the spec's state needs exactly {expected}")
            }
            FrameError::Bodies { expected, got } => write!(f, "frame header counts {got} bodies; the spec declares {expected}"),
            FrameError::Ragged { bytes } => write!(f, "frame payload of {bytes} bytes is not a whole number of 4-byte floats"),
        }
    }
}

impl std::error::Error for FrameError {}

impl FrameError {
    /// The reply status for this error.
    pub fn status(&self) -> Status {
        match self {
            FrameError::TooShort { .. } | FrameError::Magic { .. } | FrameError::Flags { .. } | FrameError::FrameNumber { .. } => Status::Malformed,
            FrameError::Version { .. } => Status::BadVersion,
            FrameError::Session { .. } => Status::BadSession,
            FrameError::Floats { .. } | FrameError::Ragged { .. } => Status::BadLength,
            FrameError::Bodies { .. } => Status::BadCounts,
        }
    }
}

impl FrameHeader {
    /// A header for `session`'s frame number `frame` carrying `floats` floats of `bodies` bodies.
    pub fn new(session: u64, frame: u64, client_time_ns: u64, floats: usize, bodies: usize) -> Self {
        Self { magic: FRAME_MAGIC, version: PROTOCOL_VERSION, flags: 0, session, frame, client_time_ns, floats: floats as u32, bodies: bodies as u32 }
    }

    /// The header's 40 bytes, little-endian.
    pub fn to_bytes(&self) -> [u8; FRAME_HEADER_BYTES] {
        let mut b = [0u8; FRAME_HEADER_BYTES];
        b[0..4].copy_from_slice(&self.magic.to_le_bytes());
        b[4..6].copy_from_slice(&self.version.to_le_bytes());
        b[6..8].copy_from_slice(&self.flags.to_le_bytes());
        b[8..16].copy_from_slice(&self.session.to_le_bytes());
        b[16..24].copy_from_slice(&self.frame.to_le_bytes());
        b[24..32].copy_from_slice(&self.client_time_ns.to_le_bytes());
        b[32..36].copy_from_slice(&self.floats.to_le_bytes());
        b[36..40].copy_from_slice(&self.bodies.to_le_bytes());
        b
    }

    /// Reads a header from the first 40 bytes of `b`, whatever they hold (no checks).
    pub fn read(b: &[u8]) -> Result<Self, FrameError> {
        if b.len() < FRAME_HEADER_BYTES {
            return Err(FrameError::TooShort { got: b.len() });
        }
        Ok(Self {
            magic: le_u32(b, 0),
            version: le_u16(b, 4),
            flags: le_u16(b, 6),
            session: le_u64(b, 8),
            frame: le_u64(b, 16),
            client_time_ns: le_u64(b, 24),
            floats: le_u32(b, 32),
            bodies: le_u32(b, 36),
        })
    }

    /// Whether the frame carries a delta ([`FLAG_DELTA`]) rather than every float.
    pub fn is_delta(&self) -> bool {
        self.flags & FLAG_DELTA != 0
    }

    /// Whether the frame asks to be kept as the session's base ([`FLAG_KEEP`]).
    pub fn keeps(&self) -> bool {
        self.flags & FLAG_KEEP != 0
    }

    /// Checks this header and a payload of `payload_floats` floats against the session (for a
    /// delta frame, pass the header's own `floats`: its payload is coded, see [`DeltaHeader`]).
    pub fn check(&self, session: u64, layout: &StateLayout, payload_floats: usize) -> Result<(), FrameError> {
        if self.magic != FRAME_MAGIC {
            return Err(FrameError::Magic { got: self.magic });
        }
        if self.version != PROTOCOL_VERSION {
            return Err(FrameError::Version { got: self.version });
        }
        if self.flags & !FRAME_FLAGS != 0 || (self.flags & FLAG_SCALED != 0 && self.flags & FLAG_DELTA == 0) {
            return Err(FrameError::Flags { got: self.flags });
        }
        if self.frame > MAX_FRAME_NUMBER {
            return Err(FrameError::FrameNumber { got: self.frame });
        }
        if self.session != session {
            return Err(FrameError::Session { expected: session, got: self.session });
        }
        if self.bodies as usize != layout.bodies.len() {
            return Err(FrameError::Bodies { expected: layout.bodies.len(), got: self.bodies as usize });
        }
        if self.floats as usize != layout.floats || payload_floats != layout.floats {
            return Err(FrameError::Floats { expected: layout.floats, header: self.floats as usize, payload: payload_floats });
        }
        Ok(())
    }
}

/// Splits a frame message (header bytes + float bytes, as on zenoh) and decodes its floats into
/// `state` (which is resized only within its capacity: give it the spec's state size).
/// Checks everything [`FrameHeader::check`] checks.
pub fn decode_frame(bytes: &[u8], session: u64, layout: &StateLayout, state: &mut Vec<f32>) -> Result<FrameHeader, (FrameHeader, FrameError)> {
    let header = FrameHeader::read(bytes).map_err(|e| (FrameHeader::default(), e))?;
    let body = &bytes[FRAME_HEADER_BYTES..];
    if !body.len().is_multiple_of(4) {
        return Err((header, FrameError::Ragged { bytes: body.len() }));
    }
    header.check(session, layout, body.len() / 4).map_err(|e| (header, e))?;
    state.clear();
    state.extend(body.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])));
    Ok(header)
}

/// Appends a whole frame message (header then floats, little-endian) to `out`.
pub fn encode_frame(header: &FrameHeader, state: &[f32], out: &mut Vec<u8>) {
    out.extend_from_slice(&header.to_bytes());
    out.reserve(4 * state.len());
    #[cfg(target_endian = "little")]
    {
        // SAFETY: f32 has no padding and no invalid bytes; u8 needs no alignment; the view
        // covers exactly the slice's memory. On little-endian hosts these are the wire bytes.
        let bytes = unsafe { std::slice::from_raw_parts(state.as_ptr().cast::<u8>(), std::mem::size_of_val(state)) };
        out.extend_from_slice(bytes);
    }
    #[cfg(not(target_endian = "little"))]
    for v in state {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// What follows the frame header of a delta frame ([`FLAG_DELTA`]): 16 bytes, then `encoded`
/// bytes of one zstd frame holding the changed rows (`lumen_transport::delta` codes them;
/// `proto/README.md`, section 2, gives the layout).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DeltaHeader {
    /// The frame number of the base: a frame the daemon answered with status 0 and kept.
    pub base: u64,
    /// Rows (3 floats: a point or a radial vector) that differ from the base.
    pub changed: u32,
    /// Bytes of the zstd frame that follows.
    pub encoded: u32,
}

impl DeltaHeader {
    /// The header's 16 bytes, little-endian.
    pub fn to_bytes(&self) -> [u8; DELTA_HEADER_BYTES] {
        let mut b = [0u8; DELTA_HEADER_BYTES];
        b[0..8].copy_from_slice(&self.base.to_le_bytes());
        b[8..12].copy_from_slice(&self.changed.to_le_bytes());
        b[12..16].copy_from_slice(&self.encoded.to_le_bytes());
        b
    }

    /// Reads the header from the first 16 bytes of `b`; `None` if there are fewer.
    pub fn read(b: &[u8]) -> Option<Self> {
        (b.len() >= DELTA_HEADER_BYTES).then(|| Self { base: le_u64(b, 0), changed: le_u32(b, 8), encoded: le_u32(b, 12) })
    }
}

impl ContactsHeader {
    /// An `Ok` reply to `frame` with no contacts yet.
    pub fn reply_to(frame: &FrameHeader) -> Self {
        Self { session: frame.session, frame: frame.frame, client_time_ns: frame.client_time_ns, ..Self::default() }
    }

    /// The reply's [`Status`], if known.
    pub fn status(&self) -> Option<Status> {
        Status::from_u16(self.status)
    }

    /// The error text (empty when the status is `Ok`).
    pub fn message(&self) -> &str {
        let n = (self.message_len as usize).min(MESSAGE_BYTES);
        match std::str::from_utf8(&self.message[..n]) {
            Ok(s) => s,
            Err(e) => std::str::from_utf8(&self.message[..e.valid_up_to()]).unwrap_or(""),
        }
    }

    /// Sets status and message, cutting the text at a character boundary if it is too long.
    /// Writes into the fixed field: no allocation for `Display` types that do not allocate.
    pub fn set_error(&mut self, status: Status, what: &dyn fmt::Display) {
        use std::io::Write;
        self.status = status as u16;
        self.count = 0;
        self.message = [0; MESSAGE_BYTES];
        let mut cursor = std::io::Cursor::new(&mut self.message[..]);
        let _ = write!(cursor, "{what}"); // a full buffer just ends the text
        let mut n = cursor.position() as usize;
        while n > 0 && std::str::from_utf8(&self.message[..n]).is_err() {
            n -= 1;
        }
        self.message[n..].fill(0);
        self.message_len = n as u16;
    }

    /// Sets the status, location and message of a frame refused before detection.
    pub fn set_frame_error(&mut self, e: &FrameError) {
        self.set_error(e.status(), e);
    }

    /// Sets the status, location and message of a frame the pipeline refused.
    /// `body_index` maps a body name to its index.
    pub fn set_input_error(&mut self, e: &InputError, body_index: impl Fn(&str) -> Option<usize>) {
        let idx = |name: &str| body_index(name).map_or(NO_INDEX, |i| i as u32);
        let (status, body, index, spoke) = match e {
            InputError::StateLength { .. } => (Status::BadLength, NO_INDEX, NO_INDEX, NO_INDEX),
            InputError::NonFinitePoint { body, point, .. } => (Status::NonFinite, idx(body), *point as u32, NO_INDEX),
            InputError::NonFiniteSpoke { body, ring, spoke, .. } => (Status::NonFinite, idx(body), *ring as u32, *spoke as u32),
            InputError::NotStarShaped { body, ring, spoke, .. } => (Status::NotStarShaped, idx(body), *ring as u32, *spoke as u32),
            InputError::OutOfRangePoint { body, point, .. } => (Status::OutOfRange, idx(body), *point as u32, NO_INDEX),
            InputError::OutOfRangeSpoke { body, ring, spoke, .. } => (Status::OutOfRange, idx(body), *ring as u32, *spoke as u32),
            InputError::NonFiniteResult { body, sample } => (Status::OutOfRange, idx(body), *sample as u32, NO_INDEX),
        };
        self.set_error(status, e);
        self.error_body = body;
        self.error_index = index;
        self.error_spoke = spoke;
    }

    /// The header's 256 bytes, little-endian.
    pub fn to_bytes(&self) -> [u8; CONTACTS_HEADER_BYTES] {
        let mut b = [0u8; CONTACTS_HEADER_BYTES];
        b[0..4].copy_from_slice(&self.magic.to_le_bytes());
        b[4..6].copy_from_slice(&self.version.to_le_bytes());
        b[6..8].copy_from_slice(&self.status.to_le_bytes());
        b[8..16].copy_from_slice(&self.session.to_le_bytes());
        b[16..24].copy_from_slice(&self.frame.to_le_bytes());
        b[24..32].copy_from_slice(&self.client_time_ns.to_le_bytes());
        b[32..36].copy_from_slice(&self.detect_ns.to_le_bytes());
        b[36..40].copy_from_slice(&self.count.to_le_bytes());
        b[40..44].copy_from_slice(&self.skipped.to_le_bytes());
        b[44..48].copy_from_slice(&self.error_body.to_le_bytes());
        b[48..52].copy_from_slice(&self.error_index.to_le_bytes());
        b[52..56].copy_from_slice(&self.error_spoke.to_le_bytes());
        b[56..58].copy_from_slice(&self.message_len.to_le_bytes());
        b[58..60].copy_from_slice(&self.flags.to_le_bytes());
        b[60..].copy_from_slice(&self.message);
        b
    }

    /// Reads a header from the first 256 bytes of `b` (no checks beyond the length).
    pub fn read(b: &[u8]) -> Option<Self> {
        if b.len() < CONTACTS_HEADER_BYTES {
            return None;
        }
        let mut message = [0u8; MESSAGE_BYTES];
        message.copy_from_slice(&b[60..CONTACTS_HEADER_BYTES]);
        Some(Self {
            magic: le_u32(b, 0),
            version: le_u16(b, 4),
            status: le_u16(b, 6),
            session: le_u64(b, 8),
            frame: le_u64(b, 16),
            client_time_ns: le_u64(b, 24),
            detect_ns: le_u32(b, 32),
            count: le_u32(b, 36),
            skipped: le_u32(b, 40),
            error_body: le_u32(b, 44),
            error_index: le_u32(b, 48),
            error_spoke: le_u32(b, 52),
            message_len: le_u16(b, 56),
            flags: le_u16(b, 58),
            message,
        })
    }
}

/// Why a contacts message could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactsDecodeError {
    /// Fewer bytes than a header.
    TooShort { got: usize },
    /// Wrong magic or version.
    NotContacts { magic: u32, version: u16 },
    /// The header's count does not match the bytes that follow.
    Count { count: u32, bytes: usize },
}

impl fmt::Display for ContactsDecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ContactsDecodeError::TooShort { got } => write!(f, "contacts message of {got} bytes is shorter than its {CONTACTS_HEADER_BYTES}-byte header"),
            ContactsDecodeError::NotContacts { magic, version } => write!(f, "not a version-{PROTOCOL_VERSION} contacts message (magic {magic:#010x}, version {version})"),
            ContactsDecodeError::Count { count, bytes } => write!(f, "contacts header counts {count} records but {bytes} bytes follow ({CONTACT_BYTES} per record)"),
        }
    }
}

impl std::error::Error for ContactsDecodeError {}

/// Appends one contact's 88 bytes, little-endian, to `out`.
pub fn encode_contact(c: &Contact, out: &mut Vec<u8>) {
    out.extend_from_slice(&c.pair.to_le_bytes());
    out.push(c.kind);
    out.push(c.flags);
    out.extend_from_slice(&c.body_a.to_le_bytes());
    out.extend_from_slice(&c.body_b.to_le_bytes());
    for v in [c.sample, c.segment_a] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&c.param_a.to_le_bytes());
    for v in [c.index_b, c.spoke_b] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let floats = std::iter::once(c.param_b).chain(c.weights_b).chain(c.point_a).chain(c.point_b).chain(c.normal).chain(std::iter::once(c.depth));
    for v in floats {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Reads one contact from 88 bytes (little-endian).
pub fn decode_contact(b: &[u8; CONTACT_BYTES]) -> Contact {
    let f = |o: usize| f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    let f3 = |o: usize| [f(o), f(o + 4), f(o + 8)];
    Contact {
        pair: le_u16(b, 0),
        kind: b[2],
        flags: b[3],
        body_a: le_u16(b, 4),
        body_b: le_u16(b, 6),
        sample: le_u32(b, 8),
        segment_a: le_u32(b, 12),
        param_a: f(16),
        index_b: le_u32(b, 20),
        spoke_b: le_u32(b, 24),
        param_b: f(28),
        weights_b: [f(32), f(36), f(40), f(44)],
        point_a: f3(48),
        point_b: f3(60),
        normal: f3(72),
        depth: f(84),
    }
}

/// Appends a whole contacts message (header then records) to `out`; sets `header.count`.
pub fn encode_contacts(header: &mut ContactsHeader, contacts: &[Contact], out: &mut Vec<u8>) {
    header.count = contacts.len() as u32;
    out.extend_from_slice(&header.to_bytes());
    for c in contacts {
        encode_contact(c, out);
    }
}

/// Reads a whole contacts message into its header and `out` (cleared first).
pub fn decode_contacts(bytes: &[u8], out: &mut Vec<Contact>) -> Result<ContactsHeader, ContactsDecodeError> {
    let h = ContactsHeader::read(bytes).ok_or(ContactsDecodeError::TooShort { got: bytes.len() })?;
    if h.magic != CONTACTS_MAGIC || h.version != PROTOCOL_VERSION {
        return Err(ContactsDecodeError::NotContacts { magic: h.magic, version: h.version });
    }
    let rest = &bytes[CONTACTS_HEADER_BYTES..];
    if rest.len() != h.count as usize * CONTACT_BYTES {
        return Err(ContactsDecodeError::Count { count: h.count, bytes: rest.len() });
    }
    out.clear();
    out.extend(rest.chunks_exact(CONTACT_BYTES).map(|c| decode_contact(c.try_into().expect("exact chunk"))));
    Ok(h)
}

fn le_u16(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn le_u32(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}
fn le_u64(b: &[u8], o: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[o..o + 8]);
    u64::from_le_bytes(a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{BodySpec, SceneSpec, Shape};

    fn layout() -> StateLayout {
        StateLayout::of(&SceneSpec::new(
            vec![BodySpec { name: "t".into(), shape: Shape::Tube { rings: 2, spokes: 3 } }, BodySpec { name: "r".into(), shape: Shape::Rod { points: 2, radius: vec![1.0] } }],
            vec![],
        ))
    }

    #[test]
    fn in_memory_layout_is_the_wire_layout() {
        // On a little-endian host the repr(C) struct's bytes are exactly `to_bytes`.
        let h = FrameHeader::new(7, 9, 11, 30, 2);
        let raw: [u8; FRAME_HEADER_BYTES] = unsafe { std::mem::transmute(h) };
        assert_eq!(raw, h.to_bytes());
        let mut c = ContactsHeader::reply_to(&h);
        c.set_error(Status::NonFinite, &"body 1 went NaN");
        let raw: [u8; CONTACTS_HEADER_BYTES] = unsafe { std::mem::transmute(c) };
        assert_eq!(raw, c.to_bytes());
        let contact = Contact { pair: 1, kind: 2, flags: 3, body_a: 4, body_b: 5, sample: 6, depth: -1.5, normal: [0.0, 1.0, 0.0], ..Contact::default() };
        let raw: [u8; CONTACT_BYTES] = unsafe { std::mem::transmute(contact) };
        let mut enc = Vec::new();
        encode_contact(&contact, &mut enc);
        assert_eq!(enc, raw);
        assert_eq!(decode_contact(&raw), contact);
    }

    #[test]
    fn frame_checks_name_the_problem() {
        let l = layout();
        assert_eq!(l.floats, 2 * 4 * 3 + 6);
        let good = FrameHeader::new(5, 0, 0, l.floats, 2);
        assert_eq!(good.check(5, &l, l.floats), Ok(()));
        assert_eq!(good.check(6, &l, l.floats), Err(FrameError::Session { expected: 6, got: 5 }));
        assert_eq!(good.check(5, &l, 29), Err(FrameError::Floats { expected: 30, header: 30, payload: 29 }));
        let bodies = FrameHeader { bodies: 3, ..good };
        assert_eq!(bodies.check(5, &l, 30).unwrap_err().status(), Status::BadCounts);
        let version = FrameHeader { version: 9, ..good };
        assert_eq!(version.check(5, &l, 30).unwrap_err().status(), Status::BadVersion);
        let flags = FrameHeader { flags: 4, ..good };
        assert_eq!(flags.check(5, &l, 30), Err(FrameError::Flags { got: 4 }));
        assert_eq!(FrameError::Flags { got: 4 }.status(), Status::Malformed);
        assert_eq!(FrameHeader { flags: FLAG_DELTA | FLAG_KEEP, ..good }.check(5, &l, 30), Ok(()));
        assert_eq!(FrameHeader { flags: FLAG_DELTA | FLAG_SCALED, ..good }.check(5, &l, 30), Ok(()));
        assert_eq!(FrameHeader { flags: 8 | FLAG_DELTA, ..good }.check(5, &l, 30), Err(FrameError::Flags { got: 9 }));
        let huge = FrameHeader { frame: u64::MAX, ..good };
        assert_eq!(huge.check(5, &l, 30), Err(FrameError::FrameNumber { got: u64::MAX }));
        assert_eq!(FrameHeader { frame: MAX_FRAME_NUMBER, ..good }.check(5, &l, 30), Ok(()));
        assert_eq!(MAX_FRAME_NUMBER, (1 << 53) - 1);
        let mut state = Vec::with_capacity(30);
        let mut msg = Vec::new();
        encode_frame(&good, &(0..30).map(|i| i as f32).collect::<Vec<_>>(), &mut msg);
        assert_eq!(decode_frame(&msg, 5, &l, &mut state).unwrap(), good);
        assert_eq!(state[29], 29.0);
        assert_eq!(decode_frame(&msg[..msg.len() - 1], 5, &l, &mut state).unwrap_err().1, FrameError::Ragged { bytes: 119 });
        assert_eq!(decode_frame(&msg[..12], 5, &l, &mut state).unwrap_err().1, FrameError::TooShort { got: 12 });
    }

    #[test]
    fn messages_are_cut_at_char_boundaries_and_contacts_round_trip() {
        let mut h = ContactsHeader::default();
        let long = "é".repeat(200); // 400 bytes, 2 per char
        h.set_error(Status::Internal, &long);
        assert_eq!(h.message_len as usize, 196);
        assert_eq!(h.message().chars().count(), 98);
        let contacts: Vec<Contact> = (0..3).map(|i| Contact { sample: i, depth: i as f32 * 0.25, ..Contact::default() }).collect();
        let mut h = ContactsHeader::default();
        let mut bytes = Vec::new();
        encode_contacts(&mut h, &contacts, &mut bytes);
        assert_eq!(bytes.len(), 256 + 3 * 88);
        let mut back = Vec::new();
        assert_eq!(decode_contacts(&bytes, &mut back).unwrap().count, 3);
        assert_eq!(back, contacts);
        assert_eq!(decode_contacts(&bytes[..300], &mut back), Err(ContactsDecodeError::Count { count: 3, bytes: 44 }));
    }
}
