//! `lumen serve` configuration: a TOML file, overridden by command-line flags.
//!
//! ```toml
//! [iceoryx2]
//! enabled = true
//! prefix = "iox2_"          # file-name prefix in /dev/shm; clients must use the same
//!
//! [zenoh]
//! listen = ["tls/0.0.0.0:7447"]  # beyond loopback: tls/ with client_ca, or insecure = true
//! connect = []              # e.g. a router: ["tcp/10.0.0.1:7447"]
//! mode = "router"           # "router" or "peer"
//! name = "lab-server"       # this daemon's name (default: host name and pid); clients pick a daemon by it
//! # For tls/ endpoints: the daemon's certificate chain and key (PEM); clients trust its CA.
//! # tls = { certificate = "server.pem", private_key = "server.key" }
//! # Mutual TLS: client certificates must be signed by this CA (`client_ca`); then each
//! # [[zenoh.access]] names a certificate's common name and what it may do (none listed:
//! # every certificate the CA signed may do everything).
//! # tls = { certificate = "server.pem", private_key = "server.key", client_ca = "ca.pem" }
//! # [[zenoh.access]]
//! # name = "physics-a"      # certificate common name
//! # open = 2                # sessions at once (0: may not open)
//! # observe = false         # describe and the observer keys of any session
//! # status = false          # the status query
//! status = "counts"        # what status shows a client without a certificate grant: "counts" or "sessions"
//! accept_pending = 1024     # connections in zenoh's handshake at once (more are closed)
//! accept_timeout_ms = 2000  # a connection that has not finished its handshake by then is closed
//! insecure = false          # true: serve endpoints beyond loopback without client certificates
//!
//! [limits]
//! max_sessions = 16
//! max_observers = 4         # per session (iceoryx2 subscribers beyond the client, zenoh places)
//! max_contacts = 65536      # per reply; more are cut and flagged
//! max_session_mib = 512     # shared memory one session may pin
//! ```

use lumen_transport::net::is_loopback;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The whole configuration.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ServeConfig {
    pub iceoryx2: IceoryxConfig,
    pub zenoh: ZenohConfig,
    pub limits: Limits,
}

/// The shared-memory transport.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IceoryxConfig {
    pub enabled: bool,
    /// iceoryx2 `global.prefix`; `None` is iceoryx2's default (`iox2_`).
    pub prefix: Option<String>,
}

impl Default for IceoryxConfig {
    fn default() -> Self {
        Self { enabled: true, prefix: None }
    }
}

/// The network transport; off unless it listens or connects somewhere.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZenohConfig {
    /// Endpoints to listen on, e.g. `tcp/0.0.0.0:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to (a router).
    pub connect: Vec<String>,
    /// `router` (clients in client mode route through the daemon) or `peer`.
    pub mode: String,
    /// The daemon's name on the zenoh network, one key chunk (default: the host's name and the
    /// process id). Clients pick a daemon by it; two daemons on one network must differ.
    pub name: Option<String>,
    /// Certificate and key for `tls/` endpoints, and the CA of client certificates.
    pub tls: Option<TlsFiles>,
    /// With client certificates: what each certificate (by common name) may do.
    pub access: Vec<crate::access::Grant>,
    /// What `status` shows a zenoh client that no certificate grant identifies: how many sessions
    /// there are (`counts`, the default), or every session with its id and figures (`sessions`).
    /// A certificate granted `status` sees every session either way.
    pub status: StatusPolicy,
    /// Connections still in zenoh's handshake at once; more are closed as they arrive
    /// (zenoh's `transport/unicast/accept_pending`, 100 by default there).
    pub accept_pending: usize,
    /// Milliseconds a connection may take to finish zenoh's handshake before it is closed and
    /// its slot freed (`transport/unicast/accept_timeout`, 10,000 by default there).
    pub accept_timeout_ms: u64,
    /// Serve endpoints other machines can reach without client certificates anyway (`lumen
    /// serve --insecure`). Off, such a configuration is refused: see [`ServeConfig::validate`].
    pub insecure: bool,
}

/// What a zenoh client without a certificate grant learns from `status`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StatusPolicy {
    /// The number of sessions only (`StatusReport::hidden`): no ids, clients or figures.
    #[default]
    Counts,
    /// Every session, as over iceoryx2.
    Sessions,
}

/// Pending connections the daemon's zenoh accepts at once, by default: ten times zenoh's own,
/// so a hundred idle connections that never handshake leave room for real clients.
pub const ACCEPT_PENDING: usize = 1024;
/// Milliseconds a connection may take to handshake, by default: a LAN or TLS handshake takes
/// milliseconds, and an idle connection then holds its slot 2 s instead of zenoh's 10 s.
pub const ACCEPT_TIMEOUT_MS: u64 = 2000;

/// The daemon's TLS identity: PEM files of its certificate chain and private key. Clients
/// connect to `tls/HOST:PORT` trusting the CA that signed it
/// (`lumen_client::Client::zenoh_tls`); the certificate must name `HOST`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TlsFiles {
    pub certificate: std::path::PathBuf,
    pub private_key: std::path::PathBuf,
    /// CA that signs client certificates: when set, every zenoh client must present one
    /// (mutual TLS) and `[[zenoh.access]]` applies.
    #[serde(default)]
    pub client_ca: Option<std::path::PathBuf>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            listen: Vec::new(),
            connect: Vec::new(),
            mode: "router".into(),
            name: None,
            tls: None,
            access: Vec::new(),
            status: StatusPolicy::Counts,
            accept_pending: ACCEPT_PENDING,
            accept_timeout_ms: ACCEPT_TIMEOUT_MS,
            insecure: false,
        }
    }
}

impl ZenohConfig {
    /// Whether zenoh is used at all.
    pub fn enabled(&self) -> bool {
        !self.listen.is_empty() || !self.connect.is_empty()
    }

    /// The endpoints other machines can use without a client certificate: every listen or
    /// connect endpoint that is not on loopback, unless it is `tls/` with a client CA set.
    pub fn open_to_others(&self) -> Vec<&str> {
        let mutual = self.tls.as_ref().is_some_and(|t| t.client_ca.is_some());
        self.listen.iter().chain(&self.connect).map(String::as_str).filter(|e| !(is_loopback(e) || mutual && e.starts_with("tls/"))).collect()
    }
}

/// What a daemon open to other machines without client certificates gives up, said where it
/// is refused and where `--insecure` starts it anyway.
pub const INSECURE_MEANS: &str = "anyone who reaches it can open sessions up to the limit, observe a session given its id, count the sessions, and answer opens and status queries in this daemon's place (an impostor daemon feeding clients false contacts); frames and replies of a session stay tagged with its secret";

/// Bounds that keep the daemon's memory bounded whatever clients ask.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// Sessions open at once (both transports).
    pub max_sessions: usize,
    /// Observers per iceoryx2 session.
    pub max_observers: usize,
    /// Contacts per reply.
    pub max_contacts: usize,
    /// Shared memory one iceoryx2 session may pin (frames and replies, all buffers), MiB; also
    /// bounds a zenoh session's frame.
    pub max_session_mib: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self { max_sessions: 16, max_observers: 4, max_contacts: 65_536, max_session_mib: 512 }
    }
}

/// A configuration file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read {path}: {source}")]
    Read { path: String, source: std::io::Error },
    #[error("{path}: {source}")]
    Parse { path: String, source: toml::de::Error },
    #[error("{0}")]
    Invalid(String),
    #[error("[[zenoh.access]]: {0}")]
    Policy(#[from] crate::access::PolicyError),
}

impl ServeConfig {
    /// Reads a TOML file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read { path: path.display().to_string(), source })?;
        toml::from_str(&text).map_err(|source| ConfigError::Parse { path: path.display().to_string(), source })
    }

    /// Checks that something is served and the limits make sense.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.iceoryx2.enabled && !self.zenoh.enabled() {
            return Err(ConfigError::Invalid("nothing to serve: iceoryx2 is disabled and zenoh has no listen/connect endpoint (try --zenoh-listen tcp/0.0.0.0:7447)".into()));
        }
        let tls_endpoint = self.zenoh.listen.iter().any(|e| e.starts_with("tls/"));
        match &self.zenoh.tls {
            None if tls_endpoint => {
                return Err(ConfigError::Invalid("a tls/ endpoint needs the daemon's certificate and key ([zenoh] tls = { certificate, private_key }, or --zenoh-tls-cert and --zenoh-tls-key)".into()))
            }
            Some(t) => {
                let ca = t.client_ca.iter().map(|p| ("client CA", p));
                for (what, p) in [("certificate", &t.certificate), ("private key", &t.private_key)].into_iter().chain(ca) {
                    if !p.is_file() {
                        return Err(ConfigError::Invalid(format!("zenoh TLS {what} {}: no such file", p.display())));
                    }
                }
            }
            None => {}
        }
        if let (false, Some(endpoint)) = (self.zenoh.insecure, self.zenoh.open_to_others().first()) {
            return Err(ConfigError::Invalid(format!(
                "zenoh endpoint {endpoint} is reachable from other machines without client certificates: {INSECURE_MEANS}. Serve it over tls/ with client certificates ([zenoh] tls with client_ca, or --zenoh-tls-cert, --zenoh-tls-key and --zenoh-client-ca; `lumen certs` makes a lab's CA and certificates), listen on loopback only, or start with --insecure ([zenoh] insecure = true) to accept that"
            )));
        }
        if !self.zenoh.access.is_empty() && self.zenoh.tls.as_ref().is_none_or(|t| t.client_ca.is_none()) {
            return Err(ConfigError::Invalid("[[zenoh.access]] names client certificates, but the daemon asks for none: set [zenoh] tls.client_ca (or --zenoh-client-ca)".into()));
        }
        self.policy()?;
        if !matches!(self.zenoh.mode.as_str(), "router" | "peer") {
            return Err(ConfigError::Invalid(format!("zenoh mode {:?}: use \"router\" or \"peer\"", self.zenoh.mode)));
        }
        if let Some(n) = &self.zenoh.name {
            if !lumen_transport::names::is_daemon_name(n) {
                return Err(ConfigError::Invalid(format!("[zenoh] name {n:?}: a daemon's name must be one zenoh key chunk (non-empty, none of / * $ # ? = & ;)")));
            }
        }
        if self.zenoh.accept_pending == 0 || self.zenoh.accept_timeout_ms == 0 {
            return Err(ConfigError::Invalid(format!(
                "[zenoh] accept_pending = {}, accept_timeout_ms = {}: both must be > 0 (no client could connect)",
                self.zenoh.accept_pending, self.zenoh.accept_timeout_ms
            )));
        }
        let l = &self.limits;
        if l.max_sessions == 0 || l.max_contacts == 0 || l.max_session_mib == 0 || l.max_observers > 64 {
            return Err(ConfigError::Invalid(format!("limits {l:?}: sessions, contacts and MiB must be > 0, observers at most 64")));
        }
        Ok(())
    }

    /// The access policy for certified zenoh clients: `None` unless client certificates are
    /// required.
    pub fn policy(&self) -> Result<Option<crate::access::Policy>, ConfigError> {
        match self.zenoh.tls.as_ref().and_then(|t| t.client_ca.as_ref()) {
            None => Ok(None),
            Some(_) => Ok(Some(crate::access::Policy::new(self.zenoh.access.clone(), self.limits.max_sessions)?)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_with_defaults_and_typos_rejected() {
        let c: ServeConfig = toml::from_str("[zenoh]\nlisten = [\"tcp/127.0.0.1:7447\"]\n[limits]\nmax_sessions = 3\n").unwrap();
        assert!(c.iceoryx2.enabled && c.zenoh.enabled());
        assert_eq!((c.limits.max_sessions, c.limits.max_observers, c.zenoh.mode.as_str()), (3, 4, "router"));
        assert_eq!((c.zenoh.accept_pending, c.zenoh.accept_timeout_ms, c.zenoh.status), (ACCEPT_PENDING, ACCEPT_TIMEOUT_MS, StatusPolicy::Counts));
        let open: ServeConfig = toml::from_str("[zenoh]\nstatus = \"sessions\"\n").unwrap();
        assert_eq!(open.zenoh.status, StatusPolicy::Sessions);
        assert!(toml::from_str::<ServeConfig>("[zenoh]\nstatus = \"all\"\n").unwrap_err().to_string().contains("counts"));
        let closed: ServeConfig = toml::from_str("[zenoh]\nlisten = [\"tcp/127.0.0.1:7447\"]\naccept_pending = 0\n").unwrap();
        assert!(closed.validate().unwrap_err().to_string().contains("accept_pending = 0"));
        assert!(toml::from_str::<ServeConfig>("[limits]\nmax_sesions = 3\n").unwrap_err().to_string().contains("max_sesions"));
        let off = ServeConfig { iceoryx2: IceoryxConfig { enabled: false, prefix: None }, ..Default::default() };
        assert!(off.validate().unwrap_err().to_string().contains("nothing to serve"));
    }

    #[test]
    fn loopback_endpoints_are_told_from_the_rest() {
        for e in ["tcp/127.0.0.1:7447", "tcp/127.8.0.1:1", "tls/localhost:7447", "tcp/[::1]:7447", "tcp/127.0.0.1:7447#iface=lo", "udp/LOCALHOST:9"] {
            assert!(is_loopback(e), "{e}");
        }
        for e in ["tcp/0.0.0.0:7447", "tcp/10.0.0.5:7447", "tls/lab-server:7447", "tcp/[::]:7447", "tcp/192.168.1.2:7447", "tcp/localhost.example.org:1"] {
            assert!(!is_loopback(e), "{e}");
        }
    }

    #[test]
    fn beyond_loopback_without_client_certificates_is_refused_unless_insecure() {
        let zenoh = |listen: &str, connect: &[&str], tls: Option<TlsFiles>, insecure: bool| ServeConfig {
            zenoh: ZenohConfig { listen: vec![listen.into()], connect: connect.iter().map(|s| s.to_string()).collect(), tls, insecure, ..Default::default() },
            ..Default::default()
        };
        let e = zenoh("tcp/0.0.0.0:7447", &[], None, false).validate().unwrap_err().to_string();
        assert!(e.starts_with("zenoh endpoint tcp/0.0.0.0:7447 is reachable from other machines without client certificates: anyone who reaches it can open sessions"), "{e}");
        assert!(e.contains("--insecure") && e.contains("lumen certs"), "{e}");
        assert!(zenoh("tcp/0.0.0.0:7447", &[], None, true).validate().is_ok());
        assert!(zenoh("tcp/127.0.0.1:7447", &[], None, false).validate().is_ok());
        // A router beyond loopback counts as well.
        assert!(zenoh("tcp/127.0.0.1:7447", &["tcp/10.0.0.1:7447"], None, false).validate().unwrap_err().to_string().contains("tcp/10.0.0.1:7447"));
        // tls/ with a client CA is what it asks for (files that exist: this source file).
        let here = std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/src/config.rs"));
        let files = |ca: bool| Some(TlsFiles { certificate: here.clone(), private_key: here.clone(), client_ca: ca.then(|| here.clone()) });
        assert!(zenoh("tls/0.0.0.0:7447", &[], files(true), false).validate().is_ok());
        assert!(zenoh("tls/0.0.0.0:7447", &[], files(false), false).validate().unwrap_err().to_string().contains("tls/0.0.0.0:7447"));
        assert!(zenoh("tls/0.0.0.0:7447", &[], files(true), false).zenoh.open_to_others().is_empty());
    }
}
