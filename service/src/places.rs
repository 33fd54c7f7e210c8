//! A zenoh session's observer places: each held by a random token, counted against
//! `limits.max_observers`, lapsing after [`OBSERVER_IDLE`] without an ask.

use lumen_proto::auth::Token;
use lumen_transport::net::OBSERVER_IDLE;
use std::sync::Mutex;
use std::time::Instant;

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

impl Place {
    /// Whether it has not lapsed at `now`.
    fn live(&self, now: Instant) -> bool {
        now.duration_since(self.last) < OBSERVER_IDLE
    }
}

impl Places {
    /// Takes a place for `token` unless `max` are held by observers that asked within
    /// [`OBSERVER_IDLE`] (lapsed places are freed first); returns whether it did.
    pub fn take(&self, token: Token, max: usize, now: Instant) -> bool {
        let mut held = self.held.lock().expect("places lock");
        held.retain(|p| p.live(now));
        if held.len() >= max {
            return false;
        }
        held.push(Place { token, last: now });
        true
    }

    /// Whether `token` holds a place that has not lapsed; if so its idle time starts again.
    pub fn touch(&self, token: &Token, now: Instant) -> bool {
        let mut held = self.held.lock().expect("places lock");
        match held.iter_mut().find(|p| p.token == *token && p.live(now)) {
            Some(p) => {
                p.last = now;
                true
            }
            None => false,
        }
    }

    /// Whether `token` holds a place that has not lapsed.
    pub fn holds(&self, token: &Token, now: Instant) -> bool {
        self.held.lock().expect("places lock").iter().any(|p| p.token == *token && p.live(now))
    }

    /// Whether any place is live: someone may ask for the next frame.
    pub fn any(&self, now: Instant) -> bool {
        self.held.lock().expect("places lock").iter().any(|p| p.live(now))
    }

    /// Frees `token`'s place.
    pub fn give_back(&self, token: &Token) {
        self.held.lock().expect("places lock").retain(|p| p.token != *token);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn places_are_counted_lapse_and_come_back() {
        let places = Places::default();
        let t = |b: u8| Token::from_bytes([b; 16]);
        let t0 = Instant::now();
        assert!(places.take(t(1), 2, t0) && places.take(t(2), 2, t0));
        assert!(!places.take(t(3), 2, t0), "a third place beyond max 2");
        assert!(places.holds(&t(1), t0) && places.holds(&t(2), t0));
        // Asking keeps a place; one that stops asking lapses and frees room.
        let later = t0 + OBSERVER_IDLE - Duration::from_millis(1);
        assert!(places.touch(&t(1), later));
        let lapsed = t0 + OBSERVER_IDLE;
        assert!(!places.touch(&t(2), lapsed), "place 2 lapsed");
        assert!(places.touch(&t(1), lapsed));
        assert!(places.take(t(3), 2, lapsed));
        assert!(!places.touch(&t(9), lapsed), "a token never given");
        assert!(places.holds(&t(3), lapsed) && !places.holds(&t(2), lapsed));
        places.give_back(&t(1));
        assert!(places.holds(&t(3), lapsed) && !places.holds(&t(1), lapsed) && !places.holds(&t(2), lapsed));
        assert!(!places.touch(&t(1), lapsed));
    }
}
