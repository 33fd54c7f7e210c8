//! Zenoh observers: places counted against `limits.max_observers`, and asks answered with the
//! session's newest frame and its reply. Nothing is published for observers, so an observer
//! gets only what it asked for (a slow one asks less often) and an unregistered subscriber gets
//! nothing; the answers go out on threads of their own, never on the session's.

use crate::control::error;
use crate::error::DaemonError;
use crate::registry::Entry;
use lumen_proto::auth::Token;
use lumen_proto::session::ErrorCode;
use lumen_transport::names::{observe_name, AFTER_PARAMETER, END_PARAMETER, OBSERVER_PARAMETER};
use lumen_transport::net::{ASK_HOLD, OBSERVER_IDLE};
use lumen_transport::TransportError;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use zenoh::bytes::ZBytes;
use zenoh::query::{Query, Queryable};
use zenoh::Wait;

/// Asks waiting for the dispatcher before new ones are ended unanswered.
const ASK_QUEUE: usize = 64;
/// How often the dispatcher looks for places that lapsed when no ask comes.
const SWEEP: Duration = Duration::from_millis(100);

/// The newest frame of a session as the owner sent it, and the reply the daemon sent for it.
struct Latest {
    frame: u64,
    message: ZBytes,
    reply: ZBytes,
}

/// What the session's thread shares with its observers' threads.
#[derive(Default)]
struct Newest {
    latest: Mutex<Option<Latest>>,
    /// Notified on each frame and when the session ends.
    changed: Condvar,
    ended: AtomicBool,
}

/// A session's observer side over zenoh: the queryable on `lumen/session/<id>/observe`, a
/// dispatcher thread that checks each ask, and one thread per observer place that answers its
/// asks (zenoh sends an answer with the ask's congestion control, so an observer whose link
/// backs up delays only its own answers). Dropped with the session: the queryable goes, and the
/// threads end by themselves, not joined, so that an answer held up on a congested link never
/// holds up the session's end.
pub struct Observing {
    newest: Arc<Newest>,
    queryable: Option<Queryable<()>>,
}

impl Observing {
    /// Declares the session's observe queryable and starts its dispatcher.
    pub fn start(z: &zenoh::Session, entry: Arc<Entry>) -> Result<Self, DaemonError> {
        let id = entry.info.session;
        let key = observe_name(id);
        let (to_dispatcher, asks) = sync_channel::<Query>(ASK_QUEUE);
        // A full queue ends the ask here, unanswered: the observer asks again.
        let queryable = z
            .declare_queryable(&key)
            .callback(move |q| {
                let _ = to_dispatcher.try_send(q);
            })
            .wait()
            .map_err(|e| TransportError::zenoh(format!("declaring the queryable {key}"), e))?;
        let newest = Arc::new(Newest::default());
        let shared = newest.clone();
        std::thread::Builder::new()
            .name(crate::registry::thread_name("zenoh-o", id))
            .spawn(move || dispatch(&entry, &shared, &asks))
            .map_err(|source| DaemonError::Spawn { thread: format!("observers of session {id}"), source })?;
        Ok(Self { newest, queryable: Some(queryable) })
    }

    /// Hands observers frame `frame` (the message as received) and its reply; buffers are
    /// shared, not copied, and the session's thread never waits on an observer.
    pub fn publish(&self, frame: u64, message: ZBytes, reply: ZBytes) {
        *self.newest.latest.lock().expect("latest lock") = Some(Latest { frame, message, reply });
        self.newest.changed.notify_all();
    }
}

impl Drop for Observing {
    fn drop(&mut self) {
        // Under the lock: a place's thread between its look at `ended` and its wait would
        // otherwise miss the wake-up and wait out its ask.
        {
            let _latest = self.newest.latest.lock().expect("latest lock");
            self.newest.ended.store(true, Ordering::SeqCst);
        }
        self.newest.changed.notify_all();
        // Undeclaring drops the callback and its sender: the dispatcher then ends, dropping
        // the places' senders, and their threads end after the ask each holds.
        if let Some(q) = self.queryable.take() {
            let _ = q.undeclare().wait();
        }
    }
}

/// One ask, checked, waiting for a frame newer than `after`.
struct Held {
    query: Query,
    token: Token,
    after: Option<u64>,
    since: Instant,
}

/// The thread answering one observer place's asks (it ends once `asks` is dropped).
struct Worker {
    token: Token,
    asks: SyncSender<Held>,
    thread: JoinHandle<()>,
}

/// The dispatcher: checks asks, hands each to its place's thread (started on the place's first
/// ask), and lets the threads of places that lapsed or ended go.
fn dispatch(entry: &Entry, newest: &Arc<Newest>, asks: &Receiver<Query>) {
    let mut workers: Vec<Worker> = Vec::new();
    loop {
        match asks.recv_timeout(SWEEP) {
            Ok(query) => {
                let Some(held) = admit(entry, query) else { continue };
                let worker = match workers.iter().position(|w| w.token == held.token) {
                    Some(i) => &workers[i],
                    None => {
                        let (tx, rx) = sync_channel(1);
                        let shared = newest.clone();
                        match std::thread::Builder::new().name(crate::registry::thread_name("zenoh-w", entry.info.session)).spawn(move || answer(&shared, &rx)) {
                            Ok(thread) => {
                                workers.push(Worker { token: held.token, asks: tx, thread });
                                &workers[workers.len() - 1]
                            }
                            Err(e) => {
                                tracing::warn!("session {}: starting an observer's thread: {e}", entry.info.session);
                                continue;
                            }
                        }
                    }
                };
                // A place's thread holds one ask and queues one more; a further ask ends
                // unanswered.
                let _ = worker.asks.try_send(held);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        // A place that lapsed or ended: its thread ends after its ask (its sender is dropped).
        let now = Instant::now();
        workers.retain(|w| entry.places.holds(&w.token, now) && !w.thread.is_finished());
    }
}

/// A place's thread: answers each ask with the newest frame once it is newer than the ask's
/// `after`, or ends it unanswered after [`ASK_HOLD`] or when the session ends.
fn answer(newest: &Newest, asks: &Receiver<Held>) {
    while let Ok(held) = asks.recv() {
        let deadline = held.since + ASK_HOLD;
        let found = {
            let mut latest = newest.latest.lock().expect("latest lock");
            loop {
                if newest.ended.load(Ordering::SeqCst) {
                    break None;
                }
                if let Some(l) = latest.as_ref().filter(|l| held.after.is_none_or(|a| l.frame > a)) {
                    break Some((l.message.clone(), l.reply.clone()));
                }
                let now = Instant::now();
                if now >= deadline {
                    break None;
                }
                latest = newest.changed.wait_timeout(latest, deadline - now).expect("latest lock").0;
            }
        };
        if let Some((message, reply)) = found {
            send(&held.query, message, reply);
        }
    }
}

/// Checks an ask: `None` when it was answered with an error or needs no answer (`end`).
fn admit(entry: &Entry, query: Query) -> Option<Held> {
    let params = query.parameters();
    let token = params.get(OBSERVER_PARAMETER).and_then(Token::parse);
    let Some(token) = token.filter(|t| entry.places.touch(t, Instant::now())) else {
        refuse(
            &query,
            ErrorCode::NotObserver,
            format!("no observer place of session {} has this token: take one with {{\"op\":\"observe\"}} (places lapse after {} s without an ask)", entry.info.session, OBSERVER_IDLE.as_secs()),
        );
        return None;
    };
    if params.get(END_PARAMETER).is_some() {
        entry.places.give_back(&token);
        return None;
    }
    let after = match params.get(AFTER_PARAMETER).map(str::parse::<u64>) {
        None => None,
        Some(Ok(a)) => Some(a),
        Some(Err(_)) => {
            refuse(&query, ErrorCode::BadRequest, format!("{AFTER_PARAMETER} must be a frame number (an unsigned decimal integer)"));
            return None;
        }
    };
    Some(Held { query, token, after, since: Instant::now() })
}

/// The answer: one reply on the ask's key, the frame then its reply in one payload (shared
/// buffers, no copy), the frame's length in bytes as the attachment (8 bytes, little-endian).
/// One reply, so that whatever the asker's consolidation, a frame never comes without its reply.
fn send(query: &Query, message: ZBytes, reply: ZBytes) {
    let split = (message.len() as u64).to_le_bytes().to_vec();
    let mut both = ZBytes::writer();
    both.append(message);
    both.append(reply);
    let _ = query.reply(query.key_expr().clone(), both.finish()).attachment(split).wait();
}

fn refuse(query: &Query, code: ErrorCode, message: String) {
    let json = serde_json::to_vec(&error(code, message)).expect("replies serialise");
    let _ = query.reply_err(json).wait();
}
