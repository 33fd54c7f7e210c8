//! The status every call returns: a fixed-width integer in C, zero for success.

/// What a call did. `LUMEN_STATUS_OK` is 0; on any other status the call changed nothing but
/// its out-parameters (set to NULL or 0), and `lumen_last_error` says what was wrong. Besides
/// the statuses each function's documentation names, any call may return
/// `LUMEN_STATUS_NULL_ARGUMENT` (a NULL pointer it needs), `LUMEN_STATUS_BAD_HANDLE` (a handle
/// freed already, or of another kind), `LUMEN_STATUS_WRONG_THREAD` (see its entry) and
/// `LUMEN_STATUS_PANIC` (a bug, caught at the boundary).
#[repr(i32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LumenStatus {
    /// Success.
    Ok = 0,
    /// A pointer argument (or a handle) was NULL.
    NullArgument = 1,
    /// The scene spec's bytes are not UTF-8.
    BadUtf8 = 2,
    /// The scene spec is not valid JSON of the scene format, or does not validate (a count,
    /// a limit, a pair); the message names the body or pair.
    BadSpec = 3,
    /// The state has the wrong number of floats or a non-finite value; the message names the
    /// body and index. The detector keeps its history; the next good frame continues.
    BadState = 4,
    /// A panic inside Lumen was caught at the boundary (a bug: please report the message).
    /// A detector that panicked answers `LUMEN_STATUS_PANIC` from then on: free it.
    Panic = 5,
    /// A handle is not a live one of the kind the call takes (freed already, never made by
    /// Lumen, or a session given where a client is wanted).
    BadHandle = 6,
    /// An iceoryx2 (local) client, session or observer was called from a thread other than
    /// the one that made it (make one client per thread), or a detector while another thread's
    /// call on it ran (one thread at a time per detector). Nothing was done.
    WrongThread = 7,
    /// No daemon answers (none running, another iceoryx2 prefix or zenoh endpoint, a zenoh
    /// endpoint nothing listens on or cannot be reached, a TLS file missing, or a daemon too
    /// busy to answer in time): start `lumen serve`, or try again.
    NoDaemon = 8,
    /// The daemon refused the request (an invalid spec, a limit, an unknown session); the
    /// message has its words and code.
    Refused = 9,
    /// No reply within the timeout; the session still works: wait again or submit the next
    /// frame.
    Timeout = 10,
    /// The daemon went away (or no longer has the session). Keep calling
    /// `lumen_session_frame`/`lumen_session_submit`: the session reopens by itself, with a
    /// new id, as soon as a daemon answers again.
    Disconnected = 11,
    /// `lumen_session_submit` without a frame got from `lumen_session_frame` since the last
    /// submit.
    NoFrame = 12,
    /// The observed session ended (its client left or the daemon stopped).
    SessionEnded = 13,
    /// The transport failed (iceoryx2: shared memory, permissions, too many ports on a
    /// service; zenoh: a bad configuration, a plain endpoint beyond loopback refused as
    /// unauthenticated); the message says which.
    Transport = 14,
    /// The daemon sent something this library does not understand (a version mismatch?).
    Protocol = 15,
}
