//! Whether an imported tube is usable: thresholds on an [`ImportReport`], and the problems
//! found, each with its cause and where along the midline it lies.
//!
//! A tube can be built from almost anything: a surface inside out, in metres beside a midline in
//! millimetres, written twice over itself, or in pieces with gaps. Each of these leaves marks in
//! the report (rays repaired, hits from outside, rings borrowed, a midline outside its surface,
//! an implausible lumen), and [`assess`] turns the marks into [`Problem`]s that name the cause and
//! the rings. `lumen import` refuses a model with problems unless told `--force`.

use crate::ImportReport;
use std::fmt;
use std::ops::RangeInclusive;

/// The limits [`assess`] holds a report to. Fractions are of all rays or of all rings; lengths
/// in mm (the import's unit after `--units`).
#[derive(Debug, Clone, PartialEq)]
pub struct Thresholds {
    /// Most rays repaired, whatever the cause (default 0.25).
    pub repaired: f64,
    /// Most rays meeting the wall from outside (default 0.05).
    pub from_outside: f64,
    /// Most rings borrowing their median from neighbouring rings (default 0.05).
    pub borrowed: f64,
    /// Most rings whose midline point lies outside the surface (default 0.02).
    pub midline_outside: f64,
    /// Most rays meeting a doubled wall (default 0.10).
    pub doubled: f64,
    /// Least agreement of first hits on which way the surface faces (default 0.8).
    pub orientation: f64,
    /// Plausible median lumen radius before inflation, mm (default 1 to 100: a colon's
    /// lumen, collapsed or insufflated; metres or centimetres read as millimetres fall below).
    pub radius_mm: RangeInclusive<f64>,
    /// Most the midline may reach beyond the surface's bounding box, as a fraction of the
    /// box's diagonal (default 0.1).
    pub midline_beyond: f64,
    /// Largest 99th percentile of the wall's distance to the surface (before inflation), as a
    /// fraction of the median lumen radius (default 0.25).
    pub fidelity: f64,
    /// Most rings where the midline turns back on itself (default 0.01): points out of order.
    pub turns_back: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Self {
            repaired: 0.25,
            from_outside: 0.05,
            borrowed: 0.05,
            midline_outside: 0.02,
            doubled: 0.10,
            orientation: 0.8,
            radius_mm: 1.0..=100.0,
            midline_beyond: 0.1,
            fidelity: 0.25,
            turns_back: 0.01,
        }
    }
}

/// Why a model is not usable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    Repaired,
    FromOutside,
    Borrowed,
    MidlineOutside,
    Doubled,
    Orientation,
    Radius,
    MidlineBeyond,
    Fidelity,
    TurnsBack,
    /// A spoke's tip lies past another ring's plane inside that ring's section: the wall passes
    /// over itself ([`lumen_detect::Tube::folds`]).
    Folds,
}

/// One problem: its cause, what was measured against what limit, and the rings it touches
/// (empty when it is the whole model's).
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    pub cause: Cause,
    pub message: String,
    pub rings: Vec<RangeInclusive<usize>>,
    /// Rings in the model, for "of N".
    pub of: usize,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.message)?;
        if !self.rings.is_empty() {
            let shown: Vec<String> = self.rings.iter().take(6).map(|r| if r.start() == r.end() { r.start().to_string() } else { format!("{}-{}", r.start(), r.end()) }).collect();
            let more = if self.rings.len() > 6 { format!(" and {} more ranges", self.rings.len() - 6) } else { String::new() };
            write!(f, " (rings {}{more} of {})", shown.join(", "), self.of)?;
        }
        Ok(())
    }
}

/// Ring indices as ranges, merging gaps of at most two rings.
pub fn ranges(rings: impl IntoIterator<Item = usize>) -> Vec<RangeInclusive<usize>> {
    let mut out: Vec<RangeInclusive<usize>> = Vec::new();
    for i in rings {
        match out.last_mut() {
            Some(r) if i <= r.end() + 3 => *r = *r.start()..=i,
            _ => out.push(i..=i),
        }
    }
    out
}

fn pct(x: f64) -> String {
    format!("{:.1}%", 100.0 * x)
}

/// The problems of a report under `limits`; empty when the model is usable.
pub fn assess(r: &ImportReport, limits: &Thresholds) -> Vec<Problem> {
    let mut out = Vec::new();
    let rays = r.rays.max(1) as f64;
    let rings = r.rings.max(1) as f64;
    let t = &r.ring_tallies;
    let mut add = |cause, message: String, at: Vec<RangeInclusive<usize>>| out.push(Problem { cause, message, rings: at, of: r.rings });
    let where_ = |f: &dyn Fn(&crate::RingTally) -> bool| ranges(t.iter().enumerate().filter(|(_, x)| f(x)).map(|(i, _)| i));
    let median = r.radius_mm[2] / r.inflate.max(f64::MIN_POSITIVE);
    if !limits.radius_mm.contains(&median) {
        let hint = if median < *limits.radius_mm.start() { "is the surface in metres or centimetres? pass --units" } else { "is the surface in micrometres or voxels? pass --units" };
        add(Cause::Radius, format!("median lumen radius {median:.3} mm is not a colon's ({} to {} mm): {hint}", limits.radius_mm.start(), limits.radius_mm.end()), vec![]);
    }
    if r.midline_beyond_surface > limits.midline_beyond * r.surface_diagonal {
        add(
            Cause::MidlineBeyond,
            format!(
                "the midline reaches {:.1} mm beyond the surface's bounding box (diagonal {:.1} mm; at most {}): are the midline and the surface in the same units?",
                r.midline_beyond_surface,
                r.surface_diagonal,
                pct(limits.midline_beyond)
            ),
            vec![],
        );
    }
    if r.orientation_agreement < limits.orientation {
        add(
            Cause::Orientation,
            format!(
                "the surface faces both ways: only {} of first hits agree on which side is inside (at least {}); make its normals consistent",
                pct(r.orientation_agreement),
                pct(limits.orientation)
            ),
            vec![],
        );
    }
    let outside = t.iter().filter(|x| x.outside(r.spokes)).count();
    if outside as f64 > limits.midline_outside * rings {
        add(
            Cause::MidlineOutside,
            format!("the midline lies outside the surface at {outside} rings, {} (at most {})", pct(outside as f64 / rings), pct(limits.midline_outside)),
            where_(&|x| x.outside(r.spokes)),
        );
    }
    if r.from_outside as f64 > limits.from_outside * rays {
        add(
            Cause::FromOutside,
            format!("{} of rays met the wall from outside (at most {})", pct(r.from_outside as f64 / rays), pct(limits.from_outside)),
            where_(&|x| 4 * x.from_outside as usize >= r.spokes),
        );
    }
    if r.doubled as f64 > limits.doubled * rays {
        add(
            Cause::Doubled,
            format!("{} of rays met a doubled wall (at most {}): the surface is written twice or has a second wall right behind the first", pct(r.doubled as f64 / rays), pct(limits.doubled)),
            where_(&|x| 4 * x.doubled as usize >= r.spokes),
        );
    }
    if r.repaired_fraction() > limits.repaired {
        add(Cause::Repaired, format!("{} of rays were repaired (at most {})", pct(r.repaired_fraction()), pct(limits.repaired)), where_(&|x| 2 * x.repaired as usize >= r.spokes));
    }
    if r.rings_borrowed as f64 > limits.borrowed * rings {
        add(
            Cause::Borrowed,
            format!("{} rings ({}) had too few wall hits and borrowed their radius (at most {})", r.rings_borrowed, pct(r.rings_borrowed as f64 / rings), pct(limits.borrowed)),
            where_(&|x| x.borrowed),
        );
    }
    if r.fidelity.p99 > limits.fidelity * median {
        add(
            Cause::Fidelity,
            format!("the imported wall lies {:.2} mm from the surface at p99 (max {:.2} mm), more than {} of the median radius {median:.2} mm", r.fidelity.p99, r.fidelity.max, pct(limits.fidelity)),
            vec![],
        );
    }
    if let Some(p) = fold_problem(&r.folds, r.rings) {
        add(p.cause, p.message, p.rings);
    }
    if r.turns_back.len() as f64 > limits.turns_back * rings {
        add(
            Cause::TurnsBack,
            format!("the midline turns back on itself {} times (at most {} of rings): are its points in order?", r.turns_back.len(), pct(limits.turns_back)),
            ranges(r.turns_back.iter().copied()),
        );
    }
    out
}

/// The fold check as a problem: none when no spoke folds.
fn fold_problem(folds: &lumen_detect::model::FoldReport, of: usize) -> Option<Problem> {
    let (a, z) = folds.ring_range?;
    Some(Problem {
        cause: Cause::Folds,
        message: format!(
            "{} spokes of {} rings reach past another ring's plane inside its section, by up to {:.1} mm: the wall passes over itself there (a model that folds)",
            folds.spokes, folds.rings, folds.max_cut
        ),
        rings: vec![a..=z],
        of,
    })
}

/// The problems of a model that did not come through [`assess`] (a model file, a generated or
/// hand-made tube): what can be checked on the tube alone, today whether it folds.
pub fn check_tube(tube: &lumen_detect::Tube) -> Vec<Problem> {
    fold_problem(&tube.folds(), tube.rings()).into_iter().collect()
}
