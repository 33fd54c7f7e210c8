//! Midlines from CSV and JSON files.

use crate::ImportError;
use std::path::Path;

/// A midline: points in order, and what else the file gave.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Centerline {
    pub points: Vec<[f32; 3]>,
    /// Arc length per point, when the file has it (column `s` / `s_mm`).
    pub s: Option<Vec<f32>>,
    /// Median lumen radius per point, when the file has it (column `r_median` /
    /// `r_median_mm`); `NaN` where the file says so.
    pub radius_median: Option<Vec<f32>>,
}

impl Centerline {
    /// Polyline length.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| (0..3).map(|d| (w[1][d] as f64 - w[0][d] as f64).powi(2)).sum::<f64>().sqrt()).sum()
    }
}

/// Writes `line` as CSV with a header: `s_mm,x_mm,y_mm,z_mm` (`s_mm` only when the line has
/// arc lengths), one point per row, which [`parse_centerline_csv`] reads back exactly.
pub fn write_centerline_csv(line: &Centerline, out: &mut impl std::io::Write) -> std::io::Result<()> {
    match &line.s {
        Some(s) => {
            writeln!(out, "s_mm,x_mm,y_mm,z_mm")?;
            for (p, s) in line.points.iter().zip(s) {
                writeln!(out, "{s},{},{},{}", p[0], p[1], p[2])?;
            }
        }
        None => {
            writeln!(out, "x_mm,y_mm,z_mm")?;
            for p in &line.points {
                writeln!(out, "{},{},{}", p[0], p[1], p[2])?;
            }
        }
    }
    Ok(())
}

/// Loads a midline by extension: `.csv` and `.txt` as [`load_centerline_csv`] reads them,
/// `.json` as [`parse_centerline_json`]; other files are JSON when they start with `[` or `{`,
/// else CSV. Errors name the file.
pub fn load_centerline(path: impl AsRef<Path>) -> Result<Centerline, ImportError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| ImportError::Io(path.display().to_string(), e))?;
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    let json = match ext.as_deref() {
        Some("csv" | "txt") => false,
        Some("json") => true,
        _ => text.trim_start().starts_with(['[', '{']),
    };
    if json { parse_centerline_json(&text) } else { parse_centerline_csv(&text) }.map_err(|e| e.in_file(path))
}

/// Loads a midline CSV as written for the GCA colon (`centerline_mm.csv`): lines starting with
/// `#` are comments; the column names come from the first comment or text line that names
/// columns (`s_mm,x_mm,y_mm,z_mm,...`; a `_mm` suffix is ignored), and `x`, `y`, `z` are
/// required there. Without a header, 3 columns are `x y z` and 4 or more `s x y z ...`. Fields
/// are separated by commas (or, if a line has none, by whitespace); `NaN` is accepted in
/// columns other than the coordinates.
pub fn load_centerline_csv(path: impl AsRef<Path>) -> Result<Centerline, ImportError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| ImportError::Io(path.display().to_string(), e))?;
    parse_centerline_csv(&text).map_err(|e| e.in_file(path))
}

fn fields(s: &str) -> Vec<&str> {
    if s.contains(',') {
        s.split(',').map(str::trim).collect()
    } else {
        s.split_whitespace().collect()
    }
}

fn perr(line: usize, message: impl Into<String>) -> ImportError {
    ImportError::Parse { file: String::new(), line, message: message.into() }
}

/// [`load_centerline_csv`] on text.
pub fn parse_centerline_csv(text: &str) -> Result<Centerline, ImportError> {
    let mut names: Option<Vec<String>> = None;
    let mut rows: Vec<(usize, Vec<f64>)> = Vec::new();
    for (ln, raw) in text.lines().enumerate() {
        let line = ln + 1;
        let t = raw.trim();
        if t.is_empty() {
            continue;
        }
        let (body, comment) = match t.strip_prefix('#') {
            Some(rest) => (rest.trim(), true),
            None => (t, false),
        };
        let f = fields(body);
        let numeric = f.iter().all(|x| x.parse::<f64>().is_ok());
        if names.is_none() && rows.is_empty() && !numeric {
            let cand: Vec<String> = f.iter().map(|x| x.to_ascii_lowercase().trim_end_matches("_mm").to_string()).collect();
            if ["x", "y", "z"].iter().all(|n| cand.iter().any(|c| c == n)) {
                names = Some(cand);
                continue;
            }
        }
        if comment {
            continue;
        }
        if !numeric {
            return Err(perr(line, format!("expected numbers, got {t:?}")));
        }
        rows.push((line, f.iter().map(|x| x.parse::<f64>().unwrap()).collect()));
    }
    if rows.len() < 2 {
        return Err(perr(0, format!("{} data rows; a midline needs at least 2", rows.len())));
    }
    let width = rows[0].1.len();
    let names = names.unwrap_or_else(|| match width {
        3 => vec!["x".into(), "y".into(), "z".into()],
        _ => ["s", "x", "y", "z"].iter().map(|s| s.to_string()).collect(),
    });
    let col = |n: &str| names.iter().position(|c| c == n);
    let (cx, cy, cz) = match (col("x"), col("y"), col("z")) {
        (Some(x), Some(y), Some(z)) => (x, y, z),
        _ => return Err(perr(0, "no x, y, z columns")),
    };
    let (cs, cr) = (col("s"), col("r_median"));
    let mut out = Centerline::default();
    let mut s = Vec::new();
    let mut r = Vec::new();
    for (line, row) in &rows {
        let get = |c: usize| row.get(c).copied().ok_or_else(|| perr(*line, format!("{} fields; column {} ({}) is missing", row.len(), c + 1, names[c])));
        let p = [get(cx)?, get(cy)?, get(cz)?];
        if !p.iter().all(|v| v.is_finite()) {
            return Err(perr(*line, format!("point is not finite: {p:?}")));
        }
        out.points.push(p.map(|v| v as f32));
        if let Some(c) = cs {
            s.push(get(c)? as f32);
        }
        if let Some(c) = cr {
            r.push(get(c)? as f32);
        }
    }
    out.s = cs.map(|_| s);
    out.radius_median = cr.map(|_| r);
    Ok(out)
}

fn jerr(message: impl Into<String>) -> ImportError {
    ImportError::Format { file: String::new(), message: message.into() }
}

/// Parses a midline from JSON, in the shapes tools write: an array of `[x, y, z]`; an array of
/// objects with `x`, `y`, `z` (or a `position` array); or an object whose `points`,
/// `centerline`, `path` or `markups` field holds one of these (3D Slicer's markups:
/// `{"markups": [{"controlPoints": [{"position": [x, y, z]}, ...]}]}`, the first markup with
/// control points). Coordinates are taken as written (no RAS/LPS flip), in mm. Errors name the
/// point and what was wrong, or the line of a JSON syntax error.
pub fn parse_centerline_json(text: &str) -> Result<Centerline, ImportError> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| perr(e.line(), format!("not JSON: {e}")))?;
    let points = find_points(&value, 0)?;
    let mut out = Centerline::default();
    for (i, p) in points.iter().enumerate() {
        out.points.push(point(p).map_err(|m| jerr(format!("point {i}: {m}")))?);
    }
    if out.points.len() < 2 {
        return Err(jerr(format!("{} points; a midline needs at least 2", out.points.len())));
    }
    Ok(out)
}

/// The array of points in `v`, looking through the fields that hold it.
fn find_points(v: &serde_json::Value, depth: usize) -> Result<&Vec<serde_json::Value>, ImportError> {
    use serde_json::Value;
    const FIELDS: &str = "`points`, `centerline`, `path`, `markups` or `controlPoints`";
    match v {
        // A Slicer `markups` array holds markups, not points: take the first with control points.
        Value::Array(items) if items.first().is_some_and(|m| m.get("controlPoints").is_some()) => {
            let m = items.iter().find(|m| m.get("controlPoints").and_then(Value::as_array).is_some_and(|c| !c.is_empty())).unwrap_or(&items[0]);
            find_points(m, depth + 1)
        }
        Value::Array(items) => Ok(items),
        Value::Object(o) if depth < 4 => {
            let field = ["points", "centerline", "path", "markups", "controlPoints"].iter().find_map(|k| o.get(*k));
            match field {
                Some(f) => find_points(f, depth + 1),
                None => Err(jerr(format!("an object without a points array: expected an array of points or a field {FIELDS}"))),
            }
        }
        other => Err(jerr(format!("expected an array of points or an object with a field {FIELDS}, got {}", kind(other)))),
    }
}

fn kind(v: &serde_json::Value) -> &'static str {
    use serde_json::Value;
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// One point: `[x, y, z]`, `{"x": .., "y": .., "z": ..}` or `{"position": [x, y, z]}`.
fn point(v: &serde_json::Value) -> Result<[f32; 3], String> {
    use serde_json::Value;
    let coord = |c: Option<&Value>, name: &str| -> Result<f32, String> {
        let c = c.ok_or_else(|| format!("no {name}"))?;
        let x = c.as_f64().ok_or_else(|| format!("{name} is {}, expected a number", kind(c)))? as f32;
        if !x.is_finite() {
            return Err(format!("{name} is not finite in single precision: {c}"));
        }
        Ok(x)
    };
    match v {
        Value::Array(a) if a.len() == 3 && a.iter().all(Value::is_number) => Ok([coord(a.first(), "x")?, coord(a.get(1), "y")?, coord(a.get(2), "z")?]),
        Value::Array(a) if a.len() != 3 => Err(format!("expected 3 numbers, got {} values", a.len())),
        Value::Array(_) => Err(format!("expected 3 numbers, got {v}")),
        Value::Object(o) if o.contains_key("position") => point(&o["position"]),
        Value::Object(o) => Ok([coord(o.get("x"), "x")?, coord(o.get("y"), "y")?, coord(o.get("z"), "z")?]),
        other => Err(format!("expected [x, y, z] or an object with x, y, z, got {}", kind(other))),
    }
}
