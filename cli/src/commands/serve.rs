//! `lumen serve`: configuration file, then flags, then run until SIGINT/SIGTERM.

use super::CliResult;
use clap::Args;
use lumen_service::config::ServeConfig;
use lumen_service::daemon::{block_termination_signals, Daemon};
use std::io::Write;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ServeArgs {
    /// TOML configuration file (flags override it).
    #[arg(long, short)]
    pub config: Option<PathBuf>,
    /// iceoryx2 file-name prefix in /dev/shm (clients must use the same; env LUMEN_IOX2_PREFIX).
    #[arg(long, env = "LUMEN_IOX2_PREFIX")]
    pub prefix: Option<String>,
    /// Do not serve over iceoryx2.
    #[arg(long)]
    pub no_iceoryx2: bool,
    /// Serve over zenoh, listening here (repeatable), e.g. tcp/127.0.0.1:7447; beyond loopback,
    /// tls/0.0.0.0:7447 with client certificates (or --insecure).
    #[arg(long = "zenoh-listen", value_name = "ENDPOINT")]
    pub zenoh_listen: Vec<String>,
    /// Connect zenoh to this router (repeatable).
    #[arg(long = "zenoh-connect", value_name = "ENDPOINT")]
    pub zenoh_connect: Vec<String>,
    /// This daemon's name on the zenoh network (default: the host's name and the pid): clients
    /// pick a daemon by it (`--daemon`).
    #[arg(long = "zenoh-name", value_name = "NAME")]
    pub zenoh_name: Option<String>,
    /// What `status` shows a zenoh client without a certificate grant: counts (the default: how
    /// many sessions, no ids) or sessions (every session, its id and figures).
    #[arg(long = "zenoh-status", value_name = "POLICY", value_parser = ["counts", "sessions"])]
    pub zenoh_status: Option<String>,
    /// zenoh mode: router or peer.
    #[arg(long = "zenoh-mode")]
    pub zenoh_mode: Option<String>,
    /// PEM certificate (chain) of the daemon for tls/ endpoints.
    #[arg(long = "zenoh-tls-cert", value_name = "PEM", requires = "zenoh_tls_key")]
    pub zenoh_tls_cert: Option<PathBuf>,
    /// PEM private key of that certificate.
    #[arg(long = "zenoh-tls-key", value_name = "PEM", requires = "zenoh_tls_cert")]
    pub zenoh_tls_key: Option<PathBuf>,
    /// PEM certificate of the CA that signs client certificates: every zenoh client must then
    /// present one (mutual TLS); what each may do is the config file's [[zenoh.access]].
    #[arg(long = "zenoh-client-ca", value_name = "PEM", requires = "zenoh_tls_cert")]
    pub zenoh_client_ca: Option<PathBuf>,
    /// Serve zenoh endpoints that other machines can reach without client certificates:
    /// anyone who reaches them can open and observe sessions and impersonate this daemon.
    /// Without it such a start is refused; say why at start-up.
    #[arg(long)]
    pub insecure: bool,
    /// Most sessions at once.
    #[arg(long)]
    pub max_sessions: Option<usize>,
    /// Most observers per session.
    #[arg(long)]
    pub max_observers: Option<usize>,
}

impl ServeArgs {
    /// The configuration: file, then flags.
    pub fn config(&self) -> Result<ServeConfig, lumen_service::config::ConfigError> {
        let mut c = match &self.config {
            Some(p) => ServeConfig::from_file(p)?,
            None => ServeConfig::default(),
        };
        if self.prefix.is_some() {
            c.iceoryx2.prefix = self.prefix.clone();
        }
        if self.no_iceoryx2 {
            c.iceoryx2.enabled = false;
        }
        if !self.zenoh_listen.is_empty() {
            c.zenoh.listen = self.zenoh_listen.clone();
        }
        if !self.zenoh_connect.is_empty() {
            c.zenoh.connect = self.zenoh_connect.clone();
        }
        if let (Some(certificate), Some(private_key)) = (&self.zenoh_tls_cert, &self.zenoh_tls_key) {
            let client_ca = c.zenoh.tls.as_ref().and_then(|t| t.client_ca.clone());
            c.zenoh.tls = Some(lumen_service::config::TlsFiles { certificate: certificate.clone(), private_key: private_key.clone(), client_ca });
        }
        if let (Some(ca), Some(tls)) = (&self.zenoh_client_ca, c.zenoh.tls.as_mut()) {
            tls.client_ca = Some(ca.clone());
        }
        if let Some(p) = &self.zenoh_status {
            c.zenoh.status = if p == "sessions" { lumen_service::config::StatusPolicy::Sessions } else { lumen_service::config::StatusPolicy::Counts };
        }
        if self.zenoh_name.is_some() {
            c.zenoh.name = self.zenoh_name.clone();
        }
        if let Some(m) = &self.zenoh_mode {
            c.zenoh.mode = m.clone();
        }
        if self.insecure {
            c.zenoh.insecure = true;
        }
        if let Some(n) = self.max_sessions {
            c.limits.max_sessions = n;
        }
        if let Some(n) = self.max_observers {
            c.limits.max_observers = n;
        }
        Ok(c)
    }
}

pub fn run(args: ServeArgs) -> CliResult {
    block_termination_signals();
    let config = args.config()?;
    let open = config.zenoh.open_to_others();
    if config.zenoh.insecure && !open.is_empty() {
        eprintln!("lumen serve: --insecure: {} reachable from other machines without client certificates: {}", open.join(", "), lumen_service::config::INSECURE_MEANS);
    }
    let running = Daemon::new(config.clone()).start()?;
    let name = running.registry.name.clone();
    let transports = [
        config.iceoryx2.enabled.then(|| format!("iceoryx2 (prefix {})", config.iceoryx2.prefix.as_deref().unwrap_or("iox2_"))),
        config.zenoh.enabled().then(|| format!("zenoh {} {:?} {:?} as {name:?}", config.zenoh.mode, config.zenoh.listen, config.zenoh.connect)),
    ];
    let transports: Vec<String> = transports.into_iter().flatten().collect();
    // One line on stdout when serving: scripts and tests wait for it.
    println!("lumen serve: ready, pid {}, {}", std::process::id(), transports.join(", "));
    let _ = std::io::stdout().flush();
    let sig = running.wait_for_signal();
    tracing::info!("stopping (signal {sig}); {} sessions open", running.registry.len());
    running.stop();
    println!("lumen serve: stopped");
    Ok(())
}
