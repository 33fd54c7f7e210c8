//! Midlines from CSV files.

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

/// Loads a midline CSV as written for the GCA colon (`centerline_mm.csv`): lines starting with
/// `#` are comments; the column names come from the first comment or text line that names
/// columns (`s_mm,x_mm,y_mm,z_mm,...`; a `_mm` suffix is ignored), and `x`, `y`, `z` are
/// required there. Without a header, 3 columns are `x y z` and 4 or more `s x y z ...`. Fields
/// are separated by commas (or, if a line has none, by whitespace); `NaN` is accepted in
/// columns other than the coordinates.
pub fn load_centerline_csv(path: impl AsRef<Path>) -> Result<Centerline, ImportError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| ImportError::Io(path.display().to_string(), e))?;
    parse_centerline_csv(&text).map_err(|e| match e {
        ImportError::Parse { line, message, .. } => ImportError::Parse { file: path.display().to_string(), line, message },
        other => other,
    })
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
