//! Benchmarks behind `lumen bench`.

pub mod ipc;
pub mod scene;
