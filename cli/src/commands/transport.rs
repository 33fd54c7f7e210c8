//! How a client subcommand reaches the daemon: iceoryx2 on this machine (`--prefix`), or zenoh
//! (`--zenoh ENDPOINT`, or `--transport zenoh` for the default endpoint). Shared by every client
//! subcommand (`lumen status`, `lumen sim`, `lumen record`, `lumen replay`).

use clap::{Args, ValueEnum};
use lumen_client::{Client, LocalOptions, Tls, Transport};
use std::path::PathBuf;

/// The zenoh endpoint clients use when none is given (a daemon started with
/// `--zenoh-listen tcp/127.0.0.1:7447` on this machine).
pub const DEFAULT_ZENOH: &str = "tcp/127.0.0.1:7447";

/// Transport choice on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TransportArg {
    /// Shared memory on this machine.
    Iceoryx2,
    /// The network (tcp or tls endpoint).
    Zenoh,
}

impl From<TransportArg> for Transport {
    fn from(t: TransportArg) -> Self {
        match t {
            TransportArg::Iceoryx2 => Transport::Iceoryx2,
            TransportArg::Zenoh => Transport::Zenoh,
        }
    }
}

/// The daemon to talk to.
#[derive(Debug, Clone, Args)]
pub struct TransportArgs {
    /// Transport (default: zenoh if --zenoh is given, else iceoryx2).
    #[arg(long = "transport", value_enum)]
    pub kind: Option<TransportArg>,
    /// iceoryx2 prefix of the daemon (env LUMEN_IOX2_PREFIX).
    #[arg(long, env = "LUMEN_IOX2_PREFIX")]
    pub prefix: Option<String>,
    /// zenoh endpoint of the daemon (default tcp/127.0.0.1:7447); implies --transport zenoh.
    #[arg(long = "zenoh", value_name = "ENDPOINT")]
    pub zenoh: Option<String>,
    /// PEM certificate of the CA that signed the daemon's certificate (for tls/ endpoints).
    #[arg(long = "zenoh-ca", value_name = "PEM")]
    pub zenoh_ca: Option<PathBuf>,
    /// This client's PEM certificate, for a daemon that requires client certificates; its
    /// common name is what the daemon's access policy knows it by.
    #[arg(long = "zenoh-cert", value_name = "PEM", requires_all = ["zenoh_key", "zenoh_ca"])]
    pub zenoh_cert: Option<PathBuf>,
    /// The private key of --zenoh-cert.
    #[arg(long = "zenoh-key", value_name = "PEM", requires = "zenoh_cert")]
    pub zenoh_key: Option<PathBuf>,
    /// Open sessions on the daemon of this name (its `--zenoh-name`), not on the least loaded
    /// daemon of the zenoh network.
    #[arg(long = "daemon", value_name = "NAME")]
    pub daemon: Option<String>,
    /// Connect to a plain (not tls/) zenoh endpoint on another machine, taking whoever answers
    /// there for the daemon (without it such an endpoint is refused).
    #[arg(long)]
    pub insecure: bool,
}

impl TransportArgs {
    /// The transport these flags choose.
    pub fn transport(&self) -> Transport {
        match (self.kind, &self.zenoh) {
            (Some(t), _) => t.into(),
            (None, Some(_)) => Transport::Zenoh,
            (None, None) => Transport::Iceoryx2,
        }
    }

    /// A client of the daemon, showing as `name` in `lumen status`.
    pub fn client(&self, name: &str) -> Result<Client, lumen_client::Error> {
        match self.transport() {
            Transport::Zenoh => {
                let endpoint = self.zenoh.as_deref().unwrap_or(DEFAULT_ZENOH);
                let client = match &self.zenoh_ca {
                    None if self.insecure => Client::zenoh_insecure(endpoint)?,
                    None => Client::zenoh(endpoint)?,
                    Some(ca) => {
                        let identity = self.zenoh_cert.clone().zip(self.zenoh_key.clone());
                        Client::zenoh_with_tls(endpoint, &Tls { root_ca: ca.clone(), identity })?
                    }
                };
                let client = match &self.daemon {
                    Some(d) => client.on_daemon(d),
                    None => client,
                };
                Ok(client.with_name(name))
            }
            Transport::Iceoryx2 => Client::local_with(LocalOptions { prefix: self.prefix.clone(), name: Some(name.into()) }),
        }
    }
}
