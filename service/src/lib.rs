//! The Lumen daemon as a library: what `lumen serve` runs, and what a program that embeds the
//! daemon links. It depends on the wire (`lumen-proto`), the pipeline (`lumen-detect`) and what
//! both sides of the IPC agree on (`lumen-transport`), and on nothing a client, a benchmark or
//! a report needs.
//!
//! - [`config`]: the TOML configuration and its limits.
//! - [`access`]: who may do what over zenoh with client certificates (zenoh ACL + our checks).
//! - [`daemon`]: starts the transports over one [`registry`], stops on SIGINT/SIGTERM.
//! - [`local`] (iceoryx2) and [`remote`] (zenoh): the transports.
//! - [`control`]: open / describe / observe / close / status, the same on both.
//! - [`places`] (counted, lapsing) and [`observe`] (their asks answered): zenoh observers.
//! - [`engine`]: one session's frame processing (check, detect, reply).
//! - [`stats`]: per-session figures for `lumen status`.
//! - [`error`]: [`DaemonError`], the one error type of this crate.

pub mod access;
pub mod config;
pub mod control;
pub mod daemon;
pub mod engine;
pub mod error;
pub mod local;
pub mod observe;
pub mod places;
pub mod registry;
pub mod remote;
pub mod spec_json;
pub mod stats;

pub use config::ServeConfig;
pub use daemon::{Daemon, Running};
pub use error::DaemonError;
