//! The README's and the guide's snippets, for real (the Rust ones are `lumen-e2e`'s doctests;
//! the Python one is `client/python/tests/test_guide.py`):
//!
//! - every `lumen` command line of their `sh` blocks parses with the real command line's parser
//!   (`lumen ...`, `target/release/lumen ...` or `cargo run ... --bin lumen -- ...`);
//! - the README names the two commands, and the test command's script exists;
//! - the C snippet of `docs/guide/integrating.md`, compiled as C and as C++ against
//!   `client/c/include/lumen.h` and `liblumen_c.a`, and the C# one, compiled with Mono's `mcs`
//!   beside `client/csharp/Lumen.cs`, run a session against a real `lumen serve`, and every
//!   contact they are handed is the straight tube's closed form;
//! - the lab's configuration file (`docs/guide/lab.md`) is one the daemon reads and accepts;
//! - the README, the guide and the crates' READMEs name no issue number and no commit id.
//!
//! Snippets are found by the `<!-- tested: NAME -->` marker before their block
//! ([`lumen_e2e::snippet`]): a missing marker fails the test.

use clap::error::ErrorKind;
use clap::Parser;
use lumen_cli::commands::Cli;
use lumen_e2e::{lumen_c_library, snippet, unique_prefix, Daemon};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const LUMEN: &str = env!("CARGO_BIN_EXE_lumen");

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the workspace root").to_path_buf()
}

/// The README and the guide's pages, the README first.
fn pages() -> Vec<PathBuf> {
    let mut guide: Vec<PathBuf> =
        std::fs::read_dir(root().join("docs/guide")).expect("docs/guide").map(|e| e.expect("a guide entry").path()).filter(|p| p.extension().is_some_and(|x| x == "md")).collect();
    guide.sort();
    for page in ["README.md", "getting-started.md", "tube-model.md", "your-colon.md", "integrating.md", "protocol.md", "lab.md", "performance.md"] {
        assert!(guide.iter().any(|p| p.ends_with(page)), "docs/guide/{page} is missing");
    }
    std::iter::once(root().join("README.md")).chain(guide).collect()
}

/// The command lines of `text`'s `sh` blocks, with the line number each starts on: lines
/// ending in `\` joined with the next.
fn shell_lines(text: &str) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut in_sh = false;
    // A line ending in `\` so far: where it started and its text.
    let mut pending: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        let fence = line.trim_start();
        if fence.starts_with("```") {
            in_sh = !in_sh && (fence == "```sh" || fence == "```bash" || fence == "```shell");
            continue;
        }
        if !in_sh {
            continue;
        }
        let (start, mut joined) = pending.take().unwrap_or((i + 1, String::new()));
        let line = line.trim();
        match line.strip_suffix('\\') {
            Some(part) => {
                joined.push_str(part);
                joined.push(' ');
                pending = Some((start, joined));
            }
            None => {
                joined.push_str(line);
                out.push((start, joined));
            }
        }
    }
    out
}

/// The commands of a shell line, each as its words: quotes removed, a comment dropped, split at
/// `&&`, `||`, `;`, `|` and `&`.
fn commands(line: &str) -> Vec<Vec<String>> {
    let (mut all, mut words, mut word, mut quote, mut in_word) = (Vec::new(), Vec::new(), String::new(), None::<char>, false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.push(c),
            (None, '\'' | '"') => {
                quote = Some(c);
                in_word = true;
            }
            (None, '#') if !in_word => break,
            (None, c) if c.is_whitespace() || matches!(c, ';' | '|' | '&') => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
                if matches!(c, ';' | '|' | '&') {
                    while chars.peek().is_some_and(|n| matches!(n, '|' | '&')) {
                        chars.next();
                    }
                    all.push(std::mem::take(&mut words));
                }
            }
            (None, c) => {
                word.push(c);
                in_word = true;
            }
        }
    }
    if in_word {
        words.push(word);
    }
    all.push(words);
    all.retain(|w| !w.is_empty());
    all
}

/// The arguments given to `lumen` by a command: after the word `lumen` (or a path ending in
/// `/lumen`), or after `--` of a `cargo run` of the binary `lumen`. `None` if it runs no lumen.
fn lumen_args(words: &[String]) -> Option<Vec<String>> {
    if words.first().is_some_and(|w| w == "cargo") {
        // `cargo build ... --bin lumen` runs nothing.
        let run = words.get(1).is_some_and(|w| w == "run") && words.windows(2).any(|w| w[0] == "--bin" && w[1] == "lumen");
        let dash = words.iter().position(|w| w == "--")?;
        return run.then(|| words[dash + 1..].to_vec());
    }
    let at = words.iter().position(|w| w == "lumen" || w.ends_with("/lumen"))?;
    Some(words[at + 1..].to_vec())
}

#[test]
fn every_lumen_command_line_in_the_readme_and_the_guide_parses() {
    let mut checked = 0;
    let mut failures = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("a page");
        let name = page.strip_prefix(root()).unwrap_or(&page).display().to_string();
        for (line, shell) in shell_lines(&text) {
            for words in commands(&shell) {
                let Some(args) = lumen_args(&words) else { continue };
                checked += 1;
                match Cli::try_parse_from(std::iter::once("lumen".to_string()).chain(args)) {
                    Ok(_) => {}
                    Err(e) if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) => {}
                    Err(e) => failures.push(format!("{name}:{line}: `{}` does not parse:\n{}", words.join(" "), e.render())),
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(checked >= 30, "only {checked} lumen command lines found in the README and docs/guide: is the extraction broken?");
}

#[test]
fn the_readme_names_the_two_commands_and_the_test_script_exists() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let blocks: Vec<String> = shell_lines(&readme).into_iter().map(|(_, l)| l).collect();
    for command in ["cargo run --release -p lumen-cli --bin lumen -- demo --frames 3000", "bash .ci/test"] {
        assert!(blocks.iter().any(|l| l == command), "the README's sh blocks should hold `{command}` on a line of its own: {blocks:?}");
    }
    assert!(root().join(".ci/test").is_file(), "the README's test command runs .ci/test, which is missing");
    let lines = readme.lines().count();
    assert!(lines <= 150, "the README is {lines} lines: a newcomer's page is at most 150 (the rest belongs in docs/guide)");
}

/// The straight tube of `client/c/examples/straight_tube_scene.h` (radius 10, 32 spokes, 11
/// rings 10 apart along x) and a rod of radius 2 (7 points from x = 20 to 80) 8.5 off the axis
/// along +y: 25 contacts a frame, each `2 - (10 cos(pi / 32) - 8.5)` deep.
const SPEC: &str = r#"{"bodies":[{"name":"colon","shape":{"tube":{"rings":11,"spokes":32}}},{"name":"scope","shape":{"rod":{"points":7,"radius":[2.0]}}}],"pairs":[{"a":"scope","b":"colon","kind":"interior"}],"precision":4}"#;
const FRAMES: usize = 100;
const CONTACTS: usize = 25;

fn integrating() -> PathBuf {
    root().join("docs/guide/integrating.md")
}

/// The C snippet inside a program that supplies what it uses (`spec`, `write_state`,
/// `push_out`) and prints how many contacts it was handed and how many were wrong.
fn c_program() -> String {
    let (code, line) = snippet(&integrating(), "c");
    let spec = SPEC.replace('"', "\\\"");
    format!(
        r#"#include "lumen.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char spec[] = "{spec}";
static size_t pushed, wrong;

static void write_state(float *frame, size_t floats) {{
    if (floats != 11 * 33 * 3 + 7 * 3) {{
        fprintf(stderr, "the frame has %zu floats\n", floats);
        exit(2);
    }}
    float *p = frame;
    for (int i = 0; i < 11; i++) {{
        *p++ = (float)(i * 10.0); *p++ = 0.0f; *p++ = 0.0f;
        for (int k = 0; k < 32; k++) {{
            double a = 2.0 * 3.14159265358979323846 * (k + 0.5) / 32;
            *p++ = 0.0f; *p++ = (float)(10.0 * cos(a)); *p++ = (float)(10.0 * sin(a));
        }}
    }}
    for (int j = 0; j < 7; j++) {{
        *p++ = (float)(20.0 + j * 10.0); *p++ = 8.5f; *p++ = 0.0f;
    }}
}}

static void push_out(const LumenContact *c) {{
    double expected = 2.0 - (10.0 * cos(3.14159265358979323846 / 32) - 8.5);
    pushed++;
    if (fabs(c->depth - expected) > 1e-3 || fabs(c->normal[1] - 1.0f) > 1e-3) wrong++;
}}

static int simulate(void) {{
#line {line} "{file}"
{code}
    return 0;
}}

int main(void) {{
    int rc = simulate();
    printf("rc %d pushed %zu wrong %zu\n", rc, pushed, wrong);
    return rc != 0 || wrong != 0;
}}
"#,
        file = integrating().display()
    )
}

/// Compiles `source` with `compiler` and `flags` against `lumen.h` and `liblumen_c.a`.
fn build_c(compiler: &str, flags: &[&str], source: &str, name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(unique_prefix(name));
    std::fs::create_dir_all(&dir).expect("a build folder");
    let exe = dir.join(name);
    let built = Command::new(compiler)
        .args(flags)
        .arg("-I")
        .arg(root().join("client/c/include"))
        .arg("-")
        // The language flag above is for the program on stdin alone.
        .args(["-x", "none"])
        .arg(lumen_c_library("liblumen_c.a"))
        // What the Rust standard library needs from the system (`rustc --print native-static-libs`).
        .args(["-lgcc_s", "-lutil", "-lrt", "-lpthread", "-lm", "-ldl", "-lc", "-o"])
        .arg(&exe)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .and_then(|mut child| {
            use std::io::Write;
            child.stdin.take().expect("stdin").write_all(source.as_bytes())?;
            child.wait_with_output()
        })
        .unwrap_or_else(|e| panic!("running {compiler}: {e}"));
    assert!(built.status.success(), "{compiler} failed on the guide's snippet:\n{}\n--- the program:\n{source}", String::from_utf8_lossy(&built.stderr));
    exe
}

/// Asserts the program ran its session through and was handed every frame's contacts, right.
fn expect_every_contact(what: &str, run: &Output) {
    let (stdout, stderr) = (String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    let want = format!("pushed {} wrong 0", FRAMES * CONTACTS);
    assert!(run.status.success() && stdout.contains(&want), "the guide's {what} snippet: {} (want `{want}`):\n{stdout}{stderr}", run.status);
}

#[test]
fn the_guides_c_snippet_runs_a_session_as_c_and_as_cpp() {
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("guide_c"), None, &[]);
    let program = c_program();
    let c = build_c(&std::env::var("CC").unwrap_or_else(|_| "cc".into()), &["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-x", "c"], &program, "guide_c");
    let cpp = build_c(&std::env::var("CXX").unwrap_or_else(|_| "c++".into()), &["-std=c++17", "-Wall", "-Wextra", "-Werror", "-x", "c++"], &program, "guide_cpp");
    for (what, exe) in [("C", c), ("C++ (the C snippet)", cpp)] {
        let run = Command::new(&exe).env("LUMEN_IOX2_PREFIX", &daemon.prefix).output().expect("running the snippet");
        assert!(String::from_utf8_lossy(&run.stdout).starts_with("rc 0 "), "the {what} snippet returned early: {run:?}");
        expect_every_contact(what, &run);
    }
}

#[test]
fn the_guides_csharp_snippet_runs_a_session() {
    let (code, line) = snippet(&integrating(), "csharp");
    let program = format!(
        r#"using System;
using Lumen;

static class GuideSnippet
{{
    static int pushed, wrong;

    static void WriteState(float[] s)
    {{
        int p = 0;
        for (int i = 0; i < 11; i++)
        {{
            s[p++] = i * 10.0f; s[p++] = 0; s[p++] = 0;
            for (int k = 0; k < 32; k++)
            {{
                double a = 2.0 * Math.PI * (k + 0.5) / 32;
                s[p++] = 0; s[p++] = (float)(10.0 * Math.Cos(a)); s[p++] = (float)(10.0 * Math.Sin(a));
            }}
        }}
        for (int j = 0; j < 7; j++) {{ s[p++] = 20.0f + j * 10.0f; s[p++] = 8.5f; s[p++] = 0; }}
    }}

    static void Push(Contact c)
    {{
        double expected = 2.0 - (10.0 * Math.Cos(Math.PI / 32) - 8.5);
        pushed++;
        if (Math.Abs(c.Depth - expected) > 1e-3) wrong++;
    }}

    static int Main()
    {{
        string specJson = "{spec}";
        float[] state = new float[11 * 33 * 3 + 7 * 3];
#line {line} "{file}"
{code}
#line default
        Console.WriteLine("pushed " + pushed + " wrong " + wrong);
        return wrong == 0 ? 0 : 1;
    }}
}}
"#,
        spec = SPEC.replace('"', "\\\""),
        file = integrating().display()
    );
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(unique_prefix("guide_cs"));
    std::fs::create_dir_all(&dir).expect("a build folder");
    let (source, exe) = (dir.join("GuideSnippet.cs"), dir.join("GuideSnippet.exe"));
    std::fs::write(&source, &program).expect("writing the program");
    let built = Command::new("mcs")
        .arg(format!("-out:{}", exe.display()))
        .arg("-warnaserror")
        .arg(root().join("client/csharp/Lumen.cs"))
        .arg(&source)
        .output()
        .unwrap_or_else(|e| panic!("running mcs ({e}): install Mono's compiler and runtime (apt-get install mono-mcs mono-runtime; bash .ci/test does)"));
    assert!(built.status.success(), "mcs failed on the guide's C# snippet:\n{}{}\n--- the program:\n{program}", String::from_utf8_lossy(&built.stdout), String::from_utf8_lossy(&built.stderr));
    let daemon = Daemon::start(Path::new(LUMEN), &unique_prefix("guide_cs"), None, &[]);
    let so = lumen_c_library("liblumen_c.so");
    let run =
        Command::new("mono").arg(&exe).env("LD_LIBRARY_PATH", so.parent().expect("its folder")).env("LUMEN_IOX2_PREFIX", &daemon.prefix).output().expect("running mono (apt-get install mono-runtime)");
    expect_every_contact("C#", &run);
}

#[test]
fn the_labs_configuration_file_is_one_the_daemon_accepts() {
    let (toml, _) = snippet(&root().join("docs/guide/lab.md"), "toml");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(unique_prefix("guide_toml"));
    std::fs::create_dir_all(&dir).expect("a folder");
    // The certificate files it names, in a folder of their own (the daemon checks they exist).
    let mut text = toml.clone();
    for file in ["server.pem", "server.key", "ca.pem"] {
        assert!(toml.contains(&format!("\"{file}\"")), "the lab's configuration no longer names {file}: update this test");
        std::fs::write(dir.join(file), "").expect("a PEM file");
        text = text.replace(&format!("\"{file}\""), &format!("\"{}\"", dir.join(file).display()));
    }
    let path = dir.join("lumen.toml");
    std::fs::write(&path, text).expect("writing lumen.toml");
    let config = lumen_service::config::ServeConfig::from_file(&path).unwrap_or_else(|e| panic!("docs/guide/lab.md's configuration: {e}"));
    config.validate().unwrap_or_else(|e| panic!("docs/guide/lab.md's configuration is refused: {e}"));
    assert_eq!(config.iceoryx2.prefix.as_deref(), Some("lab_"));
    assert_eq!(config.zenoh.name.as_deref(), Some("gpu-1"));
    assert_eq!(config.zenoh.access.iter().map(|g| g.name.as_str()).collect::<Vec<_>>(), ["physics-a", "tutor"]);
    assert!(config.policy().expect("a valid policy").is_some(), "client certificates are required");
}

/// Where `text` names an issue by its number ("issue", a space or `#`, digits) or holds a word
/// that looks like a commit id (7 to 12 hex digits, with a digit and a letter): `line: word` each.
fn history_words(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let lower = line.to_lowercase();
        let mut rest = lower.as_str();
        while let Some(at) = rest.find("issue") {
            let after = rest[at + 5..].trim_start_matches(['s', ' ', '#']);
            if after.starts_with(|c: char| c.is_ascii_digit()) {
                found.push(format!("{}: {}", i + 1, line.trim()));
            }
            rest = &rest[at + 5..];
        }
        for word in line.split(|c: char| !c.is_ascii_alphanumeric()) {
            let hex = (7..=12).contains(&word.len()) && word.chars().all(|c| c.is_ascii_digit() || ('a'..='f').contains(&c));
            if hex && word.chars().any(|c| c.is_ascii_digit()) && word.chars().any(|c| c.is_ascii_alphabetic()) {
                found.push(format!("{}: {word}", i + 1));
            }
        }
    }
    found
}

#[test]
fn the_readme_the_guide_and_the_crates_readmes_name_no_issue_and_no_commit() {
    let crates = ["proto", "detect", "transport", "client", "client/c", "client/csharp", "client/python", "service", "import", "scene", "sim", "view", "bench", "cli", "tests"];
    let readmes = crates.iter().map(|c| root().join(c).join("README.md")).filter(|p| p.is_file());
    let mut found = Vec::new();
    for page in pages().into_iter().chain(readmes) {
        let text = std::fs::read_to_string(&page).expect("a page");
        let name = page.strip_prefix(root()).unwrap_or(&page).display().to_string();
        found.extend(history_words(&text).into_iter().map(|w| format!("{name}:{w}")));
    }
    assert!(found.is_empty(), "history belongs in docs/measurements.md or docs/decisions/ (dated, with the command), not here:\n{}", found.join("\n"));
    // Split so that this file names none itself.
    let sample = ["at 0a1b", "2c3, iss", "ue 12's limit, Iss", "ue #3"].concat();
    assert_eq!(history_words(&sample).len(), 3, "the check itself finds them in {sample:?}");
}
