//! How a client subcommand reaches the daemon: iceoryx2 on this machine (`--prefix`), or zenoh
//! (`--zenoh ENDPOINT`). Shared by `lumen status`, `lumen record` and `lumen replay`.

use clap::Args;
use lumen_client::{Client, LocalOptions};

#[derive(Debug, Clone, Args)]
pub struct TransportArgs {
    /// Reach the daemon over zenoh at this endpoint instead of iceoryx2.
    #[arg(long = "zenoh", value_name = "ENDPOINT")]
    pub zenoh: Option<String>,
    /// iceoryx2 prefix of the daemon (env LUMEN_IOX2_PREFIX).
    #[arg(long, env = "LUMEN_IOX2_PREFIX")]
    pub prefix: Option<String>,
}

impl TransportArgs {
    /// A client over the chosen transport; `name` is what `lumen status` shows for it.
    pub fn client(&self, name: &str) -> Result<Client, lumen_client::Error> {
        match &self.zenoh {
            Some(ep) => Ok(Client::zenoh(ep)?.with_name(name)),
            None => Client::local_with(LocalOptions { prefix: self.prefix.clone(), name: Some(name.into()) }),
        }
    }
}
