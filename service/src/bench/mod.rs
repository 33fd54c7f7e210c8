//! Benchmarks behind `lumen bench`.

pub mod ipc;
pub mod scene;
pub mod wake;
