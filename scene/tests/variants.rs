//! The generated colon's hard variants with a shape of their own: `tight-bend` (bends tighter
//! than the lumen) and `loop` (a sigmoid that winds once around and passes beside itself),
//! measured on the tubes themselves, not on what the generator says of them.

use lumen_detect::model::FoldReport;
use lumen_detect::Tube;
use lumen_import::probe::clearance;
use lumen_scene::colon::{generate, generate_detailed, GeneratedColon, MAX_LOOP_PASS_GAP_MM, MIN_LOOP_TURN_DEG, MIN_WALL_GAP_MM};
use lumen_scene::ColonKind;

type V = [f64; 3];

fn v(p: [f32; 3]) -> V {
    p.map(f64::from)
}
fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V, b: V) -> V {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn norm(a: V) -> f64 {
    dot(a, a).sqrt()
}
fn unit(a: V) -> V {
    let n = norm(a);
    a.map(|x| x / n)
}

fn bits(t: &Tube) -> Vec<u32> {
    t.points.iter().chain(&t.radial).flat_map(|p| p.map(f32::to_bits)).collect()
}

fn longest_spoke(t: &Tube, i: usize) -> f64 {
    (0..t.spokes).map(|k| norm(v(t.spoke(i, k)))).fold(0.0, f64::max)
}

/// The midline's bend radius at ring `i`: the circumradius of the ring centres 3 rings (3.6 mm)
/// either side.
fn bend_radius(t: &Tube, i: usize) -> f64 {
    let (a, b, c) = (v(t.points[i - 3]), v(t.points[i]), v(t.points[i + 3]));
    let area2 = norm(cross(sub(a, b), sub(c, b)));
    if area2 < 1e-12 {
        return f64::INFINITY;
    }
    norm(sub(a, b)) * norm(sub(c, b)) * norm(sub(a, c)) / (2.0 * area2)
}

/// Where the planes of rings `i` and `j` cross, as the distance from ring `i`'s centre, and
/// how far ring `i`'s wall reaches towards that line.
fn planes_cross(t: &Tube, i: usize, j: usize) -> (f64, f64) {
    let tangent = |k: usize| unit(sub(v(t.points[k + 1]), v(t.points[k - 1])));
    let (ni, nj) = (tangent(i), tangent(j));
    let d = cross(ni, nj);
    let u = unit(cross(d, ni));
    let s = dot(nj, sub(v(t.points[j]), v(t.points[i]))) / dot(nj, u);
    let towards = if s >= 0.0 { u } else { u.map(|x| -x) };
    // The spoke of ring i pointing nearest the crossing line.
    let reach = (0..t.spokes).map(|k| v(t.spoke(i, k))).max_by(|a, b| dot(unit(*a), towards).total_cmp(&dot(unit(*b), towards))).map_or(0.0, norm);
    (s.abs(), reach)
}

fn arc_ring(g: &GeneratedColon, s: f32) -> usize {
    g.arc.partition_point(|&a| a < s).min(g.arc.len() - 1)
}

#[test]
fn tight_bend_is_deterministic_and_bends_tighter_than_its_lumen_in_two_places() {
    for seed in [1u64, 2, 3] {
        let p = ColonKind::TightBend.generated(seed).unwrap();
        let g = generate_detailed(&p);
        assert_eq!(bits(&g.tube), bits(&generate(&p)), "seed {seed}: two runs differ");
        let t = &g.tube;
        assert_eq!(g.tight_bends.len(), 2, "seed {seed}");
        for (k, b) in g.tight_bends.iter().enumerate() {
            // Measured on the rings: the smallest bend radius over the ring's longest spoke in
            // the window is below 1 (the generator aims at 0.6).
            let (lo, hi) = (arc_ring(&g, b.window_mm[0]), arc_ring(&g, b.window_mm[1]));
            let (ratio, at) = (lo.max(3)..hi.min(t.rings() - 3)).map(|i| (bend_radius(t, i) / longest_spoke(t, i), i)).fold((f64::INFINITY, 0), |m, x| if x.0 < m.0 { x } else { m });
            // The arc's ring planes cross inside the lumen, on the inner side of the bend: rings
            // half the arc either side of its middle.
            let mid = arc_ring(&g, b.at_mm);
            let half = ((b.radius_mm * b.turn_deg.to_radians()) / 2.0 / 1.2) as usize;
            let (cross_at, reach) = planes_cross(t, mid - half, mid + half);
            eprintln!(
                "tight-bend seed {seed}, bend {k}: window {:.0}-{:.0} mm, arc at {:.0} mm, radius {:.1} mm, turn {:.0} deg; generator's ratio {:.2}, rings' {ratio:.2} (ring {at}, {:.0} mm); planes of rings {} and {} cross {cross_at:.1} mm from the midline, the wall {reach:.1} mm",
                b.window_mm[0], b.window_mm[1], b.at_mm, b.radius_mm, b.turn_deg, b.ratio, g.arc[at], mid - half, mid + half
            );
            assert!(ratio < 0.8 && b.ratio < 0.8, "seed {seed}, bend {k}: ratio {ratio:.2} (generator {:.2})", b.ratio);
            assert!(b.turn_deg >= 45.0, "seed {seed}, bend {k}: turns {:.0} degrees", b.turn_deg);
            // The planes cross inside the lumen (its longest spoke there reaches further), and
            // the spokes that reached past the crossing now end short of it (Tube::unfold).
            let lumen = longest_spoke(t, mid);
            assert!(cross_at < lumen, "seed {seed}, bend {k}: ring planes cross {cross_at:.1} mm out, the lumen is {lumen:.1} mm");
            assert!(reach < cross_at, "seed {seed}, bend {k}: the wall towards the crossing is {reach:.1} mm out, the planes cross {cross_at:.1} mm out");
        }
        // Only spokes beside the bends were shortened, and nothing folds any more.
        let (first, last) = g.folds.ring_range.expect("spokes shortened at the tight bends");
        let near_a_bend = |i: usize| g.tight_bends.iter().any(|b| g.arc[i] >= b.window_mm[0] - 40.0 && g.arc[i] <= b.window_mm[1] + 40.0);
        assert!(near_a_bend(first) && near_a_bend(last), "seed {seed}: spokes shortened at rings {first}-{last}");
        assert_eq!(g.tube.clone().unfold(), FoldReport::default(), "seed {seed}");
        // Where the scripted colonoscopy goes: the rectosigmoid junction and the top of the sigmoid.
        let (a, b) = (g.tight_bends[0].at_mm, g.tight_bends[1].at_mm);
        assert!((120.0..200.0).contains(&a) && (280.0..350.0).contains(&b) && b - a > 100.0, "bends at {a:.0} and {b:.0} mm");
        // Outside the windows the default colon's checks hold; walls overlap only beside a bend.
        let outside = |i: usize| g.tight_bends.iter().all(|b| g.arc[i] < b.window_mm[0] - 40.0 || g.arc[i] > b.window_mm[1] + 40.0);
        let worst = (40..t.rings() - 40).filter(|&i| outside(i)).map(|i| bend_radius(t, i) / longest_spoke(t, i)).fold(f64::INFINITY, f64::min);
        assert!(worst > 1.3, "seed {seed}: bend ratio {worst:.2} outside the tight bends");
        let c = clearance(t);
        let beside = |i: usize| g.tight_bends.iter().position(|b| g.arc[i] >= b.window_mm[0] - 40.0 && g.arc[i] <= b.window_mm[1] + 40.0);
        assert!(c.min_wall_gap > 0.0 || (beside(c.at.0).is_some() && beside(c.at.0) == beside(c.at.1)), "seed {seed}: walls overlap at rings {:?}", c.at);
    }
    // The default colon keeps its checks.
    let plain = generate_detailed(&ColonKind::Generated.generated(1).unwrap());
    assert!(plain.tight_bends.is_empty() && plain.folds == FoldReport::default());
    assert_eq!("tight-bend".parse::<ColonKind>(), Ok(ColonKind::TightBend));
}

#[test]
fn loop_is_deterministic_turns_once_around_and_passes_beside_itself() {
    for seed in [1u64, 2, 3] {
        let p = ColonKind::Loop.generated(seed).unwrap();
        let g = generate_detailed(&p);
        assert_eq!(bits(&g.tube), bits(&generate(&p)), "seed {seed}: two runs differ");
        let t = &g.tube;
        let l = g.sigmoid_loop.expect("a loop");
        let (i0, i1) = (arc_ring(&g, l.arc_mm[0]), arc_ring(&g, l.arc_mm[1]));
        // Total turning of the ring centres over the revolution.
        let turn: f64 = (i0 + 1..i1).map(|i| dot(unit(sub(v(t.points[i]), v(t.points[i - 1]))), unit(sub(v(t.points[i + 1]), v(t.points[i])))).clamp(-1.0, 1.0).acos()).sum::<f64>().to_degrees();
        // The two passes: rings within 40 mm of the revolution's start against those within 40
        // mm of its end, wall to wall (centres less the longest spokes).
        let near = |i: usize, s: f32| (g.arc[i] - s).abs() <= 40.0;
        let mut gap = (f64::INFINITY, 0, 0);
        for i in (0..t.rings()).filter(|&i| near(i, l.arc_mm[0])) {
            for j in (0..t.rings()).filter(|&j| near(j, l.arc_mm[1])) {
                let d = norm(sub(v(t.points[i]), v(t.points[j]))) - longest_spoke(t, i) - longest_spoke(t, j);
                if d < gap.0 {
                    gap = (d, i, j);
                }
            }
        }
        let c = clearance(t);
        eprintln!(
            "loop seed {seed}: revolution {:.0}-{:.0} mm, turning {turn:.1} deg (generator {:.1}); passes {:.1} mm apart wall to wall at {:.0} and {:.0} mm (generator {:.1}); walls {:.1} mm apart at least, bend ratio {:.2} at least",
            l.arc_mm[0], l.arc_mm[1], l.turn_deg, gap.0, g.arc[gap.1], g.arc[gap.2], l.pass_gap_mm, c.min_wall_gap, c.min_bend_ratio
        );
        assert!(turn >= MIN_LOOP_TURN_DEG, "seed {seed}: the loop turns {turn:.1} degrees");
        assert!(gap.0 >= MIN_WALL_GAP_MM && gap.0 <= MAX_LOOP_PASS_GAP_MM, "seed {seed}: passes {:.1} mm apart", gap.0);
        // In the sigmoid, and checked like the default colon everywhere.
        assert!((120.0..200.0).contains(&l.arc_mm[0]) && (400.0..500.0).contains(&l.arc_mm[1]), "seed {seed}: {:?}", l.arc_mm);
        assert!(c.min_wall_gap >= MIN_WALL_GAP_MM - 0.5, "seed {seed}: walls {:.1} mm apart at rings {:?}", c.min_wall_gap, c.at);
        assert!(c.min_bend_ratio > 1.3, "seed {seed}: bend ratio {:.2} at ring {}", c.min_bend_ratio, c.bend_at);
    }
    assert_eq!("loop".parse::<ColonKind>(), Ok(ColonKind::Loop));
}
