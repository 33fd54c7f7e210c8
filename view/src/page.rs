//! The page, built into the binary so `lumen view` needs no files beside it and fetches
//! nothing at run time: plain WebGL2 and WebXR, no framework (three.js would need npm to build
//! `lumen`).

/// `/`: the page, its panel and controls.
pub const INDEX_HTML: &str = include_str!("../page/index.html");
/// `/view.js`: the client: socket, decoding, drawing, camera, panel, playback, VR.
pub const VIEW_JS: &str = include_str!("../page/view.js");
