//! The house's rules, checked over `cargo metadata` so they stay true (the root README's
//! layout section states them):
//!
//! - every arrow points down: no workspace crate depends, even as a dev-dependency, on a crate
//!   that depends on it (the graph of normal, build and dev edges between members is acyclic);
//! - the daemon library does not depend on the client library, nor on plotting, progress bars,
//!   MCAP, the physics or the benchmark;
//! - `lumen-detect` depends on `lumen-proto` alone among the workspace's crates, plus its math
//!   and data crates;
//! - `lumen-client` and `lumen-service` share their transport through `lumen-transport`,
//!   neither importing the other;
//! - the README's layout table names every crate and its folder, and nothing else.

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the workspace root").to_path_buf()
}

/// The workspace as cargo sees it: each member's name, folder (relative to the root) and
/// direct dependencies with their kinds (`normal`, `dev`, `build`), from `cargo metadata
/// --no-deps`; and every package's resolved dependencies from `Cargo.lock` (a running
/// `cargo test` holds the package cache, so a resolving `cargo metadata` would wait on it).
struct Workspace {
    folders: BTreeMap<String, String>,
    /// member -> (dependency name, kind)
    direct: BTreeMap<String, Vec<(String, String)>>,
    /// any package name -> names of its locked dependencies (every kind; see `closure`)
    locked: BTreeMap<String, BTreeSet<String>>,
}

fn workspace() -> Workspace {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo).args(["metadata", "--format-version", "1", "--no-deps", "--offline", "--manifest-path"]).arg(root().join("Cargo.toml")).output().expect("running cargo metadata");
    assert!(out.status.success(), "cargo metadata failed: {}", String::from_utf8_lossy(&out.stderr));
    let meta: Value = serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON");
    let mut folders = BTreeMap::new();
    let mut direct = BTreeMap::new();
    for p in meta["packages"].as_array().unwrap() {
        let name = p["name"].as_str().unwrap().to_owned();
        let manifest = Path::new(p["manifest_path"].as_str().unwrap());
        let folder = manifest.parent().unwrap().strip_prefix(root()).unwrap().to_string_lossy().into_owned();
        folders.insert(name.clone(), folder);
        let deps = p["dependencies"].as_array().unwrap().iter().map(|d| (d["name"].as_str().unwrap().to_owned(), d["kind"].as_str().unwrap_or("normal").to_owned())).collect();
        direct.insert(name, deps);
    }
    Workspace { folders, direct, locked: lock_graph() }
}

/// `Cargo.lock`'s graph: each package's name and the names of the packages it depends on.
fn lock_graph() -> BTreeMap<String, BTreeSet<String>> {
    let lock = std::fs::read_to_string(root().join("Cargo.lock")).expect("Cargo.lock");
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for package in lock.split("[[package]]").skip(1) {
        let name = package.lines().find_map(|l| l.strip_prefix("name = ")).expect("a package name").trim_matches('"').to_owned();
        let deps: BTreeSet<String> = match package.split("dependencies = [").nth(1) {
            // Entries are "name" or "name version" (when two versions are locked).
            Some(list) => {
                list.split(']').next().unwrap().lines().map(|l| l.trim().trim_end_matches(',').trim_matches('"')).filter(|l| !l.is_empty()).map(|l| l.split(' ').next().unwrap().to_owned()).collect()
            }
            None => BTreeSet::new(),
        };
        graph.entry(name).or_default().extend(deps);
    }
    graph
}

impl Workspace {
    /// Every package `name` pulls in when built as a library: its own normal and build
    /// dependencies, then everything those lock in (the lock file does not say which edges of
    /// a third-party crate are dev-only, and a published crate's dev-dependencies are not in
    /// it; the workspace's members are followed by their normal and build edges alone).
    fn closure(&self, name: &str) -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut todo = vec![name.to_owned()];
        while let Some(n) = todo.pop() {
            let next: Vec<String> = match self.direct.get(&n) {
                Some(deps) => deps.iter().filter(|(_, kind)| kind != "dev").map(|(d, _)| d.clone()).collect(),
                None => self.locked.get(&n).into_iter().flatten().cloned().collect(),
            };
            for d in next {
                if seen.insert(d.clone()) {
                    todo.push(d);
                }
            }
        }
        seen
    }

    /// Workspace members `name` depends on directly, with every kind.
    fn member_deps(&self, name: &str) -> Vec<(String, String)> {
        self.direct[name].iter().filter(|(d, _)| self.folders.contains_key(d)).cloned().collect()
    }
}

#[test]
fn every_arrow_points_down() {
    let ws = workspace();
    // Depth-first search for a cycle over members, every dependency kind included.
    fn visit(ws: &Workspace, n: &str, path: &mut Vec<String>, done: &mut BTreeSet<String>) {
        if done.contains(n) {
            return;
        }
        if let Some(at) = path.iter().position(|p| p == n) {
            panic!("dependency cycle: {} -> {n}", path[at..].join(" -> "));
        }
        path.push(n.to_owned());
        for (d, _) in ws.member_deps(n) {
            visit(ws, &d, path, done);
        }
        path.pop();
        done.insert(n.to_owned());
    }
    let mut done = BTreeSet::new();
    for n in ws.folders.keys() {
        visit(&ws, n, &mut Vec::new(), &mut done);
    }
    assert_eq!(done.len(), ws.folders.len());
}

#[test]
fn the_daemon_links_no_client_plot_progress_recording_physics_or_benchmark() {
    let ws = workspace();
    let pulled = ws.closure("lumen-service");
    for banned in ["lumen-client", "plotters", "indicatif", "mcap", "lumen-sim", "lumen-bench", "lumen-scene", "lumen-cli", "clap"] {
        assert!(!pulled.contains(banned), "lumen-service pulls in {banned}");
    }
    assert!(pulled.contains("lumen-transport") && pulled.contains("lumen-detect"), "the daemon is built on the transport and the pipeline: {pulled:?}");
}

#[test]
fn the_pipeline_depends_on_the_wire_alone() {
    let ws = workspace();
    let members: Vec<_> = ws.member_deps("lumen-detect");
    assert_eq!(members, vec![("lumen-proto".to_owned(), "normal".to_owned())], "lumen-detect's workspace dependencies");
    let allowed = ["lumen-proto", "nalgebra", "serde", "postcard", "thiserror"];
    for (d, kind) in &ws.direct["lumen-detect"] {
        assert!(allowed.contains(&d.as_str()), "lumen-detect depends on {d} ({kind}); allowed: {allowed:?}");
    }
}

#[test]
fn client_and_daemon_meet_only_in_the_transport() {
    let ws = workspace();
    assert!(!ws.closure("lumen-client").contains("lumen-service"), "the client links the daemon");
    assert!(!ws.closure("lumen-service").contains("lumen-client"), "the daemon links the client");
    for side in ["lumen-client", "lumen-service"] {
        assert!(ws.member_deps(side).iter().any(|(d, _)| d == "lumen-transport"), "{side} does not use lumen-transport");
    }
    let proto = ws.closure("lumen-proto");
    assert!(!proto.iter().any(|d| d.starts_with("lumen-") || d == "zenoh" || d == "tokio"), "lumen-proto (no I/O) pulls in {proto:?}");
}

#[test]
fn the_readme_layout_names_every_crate_and_its_folder() {
    let ws = workspace();
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let section = readme.split("\n## Layout").nth(1).expect("a Layout section in README.md");
    let section = section.split("\n## ").next().unwrap();
    // Rows of the table: | `folder/` | `crate` | holds | may import |
    let mut rows = BTreeMap::new();
    for line in section.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let folder = cells[1].trim_matches('`').trim_end_matches('/').to_owned();
        let krate = cells[2].trim_matches('`').to_owned();
        rows.insert(krate, folder);
    }
    assert_eq!(rows, ws.folders, "the README's layout table (crate -> folder) against the workspace");
}
