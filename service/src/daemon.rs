//! The daemon: both transports over one session registry, stopped by SIGINT or SIGTERM.

use crate::config::ServeConfig;
use crate::error::DaemonError;
use crate::local::Local;
use crate::registry::Registry;
use crate::remote::Remote;
use std::sync::Arc;
use std::thread::JoinHandle;

/// A configured daemon, not yet running.
pub struct Daemon {
    config: ServeConfig,
}

/// A running daemon: stop it with [`Running::stop`] (or a signal, see [`Running::wait_for_signal`]).
pub struct Running {
    pub registry: Arc<Registry>,
    threads: Vec<JoinHandle<()>>,
}

impl Daemon {
    pub fn new(config: ServeConfig) -> Self {
        Self { config }
    }

    /// Starts every configured transport; returns when they all serve.
    pub fn start(self) -> Result<Running, DaemonError> {
        self.config.validate()?;
        let name = self.config.zenoh.name.clone().unwrap_or_else(crate::registry::default_name);
        let registry = Arc::new(Registry::named(self.config.limits, name));
        let mut threads = Vec::new();
        if self.config.iceoryx2.enabled {
            let local = Local::new(self.config.iceoryx2.prefix.clone(), registry.clone());
            threads.push(local.start()?);
        }
        if self.config.zenoh.enabled() {
            let z = &self.config.zenoh;
            let policy = self.config.policy()?;
            let remote = Remote {
                mode: z.mode.clone(),
                listen: z.listen.clone(),
                connect: z.connect.clone(),
                tls: z.tls.clone(),
                policy,
                status: z.status,
                accept: (z.accept_pending, z.accept_timeout_ms),
                registry: registry.clone(),
            };
            match remote.start() {
                Ok(t) => threads.push(t),
                Err(e) => {
                    let running = Running { registry, threads };
                    running.stop();
                    return Err(e);
                }
            }
        }
        Ok(Running { registry, threads })
    }
}

impl Running {
    /// Blocks until SIGINT or SIGTERM (which must be blocked in every thread: see
    /// [`block_termination_signals`]) or until a transport thread ends by itself.
    pub fn wait_for_signal(&self) -> i32 {
        loop {
            if let Some(sig) = wait_signal(std::time::Duration::from_millis(200)) {
                return sig;
            }
            if self.threads.iter().any(|t| t.is_finished()) {
                return 0;
            }
        }
    }

    /// Ends every session and transport and waits for their threads.
    pub fn stop(self) {
        self.registry.shut_down();
        for t in self.threads {
            let _ = t.join();
        }
    }
}

/// Blocks SIGINT and SIGTERM in the calling thread and every thread it starts afterwards, so
/// that [`Running::wait_for_signal`] receives them. Call first thing in `main`.
pub fn block_termination_signals() {
    // SAFETY: plain libc calls on a local, initialised signal set.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, libc::SIGINT);
        libc::sigaddset(&mut set, libc::SIGTERM);
        libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
    }
}

/// Waits up to `timeout` (zero: just looks) for SIGINT or SIGTERM, blocked beforehand with
/// [`block_termination_signals`]; returns the signal taken, if any.
pub fn wait_signal(timeout: std::time::Duration) -> Option<i32> {
    // SAFETY: as above; sigtimedwait only reads the set and the timeout.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, libc::SIGINT);
        libc::sigaddset(&mut set, libc::SIGTERM);
        let ts = libc::timespec { tv_sec: timeout.as_secs() as libc::time_t, tv_nsec: timeout.subsec_nanos() as libc::c_long };
        let sig = libc::sigtimedwait(&set, std::ptr::null_mut(), &ts);
        (sig > 0).then_some(sig)
    }
}
