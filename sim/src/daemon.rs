//! Contacts from the Lumen daemon (`lumen serve`): a [`ContactSource`] over a
//! [`lumen_client::Session`], the way a lab's own engine would use Lumen.
//!
//! **Units**: round trips in microseconds of wall time (from `submit` to the reply in hand).
//!
//! Each frame is written straight into the session's frame (on iceoryx2 the shared memory the
//! daemon reads), so [`ContactSource::frame`] says `kept = false`: a loaned frame holds an
//! older frame's data and the world writes the whole state. [`ContactSource::detect`] submits,
//! waits for the reply to that frame (up to [`DaemonSource::timeout`]) and copies its contacts.
//!
//! ```no_run
//! use lumen_sim::{setup, daemon::DaemonSource, SimConfig, World};
//! let colon = setup::generated_colon(1, 1500.0);
//! let config = SimConfig::default();
//! let client = lumen_client::Client::local()?;
//! let session = client.open_session(&setup::scene_spec(&colon, &config.rod, &config.sim))?;
//! let mut world = World::new(&colon, config, DaemonSource::new(session)).unwrap();
//! world.step().unwrap();
//! println!("round trip {:.0} us", world.source().last_round_trip_us());
//! # Ok::<(), lumen_client::Error>(())
//! ```

use crate::world::{ContactSource, SourceError};
use lumen_client::Session;
use lumen_proto::wire::{Status, FLAG_TRUNCATED};
use lumen_proto::Contact;
use std::fmt;
use std::time::{Duration, Instant};

/// How long [`DaemonSource`] waits for a reply by default (generous: a frame takes well under
/// a millisecond, but a loaded machine can stall for a while).
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(5);

/// What went wrong between the simulation and the daemon.
#[derive(Debug)]
pub enum DaemonSourceError {
    /// The client failed (no daemon, timeout, daemon gone, transport error).
    Client(lumen_client::Error),
    /// The daemon answered the frame with an error status.
    Refused { frame: u64, status: Status, message: String },
    /// The daemon found more contacts than the session's capacity and sent only `sent`: the
    /// physics would miss constraints, so the run stops.
    Truncated { frame: u64, sent: u32 },
    /// [`DaemonSource::interrupt`] said to stop (a signal came) while waiting for the daemon.
    Interrupted(i32),
}

impl fmt::Display for DaemonSourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DaemonSourceError::Client(e) => write!(f, "{e}"),
            DaemonSourceError::Refused { frame, status, message } => write!(f, "the daemon refused frame {frame}: {status:?}: {message}"),
            DaemonSourceError::Truncated { frame, sent } => write!(f, "the daemon truncated the contacts of frame {frame} at the session's capacity ({sent})"),
            DaemonSourceError::Interrupted(sig) => write!(f, "interrupted by signal {sig} while waiting for the daemon"),
        }
    }
}

impl std::error::Error for DaemonSourceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            DaemonSourceError::Client(e) => Some(e),
            _ => None,
        }
    }
}

impl From<lumen_client::Error> for DaemonSourceError {
    fn from(e: lumen_client::Error) -> Self {
        DaemonSourceError::Client(e)
    }
}

/// How long [`DaemonSource`] keeps writing its frame again while the daemon is away, by
/// default: long enough for a restart (a zenoh link comes back within seconds of it).
pub const DEFAULT_RESUME_WITHIN: Duration = Duration::from_secs(30);

/// Pause between tries while the daemon is away.
const RETRY_PAUSE: Duration = Duration::from_millis(20);

/// Longest stretch a wait for a reply goes without asking [`DaemonSource::interrupt`].
const INTERRUPT_EVERY: Duration = Duration::from_millis(50);

/// Contacts from a daemon session (see the module docs).
///
/// It rides out a daemon restart: while the daemon is away (the client says `Disconnected`, or
/// a reply does not come), the world writes the frame again every 20 ms, and the session
/// reopens by itself once a daemon answers, for up to [`DaemonSource::resume_within`].
pub struct DaemonSource {
    session: Session,
    /// How long to wait for each reply.
    pub timeout: Duration,
    /// How long to keep retrying while the daemon is away before giving up.
    pub resume_within: Duration,
    /// Asked every 50 ms while a reply is awaited or the daemon is away: a signal number stops
    /// the wait with [`DaemonSourceError::Interrupted`] (a command line's SIGINT / SIGTERM).
    pub interrupt: Option<fn() -> Option<i32>>,
    /// Since when the daemon has been away, if it is.
    lost_since: Option<Instant>,
    /// The signal [`DaemonSource::interrupt`] gave, once it gave one.
    interrupted: Option<i32>,
    round_trips_us: Vec<f32>,
    detect_us: f64,
}

impl DaemonSource {
    /// A source over `session`, which must have been opened for the world's scene spec
    /// ([`crate::setup::scene_spec`]).
    pub fn new(session: Session) -> Self {
        Self { session, timeout: DEFAULT_TIMEOUT, resume_within: DEFAULT_RESUME_WITHIN, interrupt: None, lost_since: None, interrupted: None, round_trips_us: Vec::new(), detect_us: 0.0 }
    }

    /// The session.
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Round trip of every detection so far (submit to reply in hand), us, in order; the
    /// world's initial detections (before the first frame) included.
    pub fn round_trips_us(&self) -> &[f32] {
        &self.round_trips_us
    }

    /// Round trip of the last detection, us (0 before the first).
    pub fn last_round_trip_us(&self) -> f32 {
        self.round_trips_us.last().copied().unwrap_or(0.0)
    }

    /// The signal that stopped a wait for the daemon ([`DaemonSource::interrupt`]), if one did.
    pub fn interrupted(&self) -> Option<i32> {
        self.interrupted
    }

    /// Detection time the daemon reported for the last frame, us.
    pub fn last_detect_us(&self) -> f64 {
        self.detect_us
    }

    fn exchange(&mut self, out: &mut Vec<Contact>) -> Result<(), DaemonSourceError> {
        let t0 = Instant::now();
        let n = self.session.submit()?;
        let deadline = t0 + self.timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            // In slices, asking between them whether to stop, when someone may ask it to.
            let slice = if self.interrupt.is_some() { left.min(INTERRUPT_EVERY) } else { left };
            let reply = match self.session.contacts(slice) {
                Err(lumen_client::Error::Timeout(_)) if slice < left => {
                    if let Some(sig) = self.interrupt.and_then(|ask| ask()) {
                        self.interrupted = Some(sig);
                        return Err(DaemonSourceError::Interrupted(sig));
                    }
                    continue;
                }
                reply => reply?,
            };
            // A reply to an earlier frame (one that timed out before) is not this frame's.
            if reply.frame() < n {
                continue;
            }
            let rtt = t0.elapsed();
            if let Err((status, message)) = reply.result() {
                return Err(DaemonSourceError::Refused { frame: reply.frame(), status, message: message.to_owned() });
            }
            if reply.header().flags & FLAG_TRUNCATED != 0 {
                return Err(DaemonSourceError::Truncated { frame: reply.frame(), sent: reply.header().count });
            }
            self.detect_us = reply.detect_us();
            out.clear();
            out.extend_from_slice(reply.contacts());
            self.round_trips_us.push(rtt.as_secs_f32() * 1e6);
            self.lost_since = None;
            return Ok(());
        }
    }
}

impl ContactSource for DaemonSource {
    fn frame(&mut self) -> Result<(&mut [f32], bool), SourceError> {
        Ok((self.session.frame().map_err(DaemonSourceError::from)?, false))
    }

    fn detect(&mut self, out: &mut Vec<Contact>) -> Result<(), SourceError> {
        Ok(self.exchange(out)?)
    }

    fn retry_after(&mut self, error: &SourceError) -> Option<Duration> {
        use lumen_client::Error::{Disconnected, Timeout};
        let away = matches!(error.downcast_ref::<DaemonSourceError>(), Some(DaemonSourceError::Client(Disconnected | Timeout(_))));
        if !away {
            return None;
        }
        if let Some(sig) = self.interrupt.and_then(|ask| ask()) {
            self.interrupted = Some(sig);
            return None;
        }
        let since = *self.lost_since.get_or_insert_with(Instant::now);
        if since.elapsed() < self.resume_within {
            Some(RETRY_PAUSE)
        } else {
            None
        }
    }
}
