//! `examples/straight_tube.c` compiled with the system's C compiler against `liblumen_c.a`
//! (which cargo builds beside this test, the crate being a `staticlib`), then run: it checks
//! every contact against the closed form and exits non-zero on any mismatch.

use std::path::{Path, PathBuf};
use std::process::Command;

/// `liblumen_c.a`, from the `deps` folder this test runs in or the profile folder above it.
fn static_library() -> PathBuf {
    let exe = std::env::current_exe().expect("the test's own path");
    let deps = exe.parent().expect("the deps folder");
    [deps, deps.parent().expect("the profile folder")]
        .iter()
        .map(|d| d.join("liblumen_c.a"))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("liblumen_c.a is neither in {} nor above it", deps.display()))
}

#[test]
fn the_c_example_builds_runs_and_matches_the_closed_form() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = Path::new(env!("CARGO_TARGET_TMPDIR")).join("straight_tube");
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let built = Command::new(&cc)
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O1", "-I"])
        .arg(dir.join("include"))
        .arg(dir.join("examples/straight_tube.c"))
        .arg(static_library())
        // What the Rust standard library needs from the system (`rustc --print native-static-libs`).
        .args(["-lgcc_s", "-lutil", "-lrt", "-lpthread", "-lm", "-ldl", "-lc", "-o"])
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("running {cc}: {e}"));
    assert!(built.status.success(), "{cc} failed:\n{}", String::from_utf8_lossy(&built.stderr));
    let ran = Command::new(&exe).output().expect("running the example");
    let (stdout, stderr) = (String::from_utf8_lossy(&ran.stdout), String::from_utf8_lossy(&ran.stderr));
    assert!(ran.status.success(), "the example failed ({}):\n{stdout}{stderr}", ran.status);
    for line in [
        "frame 0: offset 8.50: 25 contacts",
        "frame 1: offset 9.00: 25 contacts",
        "frame 2: offset 0.00: 0 contacts",
        "short state refused: state: state has 1109 floats; the scene's layout needs exactly 1110",
        "ok",
    ] {
        assert!(stdout.lines().any(|l| l.starts_with(line)), "no line starting {line:?} in:\n{stdout}");
    }
}
