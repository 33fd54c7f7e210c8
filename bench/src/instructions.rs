//! Instructions per frame, counted by callgrind: unlike times on a shared machine they do not
//! move with its load. The bench writes the frames one method reads to a file, runs itself on
//! that file under `valgrind --tool=callgrind` collecting only inside [`counted_frame`], and
//! divides the instructions collected by the frames counted.
//!
//! The frames are prepared natively and only read under valgrind: building a colon (or importing
//! the real one) under callgrind would take minutes of its own.

use crate::scenes::SceneData;
use crate::sweep::{spec_for, Runner};
use crate::{Error, MethodKind, Options};
use lumen_detect::SceneSpec;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Frames counted per method (instructions are deterministic: a few frames give the figure).
pub const COUNTED: usize = 16;
/// Frames run first, not counted (the detector's coherence starts from nothing, as when timed).
pub const UNCOUNTED: usize = 2;

/// What a count file holds before its floats (one JSON line).
#[derive(Debug, Serialize, Deserialize)]
struct Header {
    spec: SceneSpec,
    method: String,
    uncounted: usize,
    frames: usize,
    floats: usize,
}

/// One counted frame: the only function callgrind collects in (`--toggle-collect`).
#[inline(never)]
pub(crate) fn counted_frame(runner: &mut Runner, state: &[f32]) -> Result<usize, Error> {
    runner.detect(state)
}

/// Whether `valgrind` runs here.
pub fn available() -> bool {
    Command::new("valgrind").arg("--version").output().is_ok_and(|o| o.status.success())
}

/// Instructions per frame of `method` at precision `x` on `scene`'s first frames, counted in a
/// child process under callgrind; its files go in `dir` and are removed after.
pub fn per_frame(scene: &SceneData, x: u32, method: MethodKind, dir: &Path) -> Result<f64, Error> {
    let frames = (UNCOUNTED + COUNTED).min(scene.frames);
    if frames <= UNCOUNTED {
        return Err(Error::Frames { frames: scene.frames, warmup: UNCOUNTED });
    }
    let stem = dir.join(format!("count-{}-B{}-x{x}-{}", scene.kind.name(), scene.spokes, method.name()));
    let (file, out) = (stem.with_extension("frames"), stem.with_extension("callgrind"));
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&file).map_err(io(&file))?);
        let header = Header { spec: spec_for(scene, x, method), method: method.name().into(), uncounted: UNCOUNTED, frames, floats: scene.floats };
        serde_json::to_writer(&mut w, &header)?;
        w.write_all(b"\n").map_err(io(&file))?;
        for f in 0..frames {
            for v in scene.state(f) {
                w.write_all(&v.to_le_bytes()).map_err(io(&file))?;
            }
        }
        w.flush().map_err(io(&file))?;
    }
    let (exe, prefix) = own_command().map_err(io(Path::new("the running executable")))?;
    let status = Command::new("valgrind")
        .args(["--tool=callgrind", "--quiet", "--toggle-collect=*counted_frame*"])
        .arg(format!("--callgrind-out-file={}", out.display()))
        .arg(exe)
        .args(prefix)
        .arg("--count-file")
        .arg(&file)
        .status()
        .map_err(io(Path::new("valgrind")))?;
    let text = std::fs::read_to_string(&out).unwrap_or_default();
    let _ = (std::fs::remove_file(&file), std::fs::remove_file(&out));
    let ir = parse_total(&text)
        .filter(|_| status.success())
        .ok_or_else(|| Error::Instructions { method: method.name().into(), detail: format!("callgrind exited with {status} and {} bytes of output", text.len()) })?;
    Ok(ir as f64 / (frames - UNCOUNTED) as f64)
}

/// The running executable and its arguments (`lumen bench detect ...` or `lumen-bench ...`):
/// the child parses its parent's command line, `--count-file` appended, so it has the same
/// options and looks at nothing but that file.
fn own_command() -> std::io::Result<(PathBuf, Vec<String>)> {
    Ok((std::env::current_exe()?, std::env::args().skip(1).collect()))
}

/// The total instructions of a callgrind output file (its `totals:` line, else `summary:`).
pub fn parse_total(text: &str) -> Option<u64> {
    let field = |key: &str| text.lines().find_map(|l| l.strip_prefix(key)).and_then(|v| v.split_whitespace().next()?.parse().ok());
    field("totals:").or_else(|| field("summary:"))
}

/// The child's side: reads `path` (written by [`per_frame`]) and runs its frames, the counted
/// ones through [`counted_frame`].
pub fn run_file(path: &Path, opts: &Options) -> Result<(), Error> {
    let io = |source| Error::Read { path: path.to_path_buf(), source };
    let mut r = std::io::BufReader::new(std::fs::File::open(path).map_err(io)?);
    let mut line = String::new();
    r.read_line(&mut line).map_err(io)?;
    let h: Header = serde_json::from_str(&line)?;
    let method = MethodKind::parse(&h.method).ok_or(Error::UnknownMethod { name: h.method.clone() })?;
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut r, &mut bytes).map_err(io)?;
    if bytes.len() != h.frames * h.floats * 4 {
        return Err(Error::Instructions { method: h.method, detail: format!("{} holds {} bytes of frames; its header says {} frames of {} floats", path.display(), bytes.len(), h.frames, h.floats) });
    }
    let states: Vec<f32> = bytes.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes"))).collect();
    let state = |f: usize| &states[f * h.floats..(f + 1) * h.floats];
    // The child parsed its parent's command line, so `opts` are the parent's (parry's shape).
    let mut runner = Runner::new(&h.spec, state(0), method, opts)?;
    for f in 0..h.frames {
        let n = if f < h.uncounted { runner.detect(state(f))? } else { counted_frame(&mut runner, state(f))? };
        std::hint::black_box(n);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn totals_are_read_from_callgrinds_output() {
        let text = "# callgrind format\nversion: 1\ncreator: callgrind-3.19.0\ncmd: x\nevents: Ir\nfn=(1) main\n3 5\nsummary: 123456\ntotals: 98765\n";
        assert_eq!(parse_total(text), Some(98765));
        assert_eq!(parse_total("events: Ir\nsummary: 42\n"), Some(42));
        assert_eq!(parse_total("events: Ir\n"), None);
        assert_eq!(parse_total("totals: many\n"), None);
    }
}
