//! Benchmarks behind `lumen bench`.

// `crate::ipc::ipc`: the IPC benchmark inside the benchmarks' folder (paths used by the e2e
// tests and the README).
#[allow(clippy::module_inception)]
pub mod ipc;
pub mod ownership;
pub mod wake;

/// The value at quantile `q` of nanoseconds `v` (sorted in place), in microseconds; NaN if empty.
pub(crate) fn quantile_us(v: &mut [u64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable();
    let i = ((v.len() as f64 * q).ceil() as usize).clamp(1, v.len()) - 1;
    v[i] as f64 / 1e3
}
