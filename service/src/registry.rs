//! The daemon's sessions, shared by both transports and `lumen status`.

use crate::config::Limits;
use crate::error::DaemonError;
use crate::places::Places;
use crate::stats::Stats;
use lumen_proto::auth::Secret;
use lumen_proto::session::{DaemonInfo, SessionInfo, SessionStatus, StatusReport, Transport};
use lumen_proto::ValidScene;
use std::collections::BTreeMap;
use std::hash::{BuildHasher, RandomState};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// One open session as the registry sees it.
#[derive(Debug)]
pub struct Entry {
    /// What `describe` tells anyone (no secret).
    pub info: SessionInfo,
    /// The owner's secret: proves closes and, over zenoh, frames; tags replies.
    pub secret: Secret,
    /// The session's scene, validated once when it opened.
    pub scene: ValidScene,
    pub client: String,
    /// The common name of the certificate that opened it (zenoh with client certificates).
    pub holder: Option<String>,
    /// The open request's `alive` chunk (empty if it gave none): the client whose sessions'
    /// ids this one's is kept for when it ends ([`Registry::next_id`]).
    pub chunk: String,
    pub opened: Instant,
    /// Set to ask the session's thread to end.
    pub close: AtomicBool,
    pub stats: Mutex<Stats>,
    /// Zenoh observers' places (iceoryx2 counts its observers in the channels).
    pub places: Places,
}

impl Entry {
    /// Counts `n` frames that did not come from the session's owner (`status`'s `forged`) and
    /// logs the total each time it passes a power of two; `what` says what they were.
    pub fn count_forged(&self, n: u64, what: &str) {
        let total = {
            let mut st = self.stats.lock().expect("stats lock");
            st.forged += n;
            st.forged
        };
        if (total - n + 1..=total).any(u64::is_power_of_two) {
            tracing::warn!("session {}: dropped {total} {what}", self.info.session);
        }
    }
}

/// How long a zenoh session's id rests after its session ended before another session may
/// take it: long enough for the old client's last messages and undeclarations to be gone.
pub const ID_REST: Duration = Duration::from_secs(1);
/// A rested id no open has taken for this long is forgotten (a client that left for good).
pub const ID_KEPT: Duration = Duration::from_secs(600);

/// All sessions, the id counter, the zenoh ids free to take again and the shutdown flag.
#[derive(Debug)]
pub struct Registry {
    pub limits: Limits,
    /// The daemon's name on the zenoh network (see [`default_name`]).
    pub name: String,
    started: Instant,
    /// Keys of the id hash, seeded by the OS.
    keys: RandomState,
    next: AtomicU64,
    /// Ids of ended zenoh sessions and when each ended, oldest first, by the `alive` chunk of
    /// the client that had them ([`Registry::next_id`]).
    rested: Mutex<std::collections::HashMap<String, std::collections::VecDeque<(u64, Instant)>>>,
    sessions: Mutex<BTreeMap<u64, Arc<Entry>>>,
    shutdown: AtomicBool,
}

impl Registry {
    /// An empty registry. Session ids are drawn at random (SipHash of a counter under keys the
    /// OS seeds), so they can't be guessed from one another, and a restarted daemon never hands
    /// out an id whose channels an old client may still hold.
    pub fn new(limits: Limits) -> Self {
        Self::named(limits, default_name())
    }

    /// An empty registry of the daemon called `name`.
    pub fn named(limits: Limits, name: String) -> Self {
        Self {
            limits,
            name,
            started: Instant::now(),
            keys: RandomState::new(),
            next: AtomicU64::new(0),
            rested: Default::default(),
            sessions: Mutex::new(BTreeMap::new()),
            shutdown: AtomicBool::new(false),
        }
    }

    /// What [`lumen_proto::session::ControlRequest::Hello`] answers: the name and the load.
    pub fn hello(&self) -> DaemonInfo {
        DaemonInfo { daemon: self.name.clone(), pid: std::process::id(), sessions: self.len() as u32, max_sessions: self.limits.max_sessions as u32 }
    }

    /// An id for a new session on `transport` for the client whose open gave `chunk` (its
    /// `alive`, empty if none): nonzero, not in use, below 2^53 (so JSON doubles hold it
    /// exactly). Over zenoh, the id of one of that client's sessions that ended at least
    /// [`ID_REST`] ago when there is one: zenoh keeps every key it has routed for as long as a
    /// connection lasts (the daemon's and each client's), so fresh keys for every session grew
    /// both by a few KiB a session; a client's ids reused keep its keys bounded by how many
    /// sessions it opens in [`ID_REST`]. Else, and always over iceoryx2 (whose services must be
    /// gone before their names are taken again), a fresh random one.
    pub fn next_id(&self, transport: Transport, chunk: &str) -> u64 {
        if transport == Transport::Zenoh {
            let mut rested = self.rested.lock().expect("registry lock");
            // Clients gone for good leave nothing behind for long.
            rested.retain(|_, ids| {
                while ids.front().is_some_and(|(_, ended)| ended.elapsed() > ID_KEPT) {
                    ids.pop_front();
                }
                !ids.is_empty()
            });
            if let Some(ids) = rested.get_mut(chunk) {
                while ids.front().is_some_and(|(_, ended)| ended.elapsed() >= ID_REST) {
                    let (id, _) = ids.pop_front().expect("a front");
                    if self.get(id).is_none() {
                        return id;
                    }
                }
            }
        }
        self.fresh_id()
    }

    /// A fresh random session id, not in use.
    fn fresh_id(&self) -> u64 {
        loop {
            let id = self.keys.hash_one(self.next.fetch_add(1, Ordering::Relaxed)) & ((1 << 53) - 1);
            if id != 0 && self.get(id).is_none() {
                return id;
            }
        }
    }

    /// Waits until session `id` has left the registry (its thread ended and its channels are
    /// gone), at most `limit`; returns whether it did.
    pub fn wait_gone(&self, id: u64, limit: Duration) -> bool {
        let end = Instant::now() + limit;
        while self.get(id).is_some() {
            if Instant::now() >= end {
                return false;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        true
    }

    /// Whether another session may open.
    pub fn has_room(&self) -> bool {
        self.sessions.lock().expect("registry lock").len() < self.limits.max_sessions
    }

    /// Adds a session; `None` if the daemon is full.
    pub fn insert(&self, info: SessionInfo, secret: Secret, scene: ValidScene, client: String, holder: Option<String>, chunk: String) -> Option<Arc<Entry>> {
        let mut s = self.sessions.lock().expect("registry lock");
        if s.len() >= self.limits.max_sessions {
            return None;
        }
        let e = Arc::new(Entry { info, secret, scene, client, holder, chunk, opened: Instant::now(), close: AtomicBool::new(false), stats: Mutex::new(Stats::default()), places: Places::default() });
        s.insert(e.info.session, e.clone());
        Some(e)
    }

    /// Makes every resting id look `by` older (tests: no sleeping through [`ID_REST`]).
    #[cfg(test)]
    pub(crate) fn age_rested(&self, by: Duration) {
        for (_, ended) in self.rested.lock().expect("registry lock").values_mut().flatten() {
            *ended -= by;
        }
    }

    /// Forgets a session (its thread has ended); a zenoh session's id rests, then may be taken
    /// again ([`Registry::next_id`]).
    pub fn remove(&self, id: u64) {
        let gone = self.sessions.lock().expect("registry lock").remove(&id);
        if let Some(e) = gone.filter(|e| e.info.transport == Transport::Zenoh) {
            self.rested.lock().expect("registry lock").entry(e.chunk.clone()).or_default().push_back((id, Instant::now()));
        }
    }

    /// The session `id`, if open.
    pub fn get(&self, id: u64) -> Option<Arc<Entry>> {
        self.sessions.lock().expect("registry lock").get(&id).cloned()
    }

    /// Sessions opened with the certificate named `holder`.
    pub fn held_by(&self, holder: &str) -> usize {
        self.sessions.lock().expect("registry lock").values().filter(|e| e.holder.as_deref() == Some(holder)).count()
    }

    /// Number of open sessions.
    pub fn len(&self) -> usize {
        self.sessions.lock().expect("registry lock").len()
    }

    /// Whether no session is open.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Asks every thread to end.
    pub fn shut_down(&self) {
        self.shutdown.store(true, Ordering::SeqCst);
    }

    /// Whether the daemon is stopping.
    pub fn stopping(&self) -> bool {
        self.shutdown.load(Ordering::SeqCst)
    }

    /// The status report.
    pub fn status(&self) -> StatusReport {
        let now = Instant::now();
        let sessions = self
            .sessions
            .lock()
            .expect("registry lock")
            .values()
            .map(|e| {
                let s = e.stats.lock().expect("stats lock");
                SessionStatus {
                    session: e.info.session,
                    transport: e.info.transport,
                    client: e.client.clone(),
                    age_s: now.duration_since(e.opened).as_secs_f64(),
                    frames: s.frames,
                    bad_frames: s.bad_frames,
                    skipped: s.skipped,
                    forged: s.forged,
                    fps: s.fps,
                    detect: s.detect.percentiles(),
                    service: s.service.percentiles(),
                    contacts_last: s.contacts_last,
                    contacts_mean: s.contacts_mean(),
                }
            })
            .collect();
        StatusReport { daemon: self.name.clone(), pid: std::process::id(), version: env!("CARGO_PKG_VERSION").into(), uptime_s: self.started.elapsed().as_secs_f64(), sessions, hidden: 0 }
    }

    /// Sessions on `transport`.
    pub fn count(&self, transport: Transport) -> usize {
        self.sessions.lock().expect("registry lock").values().filter(|e| e.info.transport == transport).count()
    }
}

/// A daemon's name when its configuration gives none: the host's name and the process id
/// (`lab-server-4242`), unique among daemons that share a zenoh network, with every character
/// that cannot stand in one zenoh key chunk replaced by `-`.
pub fn default_name() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").map(|h| h.trim().to_owned()).unwrap_or_default();
    let host = if host.is_empty() { "lumen".to_owned() } else { host };
    let clean: String = host.chars().map(|c| if c.is_whitespace() || !lumen_transport::names::is_daemon_name(c.encode_utf8(&mut [0; 4])) { '-' } else { c }).collect();
    format!("{clean}-{}", std::process::id())
}

/// A session thread's name: `kind` and as many of the id's last digits as fit in the 15 bytes
/// Linux keeps (gdb, top and /proc show only those), so two sessions' threads never look alike.
pub fn thread_name(kind: &str, id: u64) -> String {
    let digits = 15usize.saturating_sub(kind.len()).clamp(1, 19) as u32;
    let low = id % 10u64.pow(digits);
    format!("{kind}{low:0width$}", width = digits as usize)
}

/// Runs session `id` on its own thread, named [`thread_name`]`(kind, id)`: `run` gets a sender
/// on which it reports whether its channels were created, and returns why the session ended.
/// The session leaves the registry whatever happens. Returns the thread and that first report
/// (an error if the thread did not report within 10 s).
pub fn spawn_session<F>(kind: &str, id: u64, registry: Arc<Registry>, run: F) -> Result<(std::thread::JoinHandle<()>, Result<(), DaemonError>), DaemonError>
where
    F: FnOnce(&Registry, &std::sync::mpsc::Sender<Result<(), DaemonError>>) -> Result<&'static str, DaemonError> + Send + 'static,
{
    let (tx, rx) = std::sync::mpsc::channel();
    let handle = std::thread::Builder::new()
        .name(thread_name(kind, id))
        .spawn(move || {
            let result = run(&registry, &tx);
            registry.remove(id);
            match result {
                Ok(why) => tracing::info!("session {id} ended: {why}"),
                Err(e) => {
                    tracing::warn!("session {id} failed: {e}");
                    let _ = tx.send(Err(e));
                }
            }
        })
        .map_err(|source| DaemonError::Spawn { thread: format!("session {id}"), source })?;
    let r = rx.recv_timeout(std::time::Duration::from_secs(10)).unwrap_or_else(|_| Err(DaemonError::Stopped(format!("session {id}"))));
    Ok((handle, r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_restarted_daemon_never_reuses_ids() {
        // Two daemons started in the same instant (a kill -9 and restart) must not collide.
        let ids: std::collections::HashSet<u64> = (0..100).map(|_| Registry::new(Limits::default()).next_id(Transport::Zenoh, "")).collect();
        assert_eq!(ids.len(), 100);
        let r = Registry::new(Limits::default());
        let (a, b) = (r.next_id(Transport::Zenoh, ""), r.next_id(Transport::Iceoryx2, ""));
        assert_ne!(a, b);
        assert!(a < 1 << 53 && b < 1 << 53);
    }

    #[test]
    fn one_daemons_ids_are_random_not_consecutive() {
        let r = Registry::new(Limits::default());
        let ids: Vec<u64> = (0..1000).map(|_| r.next_id(Transport::Iceoryx2, "")).collect();
        assert_eq!(ids.iter().collect::<std::collections::HashSet<_>>().len(), 1000, "distinct");
        assert!(ids.iter().all(|&id| id != 0 && id < 1 << 53));
        // Consecutive or nearby ids would make the next one guessable from the last. Two random
        // ids in 2^53 fall within 2^20 of each other with odds 2^-32, so 999 pairs never do (an
        // earlier bound of 2^40 failed one run in five by chance).
        let near = ids.windows(2).filter(|w| w[0].abs_diff(w[1]) < 1 << 20).count();
        assert_eq!(near, 0, "ids within 2^20 of the one before");
        // Spread over the whole range: the top bit of 53 is set for about half of them.
        let high = ids.iter().filter(|&&id| id >> 52 == 1).count();
        assert!((400..600).contains(&high), "{high} of 1000 in the upper half");
    }

    #[test]
    fn a_default_name_is_one_key_chunk_and_ends_with_the_pid() {
        let n = default_name();
        assert!(lumen_transport::names::is_daemon_name(&n), "{n}");
        assert!(n.ends_with(&format!("-{}", std::process::id())), "{n}");
    }

    #[test]
    fn session_thread_names_fit_linux_and_tell_neighbouring_sessions_apart() {
        // Linux keeps 15 bytes of a thread's name; the old "iox2-session-<id>" cut every id.
        let (a, b) = (thread_name("iox2-s", 1131356597671358), thread_name("iox2-s", 1131356597671359));
        assert_eq!((a.as_str(), b.as_str()), ("iox2-s597671358", "iox2-s597671359"));
        assert_eq!(thread_name("zenoh-s", 42), "zenoh-s00000042");
        assert!(thread_name("zenoh-s", u64::MAX).len() <= 15);
    }
}
