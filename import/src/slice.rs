//! Ring planes that never cross inside the lumen.
//!
//! A ring's section is the part of its plane (point `C_i`, unit normal `n_i` along the midline)
//! that the rays from `C_i` reach before the wall: the polygon of its spoke tips. The detector
//! reads a point between the planes of rings `i` and `i + 1` as lying in segment `i`, at
//! `u = d_i / (d_i - d_{i+1})` with `d_i = (P - C_i) . n_i`: the level sets of `u` are the
//! planes through the line where the two ring planes meet. Where a bend is tighter than the
//! lumen is wide, that line passes through the lumen on the bend's inner side; the wall between
//! the rings passes over itself there, and a point of the lumen lies in two sections. The model
//! holds when no spoke's tip lies past another ring's plane inside that ring's section
//! ([`lumen_detect::model::Tube::folds`], the check every import reports): then no point of the
//! lumen is in two sections.
//!
//! **The choice: one smoothing width per colon, the one whose wall is truest with the fewest
//! crossings.** Ring `i`'s normal is the midline's unit tangent averaged along the arc with a
//! Gaussian of width `sigma` ([`crate::geom::tangents`]):
//!
//! ```text
//! n_i = normalize( sum_m exp(-(s_m - s_i)^2 / (2 sigma^2)) t_m )
//! ```
//!
//! A turn of the tangent by `Theta` turns the smoothed normals by about
//! `Theta / (sigma sqrt(2 pi))` per unit of arc, and two planes `h` apart whose normals differ by
//! `delta` meet about `h / delta` from the midline: a wider `sigma` fans the planes of a bend
//! about a line further out, beyond a lumen of reach `rho` once
//! `sigma > rho Theta / sqrt(2 pi)`. Too wide a `sigma` fails the other way: at a sharp turn the
//! smoothed normal lags the midline, planes turn far off the tube's own direction, cross again
//! and cut neighbouring loops (on the GCA colon at inflation 1, the spokes that cross fall from
//! 3,079 at 4 mm to 36 at 16 mm and rise again to 507 at 30 mm, where planes turn up to 84
//! degrees off the 4 mm tangent and the wall lies 1.52 mm from the surface at p99). So the
//! import slices the whole tube at each width of a [`ladder`] (from the import's tangent
//! smoothing, by [`GROW`], to [`WIDEST`]; it stops at the first width where nothing crosses),
//! finishes each slicing (repairs, fidelity, clip), and keeps the one whose wall lies within
//! [`FIDELITY_SLACK`] of the truest one's p99 with the fewest spokes clipped ([`pick`]).
//!
//! **What still crosses is clipped.** A spoke whose tip still lies past another ring's plane
//! inside its section is shortened along itself to just short of the crossing
//! ([`lumen_detect::model::Tube::clip_folds`]); shortening only shrinks sections, so afterwards
//! the check finds none. On an inflated colon the same clip is where loops pressed on each other
//! flatten their walls. Where a lumen doubles back wider than its bend (a hairpin whose legs'
//! lumens meet), no planes keep the legs apart and the clipped wall is not the surface's.
//!
//! Tried and left (docs/decisions/import.md): a width per ring (the one its neighbourhood
//! crosses least at): fewer spokes clipped, but planes turned into the other leg of a hairpin
//! and the scope went 6.1 mm deep there; widening the width round by round where sections
//! crossed: the crossings fell to a quarter in five rounds, then rose past where they started.
//! Shortening every spoke that reached past a ring's plane within that ring's longest spoke, on
//! planes along the tangent (`Tube::unfold`): it cut 9,156 spokes of the GCA colon, moved the
//! wall inward where the scope was, and its colonoscopy went from 0.60 to 1.32 mm.

/// Factor between consecutive widths tried.
pub const GROW: f64 = 1.5;

/// The widest smoothing tried by default (mm).
pub const WIDEST: f64 = 64.0;

/// How much farther from the surface than the truest slicing's (p99, as a fraction) a slicing's
/// wall may lie and still be picked for clipping fewer spokes.
pub const FIDELITY_SLACK: f64 = 0.1;

/// The widths tried: `base` (the import's tangent smoothing; one ring spacing if 0 and `widest`
/// is more) growing by [`GROW`] up to `widest` ([`WIDEST`] by default).
pub fn ladder(base: f64, spacing: f64, widest: f64) -> Vec<f64> {
    let mut w = if base > 0.0 || widest <= 0.0 { base } else { spacing.min(widest) };
    let mut out = vec![w];
    while w > 0.0 && w * GROW <= widest {
        w *= GROW;
        out.push(w);
    }
    out
}

/// Which slicing to keep, given each one's wall-to-surface distance (p99, before inflation)
/// and spokes clipped: of those whose wall lies within [`FIDELITY_SLACK`] of the truest one's,
/// the one with the fewest spokes clipped (the narrowest of equals).
pub fn pick(fidelity_p99: &[f64], clipped: &[usize]) -> usize {
    let truest = fidelity_p99.iter().copied().fold(f64::INFINITY, f64::min);
    (0..fidelity_p99.len()).filter(|&r| fidelity_p99[r] <= truest * (1.0 + FIDELITY_SLACK)).min_by_key(|&r| (clipped[r], r)).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ladder_grows_from_the_imports_smoothing_and_the_pick_weighs_the_wall_first() {
        let ladder = ladder(4.0, 1.0, WIDEST);
        assert_eq!(ladder.first(), Some(&4.0));
        assert!(ladder.windows(2).all(|w| (w[1] / w[0] - GROW).abs() < 1e-12) && *ladder.last().unwrap() <= WIDEST);
        assert_eq!(super::ladder(0.0, 0.5, WIDEST)[0], 0.5);
        assert_eq!(super::ladder(4.0, 1.0, 4.0), [4.0]);
        assert_eq!(super::ladder(0.0, 1.0, 0.0), [0.0]);
        // The fewest clipped among the walls within 10% of the truest (0.5): rung 2.
        assert_eq!(pick(&[0.75, 0.5, 0.51, 1.5], &[3000, 140, 100, 20]), 2);
        // Equal clips: the narrowest.
        assert_eq!(pick(&[0.5, 0.5], &[7, 7]), 0);
        assert_eq!(pick(&[0.2, 0.9], &[50, 0]), 0);
    }
}
