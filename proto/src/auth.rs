//! Session ownership: the secret an `opened` reply gives its client alone, and the tags that
//! prove a message comes from one who knows it.
//!
//! A tag is BLAKE3's keyed hash (its MAC mode) keyed with the secret's 32 bytes. Over zenoh
//! every frame the client sends and every contacts reply the daemon sends carries, as the
//! sample's attachment ([`TAG_BYTES`] bytes), the tag of its header and length
//! ([`Secret::message_tag`]), and a [`Gate`] admits each frame number once, in increasing
//! order. A close carries the tag of [`close_message`] in hex.
//!
//! The floats are not hashed: a tag then costs the same at any frame size (a colon-sized frame
//! is 485 KiB, and hashing it took 63 us each way, `docs/measurements.md`), and a copy of a
//! genuine header and tag with other floats is refused by the gate, because the genuine message
//! used that frame number first. What this leaves open is in `service/README.md`.

use subtle::ConstantTimeEq;

/// Bytes of a session secret (256 bits: BLAKE3's key).
pub const SECRET_BYTES: usize = blake3::KEY_LEN;
/// Bytes of a tag (BLAKE3's default output).
pub const TAG_BYTES: usize = blake3::OUT_LEN;
/// Where a frame's (and a reply's) frame number sits in its header: a little-endian `u64`.
pub const FRAME_NUMBER_AT: usize = 16;

/// A session's secret, known to the daemon and the client that opened the session.
#[derive(Clone)]
pub struct Secret {
    bytes: [u8; SECRET_BYTES],
}

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Secret(..)") // never printed: a log line must not hand out ownership
    }
}

impl PartialEq for Secret {
    fn eq(&self, other: &Self) -> bool {
        bool::from(self.bytes.ct_eq(&other.bytes))
    }
}

/// Why a secret's text was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a session secret is {} lowercase hex digits; got {got:?}", 2 * SECRET_BYTES)]
pub struct BadSecret {
    pub got: String,
}

impl Secret {
    /// The secret of these bytes (the daemon draws them from the OS).
    pub fn from_bytes(bytes: [u8; SECRET_BYTES]) -> Self {
        Self { bytes }
    }

    /// Parses the 64 hex digits of an `opened` reply's `secret`.
    pub fn parse(hex: &str) -> Result<Self, BadSecret> {
        from_hex(hex).map(Self::from_bytes).ok_or_else(|| BadSecret { got: hex.chars().take(2 * SECRET_BYTES + 8).collect() })
    }

    /// The 64 lowercase hex digits sent in the `opened` reply.
    pub fn to_hex(&self) -> String {
        hex(&self.bytes)
    }

    /// The tag of a message given in `parts` (in order; zenoh hands payloads over in fragments).
    pub fn tag<'a>(&self, parts: impl IntoIterator<Item = &'a [u8]>) -> [u8; TAG_BYTES] {
        let mut hasher = blake3::Hasher::new_keyed(&self.bytes);
        for p in parts {
            hasher.update(p);
        }
        *hasher.finalize().as_bytes()
    }

    /// Whether `tag` is the tag of `parts` (in constant time).
    pub fn verify<'a>(&self, parts: impl IntoIterator<Item = &'a [u8]>, tag: &[u8]) -> bool {
        bool::from(self.tag(parts).as_slice().ct_eq(tag))
    }

    /// The tag of a message of `len` bytes over zenoh whose header is `head` (its first bytes:
    /// 40 for a frame, 256 for a reply): the tag of `head` followed by `len` as a little-endian
    /// `u64`. Binding the length means a copy with fewer or more floats is refused too.
    pub fn message_tag(&self, head: &[u8], len: usize) -> [u8; TAG_BYTES] {
        self.tag([head, &(len as u64).to_le_bytes()])
    }

    /// The `proof` of a close of `session`: the hex tag of [`close_message`].
    pub fn close_proof(&self, session: u64) -> String {
        hex(&self.tag([close_message(session).as_bytes()]))
    }

    /// The last chunk of session `session`'s client liveliness key over zenoh: the first 16
    /// bytes of the tag of [`alive_message`] as 32 lowercase hex digits. Only the opener can
    /// name the key, so no one else can hold a token that keeps a dead client's session alive.
    pub fn alive_chunk(&self, session: u64) -> String {
        hex(&self.tag([alive_message(session).as_bytes()])[..16])
    }

    /// Whether `proof` is [`Secret::close_proof`] of `session`.
    pub fn verify_close(&self, session: u64, proof: &str) -> bool {
        let expected = self.close_proof(session);
        bool::from(expected.as_bytes().ct_eq(proof.as_bytes()))
    }
}

/// One direction of one zenoh session (frames into the daemon, or replies into the client):
/// admits a message only if its attachment is [`Secret::message_tag`] of its header and length
/// and its frame number is greater than every one admitted before. Each genuine message is
/// then admitted once, and no one who saw it (anyone may subscribe to a session's keys) can use
/// its tag again with other contents.
#[derive(Debug)]
pub struct Gate {
    secret: Secret,
    head: usize,
    last: Option<u64>,
}

impl Gate {
    /// A gate for messages whose header is `head` bytes (at least `FRAME_NUMBER_AT + 8`).
    pub fn new(secret: Secret, head: usize) -> Self {
        assert!(head >= FRAME_NUMBER_AT + 8, "a header holds the frame number");
        Self { secret, head, last: None }
    }

    /// The header's length in bytes.
    pub fn head(&self) -> usize {
        self.head
    }

    /// Whether to admit a message of `len` bytes starting with `head` (its first
    /// [`Gate::head`] bytes: fewer means too short to carry a proof) and carrying `tag`.
    pub fn admit(&mut self, head: &[u8], len: usize, tag: &[u8]) -> bool {
        if head.len() != self.head || len < self.head {
            return false;
        }
        let frame = u64::from_le_bytes(head[FRAME_NUMBER_AT..FRAME_NUMBER_AT + 8].try_into().expect("8 bytes"));
        if self.last.is_some_and(|last| frame <= last) {
            return false; // a copy, or an older message: its number was used
        }
        if !bool::from(self.secret.message_tag(head, len).as_slice().ct_eq(tag)) {
            return false;
        }
        // A number beyond the frames' range is admitted (it is its owner's, and is answered
        // with an error) but never raised to: it would lock every later frame out.
        if frame <= crate::wire::MAX_FRAME_NUMBER {
            self.last = Some(frame);
        }
        true
    }
}

/// The message a close's proof tags: `lumen close <session>` (the id in decimal).
pub fn close_message(session: u64) -> String {
    format!("lumen close {session}")
}

/// The message whose tag names a zenoh session's liveliness key: `lumen alive <session>`.
pub fn alive_message(session: u64) -> String {
    format!("lumen alive {session}")
}

/// Bytes of a zenoh observer's token (`proto/README.md`, section 4).
pub const TOKEN_BYTES: usize = 16;

/// A zenoh observer place's token: 128 random bits the `observing` reply gives, which every ask
/// carries in hex; compared in constant time, as the secret is.
#[derive(Clone, Copy)]
pub struct Token {
    bytes: [u8; TOKEN_BYTES],
}

impl std::fmt::Debug for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Token(..)") // never printed: it is the place
    }
}

impl PartialEq for Token {
    fn eq(&self, other: &Self) -> bool {
        bool::from(self.bytes.ct_eq(&other.bytes))
    }
}

impl Token {
    /// The token of these bytes (the daemon draws them from the OS).
    pub fn from_bytes(bytes: [u8; TOKEN_BYTES]) -> Self {
        Self { bytes }
    }

    /// Parses the 32 hex digits of an ask's `observer` parameter (`None` if they are not).
    pub fn parse(hex: &str) -> Option<Self> {
        from_hex(hex).map(Self::from_bytes)
    }

    /// The 32 lowercase hex digits sent in the `observing` reply.
    pub fn to_hex(&self) -> String {
        hex(&self.bytes)
    }
}

/// `bytes` as lowercase hex digits, two a byte (secrets, proofs, tokens, liveliness chunks).
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// `N` bytes from `2 N` hex digits (either case); `None` for another length or a non-digit.
fn from_hex<const N: usize>(hex: &str) -> Option<[u8; N]> {
    if hex.len() != 2 * N {
        return None;
    }
    let mut bytes = [0u8; N];
    for (i, b) in bytes.iter_mut().enumerate() {
        *b = u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_32_hex_digits() {
        let t = Token::from_bytes(std::array::from_fn(|i| (i * 17) as u8));
        let hex = t.to_hex();
        assert_eq!(hex, "00112233445566778899aabbccddeeff");
        assert_eq!(Token::parse(&hex), Some(t));
        assert_eq!(Token::parse(&hex.to_uppercase()), Some(t));
        assert_ne!(Token::parse("00112233445566778899aabbccddeefe"), Some(t));
        for bad in ["", "0011", &format!("{hex}00"), "0g112233445566778899aabbccddeeff", "ééé112233445566778899aabbccddee"] {
            assert_eq!(Token::parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn tags_are_blake3_keyed_hashes_as_its_test_vectors_give_them() {
        // BLAKE3's own test vectors (test_vectors/test_vectors.json of BLAKE3-team/BLAKE3):
        // key "whats the Elvish word for friend", inputs of the bytes 0, 1, ..., 250, 0, ...
        let s = Secret::from_bytes(*b"whats the Elvish word for friend");
        let input = |n: usize| (0..n).map(|i| (i % 251) as u8).collect::<Vec<u8>>();
        assert_eq!(hex(&s.tag([input(1).as_slice()])), "6d7878dfff2f485635d39013278ae14f1454b8c0a3a2d34bc1ab38228a80c95b");
        let long = input(1023);
        assert_eq!(hex(&s.tag([&long[..100], &long[100..]])), "c951ecdf03288d0fcc96ee3413563d8a6d3589547f2c2fb36d9786470f1b9d6e");
        // And as Python's `blake3` package (a foreign client) computes a close's proof:
        // blake3.blake3(b"lumen close 42", key=bytes(range(32))).hexdigest()
        let s = Secret::from_bytes(std::array::from_fn(|i| i as u8));
        assert_eq!(s.to_hex(), "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f");
        assert_eq!(s.close_proof(42), "d068aba186ad2d7c468a930a7751b1137b68f842939bfb30dab2135c24835a74");
        // blake3.blake3(b"lumen alive 42", key=bytes(range(32))).hexdigest()[:32]
        assert_eq!(s.alive_chunk(42), "732caea5f9833e0b2c42100effe25326");
    }

    #[test]
    fn a_gate_admits_each_owners_frame_number_once_and_in_order() {
        let (s, t) = (Secret::from_bytes([1; 32]), Secret::from_bytes([2; 32]));
        let head = |frame: u64| {
            let mut h = [0xa5u8; 40];
            h[FRAME_NUMBER_AT..FRAME_NUMBER_AT + 8].copy_from_slice(&frame.to_le_bytes());
            h
        };
        let mut gate = Gate::new(s.clone(), 40);
        let tag = |h: &[u8], len| s.message_tag(h, len);
        assert!(gate.admit(&head(5), 100, &tag(&head(5), 100)));
        // The same header and tag again (a copy with other floats after it): refused.
        assert!(!gate.admit(&head(5), 100, &tag(&head(5), 100)));
        assert!(!gate.admit(&head(4), 100, &tag(&head(4), 100)), "an older number");
        assert!(!gate.admit(&head(6), 101, &tag(&head(6), 100)), "another length");
        assert!(!gate.admit(&head(6), 100, &t.message_tag(&head(6), 100)), "another secret");
        let mut flipped = head(6);
        flipped[0] ^= 1;
        assert!(!gate.admit(&flipped, 100, &tag(&head(6), 100)), "a header byte flipped");
        assert!(!gate.admit(&head(6)[..39], 100, &tag(&head(6)[..39], 100)), "too short for a header");
        assert!(!gate.admit(&head(6), 39, &tag(&head(6), 39)), "a message shorter than its header");
        assert!(!gate.admit(&head(6), 100, &tag(&head(6), 100)[..31]), "a short tag");
        // Refusals leave the gate as it was; numbers may jump.
        assert!(gate.admit(&head(6), 100, &tag(&head(6), 100)));
        // A number beyond MAX_FRAME_NUMBER is its owner's (admitted, to be answered with an
        // error) but locks nothing out; one within the range does.
        assert!(gate.admit(&head(u64::MAX), 100, &tag(&head(u64::MAX), 100)));
        assert!(gate.admit(&head(7), 100, &tag(&head(7), 100)));
        assert!(gate.admit(&head(1 << 52), 100, &tag(&head(1 << 52), 100)));
        assert!(!gate.admit(&head(8), 100, &tag(&head(8), 100)));
        // The tag is the keyed hash of the header then the length, as Python's `blake3` (a
        // foreign client) computes it:
        // blake3.blake3(bytes(40) + (64).to_bytes(8, "little"), key=bytes(range(32))).hexdigest()
        let k = Secret::from_bytes(std::array::from_fn(|i| i as u8));
        assert_eq!(hex(&k.message_tag(&[0; 40], 64)), "6da8c366de710a5421d79e06b599593a4a801fd5995525895f1b4cba57c36b18");
    }

    #[test]
    fn secrets_parse_their_own_hex_and_nothing_else() {
        let s = Secret::from_bytes([0xab; 32]);
        assert_eq!(Secret::parse(&s.to_hex()).unwrap(), s);
        for bad in ["", "ab", &"g".repeat(64), &"a".repeat(63), &"a".repeat(65), &"a".repeat(32), &"é".repeat(32)] {
            assert!(Secret::parse(bad).is_err(), "{bad:?}");
        }
        assert_eq!(format!("{s:?}"), "Secret(..)");
    }

    #[test]
    fn a_tag_covers_every_byte_and_only_its_secret_makes_it() {
        let (s, t) = (Secret::from_bytes([1; 32]), Secret::from_bytes([2; 32]));
        let msg: &[u8] = b"a frame's bytes";
        let tag = s.tag([msg]);
        assert!(s.verify([msg], &tag));
        assert!(s.verify([&msg[..5], &msg[5..]], &tag), "parts are one message");
        assert!(!t.verify([msg], &tag), "another secret");
        assert!(!s.verify([&msg[..msg.len() - 1]], &tag), "a byte less");
        let mut flipped = msg.to_vec();
        flipped[3] ^= 1;
        assert!(!s.verify([&flipped[..]], &tag), "a bit flipped");
        assert!(!s.verify([msg], &tag[..31]), "a short tag");
        assert!(s.verify_close(7, &s.close_proof(7)) && !s.verify_close(8, &s.close_proof(7)) && !t.verify_close(7, &s.close_proof(7)));
        assert!(!s.verify_close(7, ""));
    }
}
