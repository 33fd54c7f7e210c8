//! The generated colon: size, radii, regions, no wall overlap, determinism.

use lumen_detect::Tube;
use lumen_import::probe::clearance;
use lumen_scene::colon::{generate, generate_detailed, ColonParams, Region};

fn midline_length(t: &Tube) -> f64 {
    t.points.windows(2).map(|w| (0..3).map(|d| (w[1][d] as f64 - w[0][d] as f64).powi(2)).sum::<f64>().sqrt()).sum()
}

fn norm(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[test]
fn default_colon_has_its_size_rings_and_radii() {
    let g = generate_detailed(&ColonParams::seeded(7));
    let t = &g.tube;
    assert_eq!(t.spokes, 32);
    assert!((1249..=1251).contains(&t.rings()), "{} rings", t.rings());
    let len = midline_length(t);
    assert!((len - 1500.0).abs() < 0.02 * 1500.0, "midline {len:.1} mm");
    // Radii within 20-35 mm everywhere.
    let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
    for v in &t.radial {
        let r = norm(*v);
        lo = lo.min(r);
        hi = hi.max(r);
    }
    assert!(lo >= 20.0 - 1e-3 && hi <= 35.0 + 1e-3, "radii {lo:.2}..{hi:.2}");
    assert!(hi - lo > 10.0, "radii hardly vary: {lo:.2}..{hi:.2}");
    // Regions in anatomical order, covering the arc, with their typical widths.
    let names: Vec<Region> = g.regions.iter().map(|r| r.0).collect();
    assert_eq!(names, Region::ALL.to_vec());
    assert!(g.regions.windows(2).all(|w| w[0].1 < w[1].1));
    let mean_radius = |reg: Region| {
        let (mut s, mut n) = (0.0f64, 0);
        for i in 0..t.rings() {
            if g.region_at(g.arc[i]) == reg {
                for k in 0..t.spokes {
                    s += norm(t.spoke(i, k)) as f64;
                    n += 1;
                }
            }
        }
        s / n as f64
    };
    let (sig, cae) = (mean_radius(Region::Sigmoid), mean_radius(Region::Caecum));
    assert!(cae - sig > 5.0, "caecum {cae:.1} vs sigmoid {sig:.1} mm");
    // Haustral ripple: along a spoke in the transverse colon the radius rises and falls by
    // millimetres every few centimetres (folds span the sectors between the taeniae).
    let (mut ripple, mut turns) = (0.0f32, 0);
    for k in 0..t.spokes {
        let tr: Vec<f32> = (0..t.rings()).filter(|&i| g.region_at(g.arc[i]) == Region::Transverse).map(|i| norm(t.spoke(i, k))).collect();
        let (mn, mx) = tr.iter().fold((f32::INFINITY, 0.0f32), |(a, b), &r| (a.min(r), b.max(r)));
        if mx - mn > ripple {
            ripple = mx - mn;
            turns = tr.windows(3).filter(|w| (w[1] - w[0]) * (w[2] - w[1]) < 0.0).count();
        }
    }
    assert!(ripple > 3.0, "transverse ripple {ripple:.2} mm");
    assert!(turns >= 10, "{turns} ripple extrema in the transverse colon");
    // Spokes: perpendicular to the midline, counter-clockwise about it, a star-shaped section.
    assert_eq!(t.first_non_star(), None);
    for i in 1..t.rings() - 1 {
        let along = sub(t.points[i + 1], t.points[i - 1]);
        let a = along.map(|x| x / norm(along));
        let (s0, s1) = (t.spoke(i, 0), t.spoke(i, 1));
        assert!(dot(s0, a).abs() < 0.02 * norm(s0), "ring {i}: spoke 0 not in the normal plane");
        assert!(dot(cross(s0, s1), a) > 0.0, "ring {i}: spokes turn clockwise");
    }
}

#[test]
fn walls_never_overlap_and_bends_are_gentle() {
    for (seed, length, spacing) in [(0u64, 1500.0f32, 1.2f32), (1, 1500.0, 1.2), (2, 1500.0, 1.2), (3, 800.0, 0.8), (4, 3000.0, 2.5)] {
        let p = ColonParams { seed, length_mm: length, ring_spacing: spacing, ..ColonParams::default() };
        let g = generate_detailed(&p);
        let c = clearance(&g.tube);
        eprintln!(
            "seed {seed}, {length} mm: candidate {}, wall gap {:.1} mm (rings {:?}), bend ratio {:.2} (ring {}); generator's own: {:.1} mm, {:.2}",
            g.attempt, c.min_wall_gap, c.at, c.min_bend_ratio, c.bend_at, g.min_wall_gap_mm, g.min_bend_ratio
        );
        // Midline points further apart along the arc than max(40 mm, 1.5 (R_i + R_j)) are
        // further apart in space than R_i + R_j (longest radial vectors): walls do not overlap.
        assert!(c.min_wall_gap > 0.0, "seed {seed}: walls overlap by {:.2} mm at rings {:?}", -c.min_wall_gap, c.at);
        // Bends: radius of curvature well above the lumen's.
        assert!(c.min_bend_ratio > 1.3, "seed {seed}: bend radius only {:.2} x the lumen radius at ring {}", c.min_bend_ratio, c.bend_at);
        let len = midline_length(&g.tube);
        assert!((len - length as f64).abs() < 0.02 * length as f64, "seed {seed}: {len:.1} mm of {length}");
        let scale = (length / 1500.0).min(1.0);
        assert!(g.tube.radial.iter().all(|v| (20.0 * scale - 1e-3..=35.0 * scale + 1e-3).contains(&norm(*v))));
    }
}

#[test]
fn same_seed_same_bytes_different_seed_different_colon() {
    let bits = |t: &Tube| -> Vec<u32> { t.points.iter().chain(&t.radial).flat_map(|p| p.map(f32::to_bits)).collect() };
    let a = generate(&ColonParams::seeded(11));
    let b = generate(&ColonParams::seeded(11));
    assert_eq!(bits(&a), bits(&b));
    let c = generate(&ColonParams::seeded(12));
    assert_eq!(a.rings(), c.rings());
    let moved = a.points.iter().zip(&c.points).map(|(p, q)| norm(sub(*p, *q))).fold(0.0f32, f32::max);
    assert!(moved > 5.0, "seeds 11 and 12 differ by at most {moved} mm");
    // The anus stays at the origin whatever the seed.
    assert_eq!(a.points[0], [0.0, 0.0, 0.0]);
    assert_eq!(c.points[0], [0.0, 0.0, 0.0]);
}

#[test]
fn the_hard_variants_narrow_the_lumen_where_they_say_and_nowhere_else() {
    use lumen_scene::ColonKind;
    let base = generate(&ColonKind::Generated.generated(1).unwrap());
    for (kind, places) in [(ColonKind::Narrow, lumen_scene::NARROW.to_vec()), (ColonKind::Collapsed, lumen_scene::COLLAPSED.to_vec())] {
        let t = generate(&kind.generated(1).unwrap());
        assert_eq!(t.points, base.points, "{kind}: the same midline");
        let arc = |i: usize| i as f32 * 1.2;
        for i in 0..t.rings() {
            let s = arc(i);
            let inside = places.iter().find(|n| (s - n.at_mm).abs() <= 0.5 * n.length_mm);
            let near = places.iter().any(|n| (s - n.at_mm).abs() <= 0.5 * n.length_mm + lumen_scene::colon::NARROWING_RAMP_MM as f32);
            for k in 0..t.spokes {
                let (r, r0) = (norm(t.spoke(i, k)), norm(base.spoke(i, k)));
                match inside {
                    // The whole section at the narrowing's radius (all of them below the base's).
                    Some(n) => assert!((r - n.radius_mm).abs() < 1e-4, "{kind} ring {i}: {r} mm, expected {}", n.radius_mm),
                    // Easing between the narrowing and the base lumen, never wider than the base.
                    None if near => assert!(r <= r0 + 1e-4, "{kind} ring {i}: {r} > {r0}"),
                    None => assert_eq!(r, r0, "{kind} ring {i} is untouched"),
                }
            }
        }
        // Below a 13 mm scope's radius where they say, so the sim's fit check finds them.
        let runs = lumen_import::fit::narrowings(&t, 6.5);
        assert_eq!(runs.len(), places.len(), "{kind}: {runs:?}");
        for (run, n) in runs.iter().zip(&places) {
            let centre = 0.5 * (arc(*run.rings.start()) + arc(*run.rings.end()));
            assert!((centre - n.at_mm).abs() < 5.0 && (run.smallest - n.radius_mm as f64).abs() < 1e-4, "{kind}: {run:?} for {n:?}");
        }
    }
    assert!(lumen_import::fit::narrowings(&base, 6.5).is_empty(), "the base colon is wider than the scope everywhere");
    assert_eq!("narrow".parse::<ColonKind>(), Ok(ColonKind::Narrow));
    assert!("narrowed".parse::<ColonKind>().unwrap_err().to_string().contains("narrow, collapsed"));
}
