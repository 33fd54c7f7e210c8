//! The machine's own floor under any round trip: one byte there and back between two threads of
//! this process over a Unix socket pair, no payload, no iceoryx2, no zenoh, no detection.
//!
//! Every round trip of `lumen bench ipc` wakes two sleeping threads (the daemon's on the frame,
//! the client's on the reply). Where the two run on different cores of a virtual machine, each
//! wake-up goes through the hypervisor, and a round-trip target below this floor cannot be met
//! on that machine by anything the daemon does (the development VM's figures:
//! `docs/measurements.md`).

use super::quantile_us;
use serde::Serialize;
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::time::{Duration, Instant};

/// Quantiles of the wake-up round trip, microseconds.
#[derive(Debug, Clone, Serialize)]
pub struct Wake {
    /// `back-to-back` (the next byte at once) or `paced-1khz` (one a millisecond).
    pub mode: String,
    /// `two cores` (each thread pinned to its own) or `one core` (both pinned to the same).
    pub cores: String,
    pub p50_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    pub round_trips: u64,
}

/// The first two cores this process may run on (one if it may run on one only).
pub fn cores() -> Vec<usize> {
    // SAFETY: a zeroed cpu_set_t is a valid empty set; the call writes at most its size.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    if unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) } != 0 {
        return vec![0];
    }
    // SAFETY: reading bits of the set the kernel filled, within its capacity.
    (0..libc::CPU_SETSIZE as usize).filter(|&c| unsafe { libc::CPU_ISSET(c, &set) }).take(2).collect()
}

/// Pins the calling thread to `cpu` (best effort: the measurement says where it ran).
fn pin(cpu: usize) {
    // SAFETY: as in `cores`; the set names one core of those allowed.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
    }
}

/// Measures `n` round trips (after a warm-up of a tenth), back to back or one a millisecond,
/// between two threads of their own pinned to cores `near_cpu` and `far_cpu` (the same core or
/// two), so the caller's affinity is left alone.
pub fn measure(n: usize, paced: bool, near_cpu: usize, far_cpu: usize) -> std::io::Result<Wake> {
    let (mut near, mut far) = UnixStream::pair()?;
    // The far thread answers every byte until the near side closes.
    let echo = std::thread::spawn(move || {
        pin(far_cpu);
        let mut b = [0u8; 1];
        while far.read(&mut b).is_ok_and(|got| got == 1) && far.write_all(&b).is_ok() {}
    });
    let timer = std::thread::spawn(move || -> std::io::Result<Vec<u64>> {
        pin(near_cpu);
        let warm = n / 10;
        let mut rtt = Vec::with_capacity(n);
        let start = Instant::now();
        for k in 0..warm + n {
            if paced {
                let due = start + Duration::from_micros(1000 * k as u64);
                std::thread::sleep(due.saturating_duration_since(Instant::now()));
            }
            let t0 = Instant::now();
            near.write_all(&[1])?;
            let mut b = [0u8; 1];
            near.read_exact(&mut b)?;
            if k >= warm {
                rtt.push(t0.elapsed().as_nanos() as u64);
            }
        }
        Ok(rtt)
    });
    let mut rtt = timer.join().map_err(|_| std::io::Error::other("the measuring thread panicked"))??;
    let _ = echo.join();
    let cores = if near_cpu == far_cpu { "one core" } else { "two cores" };
    let (p50_us, p99_us, p999_us) = (quantile_us(&mut rtt, 0.5), quantile_us(&mut rtt, 0.99), quantile_us(&mut rtt, 0.999));
    Ok(Wake { mode: if paced { "paced-1khz" } else { "back-to-back" }.into(), cores: cores.into(), p50_us, p99_us, p999_us, round_trips: rtt.len() as u64 })
}

/// The floor both ways (back to back, paced at 1 kHz), across two cores where the process may
/// use two, and on one.
pub fn floor(n: usize) -> std::io::Result<Vec<Wake>> {
    let cpus = cores();
    let mut out = Vec::new();
    for paced in [false, true] {
        if cpus.len() > 1 {
            out.push(measure(n, paced, cpus[0], cpus[1])?);
        }
        out.push(measure(n, paced, cpus[0], cpus[0])?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_are_counted_and_ordered() {
        let c = cores()[0];
        let w = measure(200, false, c, c).unwrap();
        assert_eq!((w.mode.as_str(), w.cores.as_str(), w.round_trips), ("back-to-back", "one core", 200));
        assert!(0.0 < w.p50_us && w.p50_us <= w.p99_us && w.p99_us <= w.p999_us, "{w:?}");
        let w = measure(20, true, c, c).unwrap();
        assert_eq!((w.mode.as_str(), w.round_trips), ("paced-1khz", 20));
        // Paced, the 20 round trips (and 2 of warm-up) take at least 21 ms.
        let t = Instant::now();
        floor(20).unwrap();
        assert!(t.elapsed() >= Duration::from_millis(21));
    }
}
