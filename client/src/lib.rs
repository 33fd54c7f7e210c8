//! Client of the Lumen daemon (`lumen serve`): open a session for a scene, write each frame in
//! place, submit it, read the contacts.
//!
//! ```no_run
//! use lumen_client::Client;
//! # fn spec() -> lumen_proto::SceneSpec { unimplemented!() }
//! let client = Client::local()?;                 // or Client::zenoh("tcp/10.0.0.5:7447")?
//! let mut session = client.open_session(&spec())?;
//! loop {
//!     let state = session.frame()?;              // the shared-memory frame itself (iceoryx2)
//!     state.fill(0.0);                           // write every float, in the spec's layout
//!     session.submit()?;
//!     let reply = session.contacts(std::time::Duration::from_millis(100))?;
//!     for c in reply.contacts() { let _ = c.depth; }
//! }
//! # Ok::<(), lumen_client::Error>(())
//! ```
//!
//! - [`Client`]: a connection to the daemon, on this machine ([`Client::local`], iceoryx2 shared
//!   memory) or over the network ([`Client::zenoh`]).
//! - [`Session`]: one scene; frames in, contacts out. If the daemon dies and comes back, the
//!   session reopens by itself on the next [`Session::frame`] / [`Session::submit`].
//! - [`Observer`]: watches another session's frames and contacts without slowing it.
//!
//! iceoryx2 ports belong to the thread that made them: a local [`Client`], its sessions and
//! observers are not `Send` (make one client per thread). Zenoh ones are.

mod clock;
mod control;
mod deltas;
mod error;
pub mod local;
mod observer;
pub mod remote;
mod session;
mod view;

pub use clock::now_ns;
pub use deltas::FrameCounts;
pub use error::Error;
pub use lumen_proto as proto;
pub use lumen_proto::session::{DaemonInfo, SessionInfo, StatusReport, Transport};
pub use observer::{Observed, Observer};
pub use session::Session;
pub use view::ContactsView;

use lumen_proto::session::{ControlReply, ControlRequest};
use lumen_proto::wire::PROTOCOL_VERSION;
use lumen_proto::SceneSpec;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How long control requests (open, describe, status) wait for the daemon.
pub const CONTROL_TIMEOUT: Duration = Duration::from_secs(3);

/// A connection to the daemon.
pub struct Client {
    inner: Inner,
    name: String,
}

enum Inner {
    Local(local::LocalClient),
    Zenoh(remote::ZenohClient),
}

/// A zenoh client's TLS material, as PEM files.
#[derive(Debug, Clone)]
pub struct Tls {
    /// The certificate authority that signed the daemon's certificate.
    pub root_ca: PathBuf,
    /// This client's certificate and private key, for a daemon that requires client
    /// certificates (mutual TLS); `None` otherwise.
    pub identity: Option<(PathBuf, PathBuf)>,
}

/// The subject common name of the first certificate in the PEM file `certificate`: the name a
/// daemon requiring client certificates knows this client by, and its control key's last chunk.
fn common_name(certificate: &Path) -> Result<String, Error> {
    let bad = |why: String| Error::NoDaemon { transport: Transport::Zenoh, detail: format!("client certificate {}: {why}", certificate.display()) };
    let bytes = std::fs::read(certificate).map_err(|e| bad(e.to_string()))?;
    let (_, pem) = x509_parser::pem::parse_x509_pem(&bytes).map_err(|e| bad(format!("not a PEM certificate: {e}")))?;
    let cert = pem.parse_x509().map_err(|e| bad(format!("not an X.509 certificate: {e}")))?;
    let name = cert.subject().iter_common_name().next().and_then(|cn| cn.as_str().ok()).ok_or_else(|| bad("its subject has no common name".into()))?;
    if !lumen_transport::names::is_key_chunk(name) {
        return Err(bad(format!("its common name {name:?} cannot be a zenoh key chunk (no '/', '*', '$', '#', '?')")));
    }
    Ok(name.to_owned())
}

/// Options of a local (iceoryx2) client.
#[derive(Debug, Clone, Default)]
pub struct LocalOptions {
    /// iceoryx2 `global.prefix` (file name prefix in `/dev/shm`); must match the daemon's.
    /// `None`: the `LUMEN_IOX2_PREFIX` environment variable, else iceoryx2's default.
    pub prefix: Option<String>,
    /// Name shown by `lumen status` (default: the executable's name).
    pub name: Option<String>,
}

impl Client {
    /// A client of the daemon on this machine, over iceoryx2 shared memory.
    pub fn local() -> Result<Self, Error> {
        Self::local_with(LocalOptions::default())
    }

    /// A local client with explicit options.
    pub fn local_with(options: LocalOptions) -> Result<Self, Error> {
        let prefix = options.prefix.or_else(|| std::env::var("LUMEN_IOX2_PREFIX").ok());
        let inner = Inner::Local(local::LocalClient::new(prefix.as_deref())?);
        Ok(Self { inner, name: options.name.unwrap_or_else(default_name) })
    }

    /// A client of the daemon at a zenoh endpoint on this machine, such as
    /// `tcp/127.0.0.1:7447`. Beyond loopback a plain endpoint cannot tell the daemon from
    /// anyone answering in its place, so it is refused ([`Error::Unauthenticated`]): connect
    /// with [`Client::zenoh_tls`] / [`Client::zenoh_with_tls`] (the daemon's certificate checked
    /// against the lab's CA), or, accepting that, with [`Client::zenoh_insecure`] (or the
    /// environment variable `LUMEN_ZENOH_INSECURE=1`, for the C, C# and Python clients).
    pub fn zenoh(endpoint: &str) -> Result<Self, Error> {
        if !lumen_transport::net::is_loopback(endpoint) && std::env::var("LUMEN_ZENOH_INSECURE").as_deref() != Ok("1") {
            return Err(Error::Unauthenticated { endpoint: endpoint.to_owned() });
        }
        Self::zenoh_insecure(endpoint)
    }

    /// A client of the daemon at any plain zenoh endpoint, on this machine or not, without
    /// authenticating the daemon: whoever answers there is taken for it (an impostor could feed
    /// false contacts). For a lab's trusted network; [`Client::zenoh_with_tls`] otherwise.
    pub fn zenoh_insecure(endpoint: &str) -> Result<Self, Error> {
        Ok(Self { inner: Inner::Zenoh(remote::ZenohClient::connect(endpoint)?), name: default_name() })
    }

    /// A client of the daemon at a TLS endpoint such as `tls/lab-server:7447`, trusting the
    /// certificate authority in the PEM file `root_ca` (the daemon's certificate must be signed
    /// by it and name the host).
    pub fn zenoh_tls(endpoint: &str, root_ca: &Path) -> Result<Self, Error> {
        Self::zenoh_with_tls(endpoint, &Tls { root_ca: root_ca.to_owned(), identity: None })
    }

    /// A client of the daemon at a TLS endpoint with the given TLS material: the authority
    /// that signed the daemon's certificate and, for a daemon that asks for client
    /// certificates (mutual TLS), this client's own certificate and key.
    pub fn zenoh_with_tls(endpoint: &str, tls: &Tls) -> Result<Self, Error> {
        let mut config = lumen_transport::net::client_config(&[endpoint.to_owned()])?;
        let mut files = vec![("root_ca_certificate", &tls.root_ca)];
        if let Some((certificate, key)) = &tls.identity {
            files.extend([("connect_certificate", certificate), ("connect_private_key", key)]);
            lumen_transport::net::set(&mut config, "transport/link/tls/enable_mtls", "true")?;
        }
        for (key, file) in files {
            if !file.is_file() {
                return Err(Error::NoDaemon { transport: Transport::Zenoh, detail: format!("the TLS file {} ({key}) does not exist", file.display()) });
            }
            let value = serde_json::to_string(&file.display().to_string()).expect("a string");
            lumen_transport::net::set(&mut config, &format!("transport/link/tls/{key}"), &value)?;
        }
        let mut client = remote::ZenohClient::with_config(config, endpoint)?;
        if let Some((certificate, _)) = &tls.identity {
            client = client.certified_as(&common_name(certificate)?);
        }
        Ok(Self { inner: Inner::Zenoh(client), name: default_name() })
    }

    /// Opens sessions on the daemon named `daemon` only ([`DaemonInfo::daemon`], `[zenoh] name`
    /// of its configuration), not on the least loaded daemon of the zenoh network. A local client
    /// has one daemon and ignores this.
    pub fn on_daemon(mut self, daemon: &str) -> Self {
        if let Inner::Zenoh(c) = self.inner {
            self.inner = Inner::Zenoh(c.on_daemon(daemon));
        }
        self
    }

    /// Every daemon this client reaches, with its name and load: over zenoh each daemon on the
    /// network (through a router), locally the one.
    pub fn daemons(&self) -> Result<Vec<DaemonInfo>, Error> {
        match &self.inner {
            Inner::Local(_) => match self.request(&ControlRequest::Hello)? {
                ControlReply::Hello(d) => Ok(vec![d]),
                other => Err(control::unexpected(other)),
            },
            Inner::Zenoh(c) => c.daemons(CONTROL_TIMEOUT),
        }
    }

    /// Every daemon's status report, by daemon name (see [`Client::daemons`]); [`Client::status`]
    /// asks the nearest daemon only.
    pub fn status_all(&self) -> Result<Vec<StatusReport>, Error> {
        match &self.inner {
            Inner::Local(_) => Ok(vec![self.status()?]),
            Inner::Zenoh(c) => c.status_all(CONTROL_TIMEOUT),
        }
    }

    /// Sets the name `lumen status` shows for sessions this client opens.
    pub fn with_name(mut self, name: &str) -> Self {
        self.name = name.to_owned();
        self
    }

    /// The transport this client uses.
    pub fn transport(&self) -> Transport {
        match self.inner {
            Inner::Local(_) => Transport::Iceoryx2,
            Inner::Zenoh(_) => Transport::Zenoh,
        }
    }

    /// Opens a session for `spec`: the daemon validates it (an invalid one is refused with a
    /// message naming the problem) and sizes the session's channels from it.
    pub fn open_session(&self, spec: &SceneSpec) -> Result<Session, Error> {
        self.open(spec, false)
    }

    /// Opens a session whose daemon side only echoes an empty reply for each frame, without
    /// detecting: the transport's own cost, for benchmarks.
    pub fn open_echo_session(&self, spec: &SceneSpec) -> Result<Session, Error> {
        self.open(spec, true)
    }

    fn open(&self, spec: &SceneSpec, echo: bool) -> Result<Session, Error> {
        let request = ControlRequest::Open { version: PROTOCOL_VERSION, spec: spec.clone(), client: self.name.clone(), echo, alive: String::new() };
        match &self.inner {
            Inner::Local(c) => c.open(request).map(Session::from_local),
            Inner::Zenoh(c) => c.open(request).map(Session::from_zenoh),
        }
    }

    /// Watches session `session` (of any client of the same transport).
    pub fn observe(&self, session: u64) -> Result<Observer, Error> {
        let info = self.describe(session)?;
        match &self.inner {
            Inner::Local(c) => c.observe(info).map(Observer::from_local),
            Inner::Zenoh(c) => c.observe(info).map(Observer::from_zenoh),
        }
    }

    /// What the daemon that serves session `session` knows of it.
    pub fn describe(&self, session: u64) -> Result<SessionInfo, Error> {
        match self.request(&ControlRequest::Describe { session })? {
            ControlReply::Described(info) => Ok(info),
            other => Err(control::unexpected(other)),
        }
    }

    /// The daemon's sessions with their frame rates, latencies and contact counts (over zenoh
    /// the nearest daemon's; every daemon's: [`Client::status_all`]).
    pub fn status(&self) -> Result<StatusReport, Error> {
        match self.request(&ControlRequest::Status)? {
            ControlReply::Status(s) => Ok(s),
            other => Err(control::unexpected(other)),
        }
    }

    /// Sends one control request and returns the reply (errors from the daemon become
    /// [`Error::Refused`]).
    pub fn request(&self, request: &ControlRequest) -> Result<ControlReply, Error> {
        let reply = match &self.inner {
            Inner::Local(c) => c.control().request(request, CONTROL_TIMEOUT)?,
            Inner::Zenoh(c) => c.request(request, CONTROL_TIMEOUT)?,
        };
        match reply {
            ControlReply::Error(e) => Err(Error::Refused(e)),
            r => Ok(r),
        }
    }
}

fn default_name() -> String {
    std::env::current_exe().ok().and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned())).unwrap_or_else(|| "client".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plain endpoint on another machine is refused before any connection is tried, naming
    /// the endpoint and the ways out; TLS endpoints go through `zenoh_with_tls`.
    #[test]
    fn a_plain_endpoint_beyond_loopback_is_refused_unauthenticated() {
        for endpoint in ["tcp/10.0.0.5:7447", "tcp/0.0.0.0:7447", "tcp/lab-server:7447", "udp/[2001:db8::1]:7447"] {
            match Client::zenoh(endpoint) {
                Err(e @ Error::Unauthenticated { .. }) => {
                    let m = e.to_string();
                    assert!(m.starts_with(&format!("{endpoint} is not on this machine")) && m.contains("zenoh_insecure") && m.contains("LUMEN_ZENOH_INSECURE=1"), "{m}");
                }
                Err(e) => panic!("{endpoint}: {e}"),
                Ok(_) => panic!("{endpoint}: connected"),
            }
        }
    }
}
