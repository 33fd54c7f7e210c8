//! The daemon's one error type.

use crate::config::ConfigError;
use lumen_transport::TransportError;

/// Why the daemon, one of its transports or one of its sessions could not run.
#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    /// The configuration is not usable.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// iceoryx2 or zenoh failed.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// A thread could not be started.
    #[error("starting the {thread} thread: {source}")]
    Spawn { thread: String, source: std::io::Error },
    /// Another daemon of the same name already serves on the zenoh network.
    #[error("a daemon named {0:?} already serves on this zenoh network: give this one another name ([zenoh] name, or --zenoh-name)")]
    NameTaken(String),
    /// Another daemon already serves the control service of this iceoryx2 prefix.
    #[error("another Lumen daemon already serves iceoryx2 prefix {0:?} on this machine: stop it, or start this one with another --prefix (clients then need the same, LUMEN_IOX2_PREFIX)")]
    PrefixTaken(String),
    /// A thread stopped before it reported that it serves.
    #[error("the {0} thread stopped before it served")]
    Stopped(String),
}
