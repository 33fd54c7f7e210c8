use std::sync::OnceLock;
use std::time::Instant;

/// Nanoseconds on this process's monotonic clock (since its first use). Frames carry it as
/// `client_time_ns`; replies echo it, so `now_ns() - reply.client_time_ns` is the round trip.
pub fn now_ns() -> u64 {
    static BASE: OnceLock<Instant> = OnceLock::new();
    BASE.get_or_init(Instant::now).elapsed().as_nanos() as u64
}
