//! The method's original text format for tubes.
//!
//! First line `A B`; then, for each of the `A` control points, one line `x y z` with its
//! position followed by `B` lines `x y z` with its radial vectors (relative to the point).
//! Numbers are whitespace separated and may use exponents (`1.490116E-08`). Blank lines are
//! skipped.

use super::{ModelError, Tube};

fn err(line: usize, message: impl Into<String>) -> ModelError {
    ModelError::Parse { line, message: message.into() }
}

fn triple(line: usize, text: &str, what: &str) -> Result<[f32; 3], ModelError> {
    let mut out = [0f32; 3];
    let mut it = text.split_whitespace();
    for (c, o) in out.iter_mut().enumerate() {
        let tok = it.next().ok_or_else(|| err(line, format!("{what}: expected 3 numbers, found {c}")))?;
        *o = tok.parse::<f32>().map_err(|_| err(line, format!("{what}: {tok:?} is not a number")))?;
        if !o.is_finite() {
            return Err(err(line, format!("{what}: {tok:?} is not finite")));
        }
    }
    if let Some(extra) = it.next() {
        return Err(err(line, format!("{what}: unexpected {extra:?} after 3 numbers")));
    }
    Ok(out)
}

/// Parses a tube from the original text format; errors carry the 1-based line number.
pub fn parse_text(src: &str) -> Result<Tube, ModelError> {
    let mut lines = src.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty());
    let (hl, header) = lines.next().ok_or_else(|| err(1, "empty file: expected a header line `A B`"))?;
    let mut h = header.split_whitespace();
    let mut count = |name: &str| -> Result<usize, ModelError> {
        let tok = h.next().ok_or_else(|| err(hl, format!("header: missing {name}")))?;
        tok.parse::<usize>().map_err(|_| err(hl, format!("header: {name} = {tok:?} is not a count")))
    };
    let (a, b) = (count("A (control points)")?, count("B (radial vectors per point)")?);
    if let Some(extra) = h.next() {
        return Err(err(hl, format!("header: unexpected {extra:?} after `A B`")));
    }
    super::check_counts(a, Some(b)).map_err(|e| err(hl, e.to_string()))?;
    let mut points = Vec::with_capacity(a);
    let mut radial = Vec::with_capacity(a * b);
    let mut last = hl;
    for i in 0..a {
        let (l, t) = lines.next().ok_or_else(|| err(last + 1, format!("file ends before control point {i} of {a}")))?;
        points.push(triple(l, t, &format!("control point {i}"))?);
        last = l;
        for k in 0..b {
            let (l, t) = lines.next().ok_or_else(|| err(last + 1, format!("file ends before radial vector {k} of control point {i}")))?;
            radial.push(triple(l, t, &format!("radial vector {k} of control point {i}"))?);
            last = l;
        }
    }
    if let Some((l, t)) = lines.next() {
        return Err(err(l, format!("unexpected data after {a} control points: {t:?}")));
    }
    Tube::new(points, radial, b)
}

/// Writes a tube in the original text format (shortest round-trip representation of each f32).
pub fn to_text(t: &Tube) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "{} {}", t.rings(), t.spokes);
    for i in 0..t.rings() {
        let p = t.points[i];
        let _ = writeln!(s, "{:?} {:?} {:?}", p[0], p[1], p[2]);
        for k in 0..t.spokes {
            let v = t.spoke(i, k);
            let _ = writeln!(s, "{:?} {:?} {:?}", v[0], v[1], v[2]);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "2 3\n0 0 0\n1 0 0\n-0.5 0.866 0\n-0.5 -0.866 1.490116E-08\n\n10 0 0\n1 0 0\n-0.5 0.866 0\n-0.5 -0.866 0\n";

    #[test]
    fn parses_the_original_format_with_exponents() {
        let t = parse_text(SAMPLE).unwrap();
        assert_eq!(t.rings(), 2);
        assert_eq!(t.spokes, 3);
        assert_eq!(t.spoke(0, 2)[2], 1.490116E-08);
        assert_eq!(t.points[1], [10.0, 0.0, 0.0]);
        assert_eq!(parse_text(&to_text(&t)).unwrap(), t);
    }

    #[test]
    fn errors_carry_the_line() {
        let bad = SAMPLE.replace("-0.5 0.866 0\n-0.5 -0.866 0\n", "-0.5 zero 0\n-0.5 -0.866 0\n");
        let e = parse_text(&bad).unwrap_err().to_string();
        assert!(e.starts_with("line 9: radial vector 1 of control point 1"), "{e}");
        let e = parse_text("2 3\n0 0 0\n1 0\n").unwrap_err().to_string();
        assert!(e.starts_with("line 3: radial vector 0 of control point 0: expected 3 numbers, found 2"), "{e}");
        let e = parse_text("1 3\n").unwrap_err().to_string();
        assert!(e.starts_with("line 1:") && e.contains("1 control points"), "{e}");
        let e = parse_text("2 3\n0 0 0\n").unwrap_err().to_string();
        assert!(e.starts_with("line 3: file ends before radial vector 0"), "{e}");
        let e = parse_text(&(SAMPLE.to_owned() + "1 2 3\n")).unwrap_err().to_string();
        assert!(e.starts_with("line 11: unexpected data"), "{e}");
        let e = parse_text("2 3\nnan 0 0\n").unwrap_err().to_string();
        assert!(e.starts_with("line 2: control point 0: \"nan\" is not finite"), "{e}");
    }
}
