//! Names of the control channel and of each session's channels: iceoryx2 service names and
//! zenoh key expressions alike (`proto/README.md` documents them for other languages).

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

/// Zenoh liveliness token the daemon holds while it runs.
pub const DAEMON_ALIVE: &str = "lumen/daemon";

/// Name of session `id`'s frame channel (iceoryx2 publish-subscribe + event service of the same
/// name, or zenoh key).
pub fn frame_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/frame")
}

/// Name of session `id`'s contacts channel (iceoryx2 publish-subscribe + event, or zenoh key).
pub fn contacts_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/contacts")
}

/// Zenoh liveliness key the client of session `id` must hold while it lives.
pub fn client_alive_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/client")
}

/// Zenoh key on which the daemon repeats session `id`'s frames for observers, droppable: an
/// observer that cannot keep up loses samples rather than slowing the session.
pub fn observe_frame_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/observe/frame")
}

/// Zenoh key on which the daemon repeats session `id`'s replies for observers, droppable.
pub fn observe_contacts_name(id: u64) -> String {
    format!("{ROOT}/session/{id}/observe/contacts")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_documented_strings() {
        assert_eq!(frame_name(42), "lumen/session/42/frame");
        assert_eq!(contacts_name(42), "lumen/session/42/contacts");
        assert_eq!(client_alive_name(42), "lumen/session/42/client");
        assert_eq!(observe_frame_name(42), "lumen/session/42/observe/frame");
        assert_eq!(observe_contacts_name(42), "lumen/session/42/observe/contacts");
        assert_eq!((CONTROL, DAEMON_ALIVE), ("lumen/control", "lumen/daemon"));
        assert_eq!(control_name_for("physics-a"), "lumen/control/physics-a");
        assert!(is_key_chunk("physics-a.lab") && !is_key_chunk("a/b") && !is_key_chunk("") && !is_key_chunk("a*"));
    }
}
