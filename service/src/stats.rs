//! Per-session figures for `lumen status`, kept in fixed buffers (no allocation per frame).

use lumen_proto::session::Percentiles;
use std::time::Instant;

const RING: usize = 1024;

/// The last [`RING`] values of something, in nanoseconds.
#[derive(Debug, Clone)]
pub struct Ring {
    values: Box<[u32; RING]>,
    len: usize,
    pos: usize,
}

impl Default for Ring {
    fn default() -> Self {
        Self { values: Box::new([0; RING]), len: 0, pos: 0 }
    }
}

impl Ring {
    /// Records one value (ns, saturating at ~4.3 s).
    pub fn push(&mut self, ns: u64) {
        self.values[self.pos] = ns.min(u32::MAX as u64) as u32;
        self.pos = (self.pos + 1) % RING;
        self.len = (self.len + 1).min(RING);
    }

    /// p50 / p99 / p99.9 of the recorded values, in microseconds (zeros when empty).
    pub fn percentiles(&self) -> Percentiles {
        let mut v: Vec<u32> = self.values[..self.len].to_vec();
        v.sort_unstable();
        Percentiles { p50_us: pick(&v, 0.5), p99_us: pick(&v, 0.99), p999_us: pick(&v, 0.999) }
    }
}

/// The value at quantile `q` of sorted nanoseconds, in microseconds.
pub fn pick(sorted: &[u32], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() as f64 * q).ceil() as usize).clamp(1, sorted.len()) - 1;
    sorted[i] as f64 / 1e3
}

/// What one session did.
#[derive(Debug, Clone)]
pub struct Stats {
    pub frames: u64,
    pub bad_frames: u64,
    pub skipped: u64,
    /// Zenoh messages on the frame key without the owner's tag (dropped).
    pub forged: u64,
    pub contacts_last: u32,
    pub contacts_sum: u64,
    pub detect: Ring,
    pub service: Ring,
    /// (time, frames) at the start of the current rate window, and the last rate.
    window: (Instant, u64),
    pub fps: f64,
}

impl Default for Stats {
    fn default() -> Self {
        Self { frames: 0, bad_frames: 0, skipped: 0, forged: 0, contacts_last: 0, contacts_sum: 0, detect: Ring::default(), service: Ring::default(), window: (Instant::now(), 0), fps: 0.0 }
    }
}

impl Stats {
    /// Updates the frame rate over windows of about a second.
    pub fn tick(&mut self, now: Instant) {
        let dt = now.duration_since(self.window.0).as_secs_f64();
        if dt >= 1.0 {
            self.fps = (self.frames - self.window.1) as f64 / dt;
            self.window = (now, self.frames);
        }
    }

    /// Mean contacts per good frame.
    pub fn contacts_mean(&self) -> f64 {
        let good = self.frames - self.bad_frames;
        if good == 0 {
            0.0
        } else {
            self.contacts_sum as f64 / good as f64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_percentiles_over_the_last_values() {
        let mut r = Ring::default();
        assert_eq!(r.percentiles().p50_us, 0.0);
        for i in 1..=2000u64 {
            r.push(i * 1000); // 1..2000 us; only the last 1024 (977..2000) stay
        }
        let p = r.percentiles();
        assert_eq!(p.p50_us, 1488.0);
        assert_eq!(p.p99_us, 1990.0);
        assert_eq!(p.p999_us, 1999.0);
    }
}
