//! Names of the control channel and of each session's channels: iceoryx2 service names and
//! zenoh key expressions alike (`proto/README.md` documents them for other languages).

use lumen_proto::auth::Secret;

/// Root of every service name and key expression.
pub const ROOT: &str = "lumen";
/// The control channel: iceoryx2 request-response service name and zenoh key expression.
pub const CONTROL: &str = "lumen/control";
/// The control key of a zenoh client whose certificate's common name is `name`, when the
/// daemon requires client certificates: zenoh's access control lets only that certificate
/// query it, so the key tells the daemon who asks.
pub fn control_name_for(name: &str) -> String {
    format!("{CONTROL}/{name}")
}

/// Whether `s` can stand as one chunk of a zenoh key expression: non-empty, and none of
/// `/ * $ # ?` (separators, wildcards, the DSL, selector parameters).
pub fn is_key_chunk(s: &str) -> bool {
    !s.is_empty() && !s.contains(['/', '*', '$', '#', '?'])
}

/// Whether `s` can be a daemon's name: one key chunk ([`is_key_chunk`]) without the selector's
/// `= & ;`, since a name travels as the selector parameter [`DAEMON_PARAMETER`].
pub fn is_daemon_name(s: &str) -> bool {
    is_key_chunk(s) && !s.contains(['=', '&', ';'])
}

/// Zenoh liveliness token daemon `name` holds while it runs (`lumen/daemon/<name>`); a client
/// watches its session's daemon's (the session info's `daemon`).
pub fn daemon_alive_name(name: &str) -> String {
    format!("{ROOT}/daemon/{name}")
}

/// The key of every daemon's liveliness token.
pub const DAEMONS_ALIVE: &str = "lumen/daemon/*";

/// The selector parameter of a zenoh control request that names the daemon it is for
/// (`lumen/control?daemon=<name>`): the others drop it unanswered.
pub const DAEMON_PARAMETER: &str = "daemon";

/// Name of session `id`'s frame channel (iceoryx2 publish-subscribe + event service of the same
/// name, or zenoh key).
pub fn frame_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/frame")
}

/// Name of session `id`'s contacts channel (iceoryx2 publish-subscribe + event, or zenoh key).
pub fn contacts_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/contacts")
}

/// Zenoh liveliness key the client of session `id` must hold while it lives:
/// `lumen/session/<id>/client/<chunk>`, the last chunk the one its open request gave
/// (`alive`, random, [`lumen_proto::session::is_alive_chunk`]) or else derived from the
/// session's secret ([`Secret::alive_chunk`]): either way only its owner can name it.
pub fn client_alive_name(id: u64, chunk: &str, secret: &Secret) -> String {
    if chunk.is_empty() {
        format!("{ROOT}/session/{id}/client/{}", secret.alive_chunk(id))
    } else {
        format!("{ROOT}/session/{id}/client/{chunk}")
    }
}

/// Zenoh liveliness key the daemon holds while session `id` is open: observers watch it to
/// learn that the session ended.
pub fn session_live_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/live")
}

/// Zenoh key a registered observer of session `id` asks (a query) for the session's newest
/// frame and its reply: nothing is published for observers, so each gets what it asks for.
pub fn observe_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/observe")
}

/// Selector parameter of an ask: the observer's token from the `observing` reply.
pub const OBSERVER_PARAMETER: &str = "observer";
/// Selector parameter of an ask: the newest frame number the observer has (the answer is a
/// newer frame); absent, any frame will do.
pub const AFTER_PARAMETER: &str = "after";
/// Selector parameter of an ask that gives the observer's place back (no answer).
pub const END_PARAMETER: &str = "end";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_documented_strings() {
        assert_eq!(frame_name(42), "lumen/session/42/frame");
        assert_eq!(contacts_name(42), "lumen/session/42/contacts");
        let secret = Secret::from_bytes(std::array::from_fn(|i| i as u8));
        assert_eq!(client_alive_name(42, "", &secret), "lumen/session/42/client/732caea5f9833e0b2c42100effe25326");
        assert_eq!(client_alive_name(42, "0123456789abcdef0123456789abcdef", &secret), "lumen/session/42/client/0123456789abcdef0123456789abcdef");
        assert_eq!(session_live_name(42), "lumen/session/42/live");
        assert_eq!(observe_name(42), "lumen/session/42/observe");
        assert_eq!((OBSERVER_PARAMETER, AFTER_PARAMETER, END_PARAMETER), ("observer", "after", "end"));
        assert_eq!((CONTROL, daemon_alive_name("lab-1").as_str(), DAEMONS_ALIVE), ("lumen/control", "lumen/daemon/lab-1", "lumen/daemon/*"));
        assert_eq!(control_name_for("physics-a"), "lumen/control/physics-a");
        assert!(is_key_chunk("physics-a.lab") && !is_key_chunk("a/b") && !is_key_chunk("") && !is_key_chunk("a*"));
        assert!(is_daemon_name("gpu-1.lab") && !is_daemon_name("a=b") && !is_daemon_name("a&b") && !is_daemon_name("a;b") && !is_daemon_name("a/b"));
    }
}
