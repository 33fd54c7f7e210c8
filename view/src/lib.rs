#![doc = include_str!("../README.md")]
//!
//! ## Modules
//! - [`stream`]: what a page is sent (the scene, then frames carrying only what changed).
//! - [`server`]: the page over HTTP and a WebSocket per page, newest wins.
//! - [`page`]: the page itself (HTML and JavaScript, WebGL2 and WebXR), built into the binary.

pub mod page;
pub mod server;
pub mod stream;

pub use server::{Control, Counters, Viewer};
pub use stream::{SceneInfo, Snapshot, Source, Stats};

/// What can go wrong starting the view.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The address could not be listened on.
    #[error("the view cannot listen on {addr}: {source}")]
    Bind { addr: String, source: std::io::Error },
    /// No thread could be started for the server.
    #[error("the view cannot start its server thread: {0}")]
    Thread(std::io::Error),
}
