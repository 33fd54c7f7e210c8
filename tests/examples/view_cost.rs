//! What the live view costs the session it watches: `lumen sim` (the colonoscopy against a
//! real daemon) without a view, with `lumen view` and a page drawing in headless Chromium, and
//! with a page held (it never asks for the next frame: a stalled browser), alternated over
//! rounds in one run. Prints the sim's frame rate per run and the medians, the page's frame
//! rate and the WebSocket's bytes per second.
//!
//! `cargo run --release -p lumen-e2e --example view_cost -- [LUMEN_BINARY] [FRAMES] [ROUNDS]`
//! (default `target/release/lumen`, 3000 frames, 3 rounds).

use lumen_e2e::browser::Browser;
use lumen_e2e::{unique_prefix, ChildProcess, Daemon};
use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const WAIT: Duration = Duration::from_secs(120);

#[derive(Clone, Copy, PartialEq, Debug)]
enum Variant {
    NoView,
    Page,
    Held,
}

struct Run {
    fps: f64,
    page_fps: Option<f64>,
    ws: Option<String>,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let lumen = args.get(1).map_or("target/release/lumen", String::as_str).to_owned();
    let frames: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(3000);
    let rounds: usize = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(3);
    let prefix = unique_prefix("viewcost");
    let _daemon = Daemon::start(Path::new(&lumen), &prefix, None, &[]);
    let browser = Browser::launch().expect("headless Chromium");
    let mut results: Vec<(Variant, Run)> = Vec::new();
    for round in 0..rounds {
        for v in [Variant::NoView, Variant::Page, Variant::Held] {
            let r = once(&lumen, &prefix, &browser, frames, v);
            println!("round {round} {v:?}: sim {:.0} frames/s, page {:?} frames/s, {}", r.fps, r.page_fps.map(|f| f.round()), r.ws.as_deref().unwrap_or("-"));
            results.push((v, r));
        }
    }
    for v in [Variant::NoView, Variant::Page, Variant::Held] {
        let mut f: Vec<f64> = results.iter().filter(|r| r.0 == v).map(|r| r.1.fps).collect();
        f.sort_by(f64::total_cmp);
        let mut p: Vec<f64> = results.iter().filter(|r| r.0 == v).filter_map(|r| r.1.page_fps).collect();
        p.sort_by(f64::total_cmp);
        println!("median {v:?}: sim {:.0} frames/s{}", f[f.len() / 2], p.get(p.len() / 2).map_or(String::new(), |x| format!(", page {x:.0} frames/s")));
    }
}

fn once(lumen: &str, prefix: &str, browser: &Browser, frames: u64, v: Variant) -> Run {
    let mut sim = Command::new(lumen);
    sim.args(["sim", "--hold", "--prefix", prefix, "--log", "warn", "--progress-every", "0", "--frames", &frames.to_string()]);
    let mut sim = ChildProcess::spawn(sim);
    let id = sim.line_starting("session ", WAIT).expect("the sim's session").trim_start_matches("session ").trim().to_owned();
    let mut view = None;
    let mut page = None;
    if v != Variant::NoView {
        let mut cmd = Command::new(lumen);
        cmd.args(["view", &id, "--prefix", prefix, "--listen", "127.0.0.1:0", "--log", "warn"]);
        let child = ChildProcess::spawn(cmd);
        let url = child.line_starting("lumen view: serving ", WAIT).expect("the view's address").trim_start_matches("lumen view: serving ").trim().to_owned();
        let mut p = browser.new_page("about:blank").unwrap();
        p.set_viewport(960, 640).unwrap();
        p.navigate(&url).unwrap();
        p.wait_for("window.lumenView && lumenView.scene !== null", WAIT).expect("the page has the scene");
        if v == Variant::Held {
            p.eval("document.getElementById('hold').checked = true; true").unwrap();
        }
        view = Some(child);
        page = Some(p);
    }
    sim.child.stdin.as_mut().expect("piped").write_all(b"go\n").unwrap();
    // The page's own frame count over the middle of the run.
    let mut page_fps = None;
    if let (Some(p), Variant::Page) = (page.as_mut(), v) {
        std::thread::sleep(Duration::from_millis(1500));
        let (n0, t) = (p.eval("lumenView.frames").unwrap().as_f64().unwrap(), Instant::now());
        std::thread::sleep(Duration::from_secs(3));
        let n1 = p.eval("lumenView.frames").unwrap().as_f64().unwrap();
        page_fps = Some((n1 - n0) / t.elapsed().as_secs_f64());
    }
    let summary = sim.line_starting("{\"type\":\"summary\"", Duration::from_secs(600)).expect("the sim's summary");
    let s: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let mut ws = None;
    if let Some(mut child) = view {
        // The session ended: the view says what it sent and exits.
        ws = child.line_starting("lumen view: sent ", WAIT).map(|l| l.trim_start_matches("lumen view: ").to_owned());
        child.wait_exit(Duration::from_secs(10));
    }
    sim.wait_exit(Duration::from_secs(10));
    Run { fps: s["physics_fps"].as_f64().unwrap(), page_fps, ws }
}
