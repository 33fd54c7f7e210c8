//! The status every call returns: a fixed-width integer in C, zero for success.

/// What a call did. `LUMEN_STATUS_OK` is 0; on any other status the call changed nothing but
/// its out-parameters (set to NULL or 0), and `lumen_last_error` says what was wrong.
#[repr(i32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LumenStatus {
    /// Success.
    Ok = 0,
    /// A pointer argument (or the detector handle) was NULL.
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
}
