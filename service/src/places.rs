//! A zenoh session's observer places: each held by a random token, counted against
//! `limits.max_observers`, lapsing after [`OBSERVER_IDLE`] without an ask.

use lumen_transport::net::OBSERVER_IDLE;
use std::sync::Mutex;
use std::time::Instant;

/// Bytes of an observer's token (32 hex digits in an ask).
pub const TOKEN_BYTES: usize = 16;
/// An observer's token: 128 random bits, given by the `observing` reply.
pub type Token = [u8; TOKEN_BYTES];

/// The observer places of one session.
#[derive(Debug, Default)]
pub struct Places {
    held: Mutex<Vec<Place>>,
}

#[derive(Debug)]
struct Place {
    token: Token,
    /// When it last asked (or was taken).
    last: Instant,
}

impl Places {
    /// Takes a place for `token` unless `max` are held by observers that asked within
    /// [`OBSERVER_IDLE`] (lapsed places are freed first); returns whether it did.
    pub fn take(&self, token: Token, max: usize, now: Instant) -> bool {
        let mut held = self.held.lock().expect("places lock");
        held.retain(|p| now.duration_since(p.last) < OBSERVER_IDLE);
        if held.len() >= max {
            return false;
        }
        held.push(Place { token, last: now });
        true
    }

    /// Whether `token` holds a place that has not lapsed; if so its idle time starts again.
    pub fn touch(&self, token: &Token, now: Instant) -> bool {
        let mut held = self.held.lock().expect("places lock");
        match held.iter_mut().find(|p| p.token == *token && now.duration_since(p.last) < OBSERVER_IDLE) {
            Some(p) => {
                p.last = now;
                true
            }
            None => false,
        }
    }

    /// Whether `token` holds a place that has not lapsed.
    pub fn holds(&self, token: &Token, now: Instant) -> bool {
        self.held.lock().expect("places lock").iter().any(|p| p.token == *token && now.duration_since(p.last) < OBSERVER_IDLE)
    }

    /// Frees `token`'s place.
    pub fn give_back(&self, token: &Token) {
        self.held.lock().expect("places lock").retain(|p| p.token != *token);
    }

    /// Places held by observers that asked within [`OBSERVER_IDLE`].
    pub fn held(&self, now: Instant) -> usize {
        self.held.lock().expect("places lock").iter().filter(|p| now.duration_since(p.last) < OBSERVER_IDLE).count()
    }
}

/// Parses 32 hex digits.
pub fn parse_token(hex: &str) -> Option<Token> {
    if hex.len() != 2 * TOKEN_BYTES || !hex.is_ascii() {
        return None;
    }
    let mut t = [0u8; TOKEN_BYTES];
    for (i, b) in t.iter_mut().enumerate() {
        *b = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(t)
}

/// 32 lowercase hex digits of `token`.
pub fn token_hex(token: &Token) -> String {
    token.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn places_are_counted_lapse_and_come_back() {
        let places = Places::default();
        let t0 = Instant::now();
        assert!(places.take([1; 16], 2, t0) && places.take([2; 16], 2, t0));
        assert!(!places.take([3; 16], 2, t0), "a third place beyond max 2");
        assert_eq!(places.held(t0), 2);
        // Asking keeps a place; one that stops asking lapses and frees room.
        let later = t0 + OBSERVER_IDLE - Duration::from_millis(1);
        assert!(places.touch(&[1; 16], later));
        let lapsed = t0 + OBSERVER_IDLE;
        assert!(!places.touch(&[2; 16], lapsed), "place 2 lapsed");
        assert!(places.touch(&[1; 16], lapsed));
        assert!(places.take([3; 16], 2, lapsed));
        assert!(!places.touch(&[9; 16], lapsed), "a token never given");
        assert!(places.holds(&[3; 16], lapsed) && !places.holds(&[2; 16], lapsed));
        places.give_back(&[1; 16]);
        assert_eq!(places.held(lapsed), 1);
        assert!(!places.touch(&[1; 16], lapsed));
    }

    #[test]
    fn tokens_are_32_hex_digits() {
        let t: Token = std::array::from_fn(|i| (i * 17) as u8);
        let hex = token_hex(&t);
        assert_eq!(hex, "00112233445566778899aabbccddeeff");
        assert_eq!(parse_token(&hex), Some(t));
        assert_eq!(parse_token(&hex.to_uppercase()), Some(t));
        for bad in ["", "0011", &format!("{hex}00"), "0g112233445566778899aabbccddeeff", "ééé112233445566778899aabbccddee"] {
            assert_eq!(parse_token(bad), None, "{bad}");
        }
    }
}
