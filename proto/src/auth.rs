//! Session ownership: the secret an `opened` reply gives its client alone, and the tags that
//! prove a message comes from one who knows it.
//!
//! A tag is BLAKE3's keyed hash (its MAC mode) keyed with the secret's 32 bytes. Over zenoh
//! every frame the client sends and every contacts reply the daemon sends carries the tag of its
//! bytes as the sample's attachment ([`TAG_BYTES`] bytes), and a close carries the tag of
//! [`close_message`] in hex. BLAKE3 rather than HMAC-SHA256 because a colon-sized frame is
//! 485 KiB and is tagged by the client and checked by the daemon: `docs/measurements.md` has the
//! measured cost of both.

use subtle::ConstantTimeEq;

/// Bytes of a session secret (256 bits: BLAKE3's key).
pub const SECRET_BYTES: usize = blake3::KEY_LEN;
/// Bytes of a tag (BLAKE3's default output).
pub const TAG_BYTES: usize = blake3::OUT_LEN;

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
        let bad = || BadSecret { got: hex.chars().take(2 * SECRET_BYTES + 8).collect() };
        if hex.len() != 2 * SECRET_BYTES {
            return Err(bad());
        }
        let mut bytes = [0u8; SECRET_BYTES];
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = u8::from_str_radix(hex.get(2 * i..2 * i + 2).ok_or_else(bad)?, 16).map_err(|_| bad())?;
        }
        Ok(Self::from_bytes(bytes))
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

/// The message a close's proof tags: `lumen close <session>` (the id in decimal).
pub fn close_message(session: u64) -> String {
    format!("lumen close {session}")
}

/// The message whose tag names a zenoh session's liveliness key: `lumen alive <session>`.
pub fn alive_message(session: u64) -> String {
    format!("lumen alive {session}")
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
