//! The import's quality gate: a bent tube imports clean, and each way a lab's files go wrong
//! (inside out, faces both ways, wrong units, a midline in voxels, a doubled wall, open pieces,
//! a midline out of order) is either read right or refused with its cause and rings.

use lumen_import::*;

/// Bend radius of the tube's midline, tube radius (mm), vertices around, rings of vertices.
const BEND: f32 = 60.0;
const R: f32 = 10.0;
const AROUND: usize = 64;
const ALONG: usize = 121;

/// The midline: half a circle of radius BEND in the xz plane, plus 20 mm straight at each end.
fn centre(s: f32) -> ([f32; 3], [f32; 3]) {
    let arc = std::f32::consts::PI * BEND;
    if s < 20.0 {
        ([BEND, 0.0, s - 20.0], [1.0, 0.0, 0.0])
    } else if s <= 20.0 + arc {
        let a = (s - 20.0) / BEND;
        ([BEND * a.cos(), 0.0, BEND * a.sin()], [a.cos(), 0.0, a.sin()])
    } else {
        ([-BEND, 0.0, -(s - 20.0 - arc)], [-1.0, 0.0, 0.0])
    }
}

fn length() -> f32 {
    40.0 + std::f32::consts::PI * BEND
}

/// A closed bent tube of radius `R` about [`centre`], outward faces.
fn tube_mesh() -> Mesh {
    let mut m = Mesh::default();
    for i in 0..ALONG {
        let (c, n) = centre(length() * i as f32 / (ALONG - 1) as f32);
        for k in 0..AROUND {
            let a = std::f32::consts::TAU * k as f32 / AROUND as f32;
            m.vertices.push([0, 1, 2].map(|d| c[d] + R * (a.cos() * n[d] + a.sin() * [0.0, 1.0, 0.0][d])));
        }
    }
    let id = |i: usize, k: usize| (i * AROUND + k % AROUND) as u32;
    for i in 0..ALONG - 1 {
        for k in 0..AROUND {
            m.triangles.push([id(i, k), id(i, k + 1), id(i + 1, k + 1)]);
            m.triangles.push([id(i, k), id(i + 1, k + 1), id(i + 1, k)]);
        }
    }
    for (i, end) in [(0, centre(0.0).0), (ALONG - 1, centre(length()).0)] {
        let c = m.vertices.len() as u32;
        m.vertices.push(end);
        for k in 0..AROUND {
            m.triangles.push([c, id(i, k + 1), id(i, k)]);
        }
    }
    if m.signed_volume() < 0.0 {
        m.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    }
    m
}

/// The midline, 2 mm short of the caps at both ends (rays in a cap's plane graze it).
fn midline() -> Centerline {
    Centerline { points: (0..=200).map(|i| centre(2.0 + (length() - 4.0) * i as f32 / 200.0).0).collect(), ..Default::default() }
}

fn params() -> ImportParams {
    ImportParams { spokes: 32, ring_spacing: 2.0, ..Default::default() }
}

fn import(mesh: &Mesh, line: &Centerline) -> (lumen_detect::Tube, ImportReport, Vec<Problem>) {
    let (tube, rep) = build_tube(mesh, line, &params()).unwrap();
    let problems = assess(&rep, &Thresholds::default());
    (tube, rep, problems)
}

fn causes(p: &[Problem]) -> Vec<Cause> {
    p.iter().map(|p| p.cause).collect()
}

#[test]
fn a_bent_tube_imports_clean_and_close_to_its_surface() {
    let (_, rep, problems) = import(&tube_mesh(), &midline());
    assert!(problems.is_empty(), "{problems:?}\n{rep}");
    assert_eq!(rep.repaired(), 0, "{rep}");
    assert!(rep.oriented && !rep.flipped && rep.orientation_agreement == 1.0);
    assert!((rep.radius_mm[2] - R as f64).abs() < 0.05, "{rep}");
    // The wall's corners lie on the surface; between them it cuts the facets' chords (64 around
    // on radius 10: 0.012 mm) and the bend's (1.8 mm long facets on a 60 mm bend).
    assert!(rep.fidelity.p50 < 0.05 && rep.fidelity.p99 < 0.1 && rep.fidelity.samples > 10_000, "{:?}", rep.fidelity);
    assert!(rep.to_string().contains("Wall (before inflation) to surface"), "{rep}");
}

#[test]
fn an_inside_out_surface_is_read_flipped_and_gives_the_same_tube() {
    let good = import(&tube_mesh(), &midline());
    let mut m = tube_mesh();
    m.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let (tube, rep, problems) = import(&m, &midline());
    assert!(problems.is_empty(), "{problems:?}");
    assert!(rep.flipped && rep.oriented, "{rep}");
    assert!(rep.to_string().contains("read flipped"));
    assert_eq!(tube, good.0);
}

#[test]
fn a_surface_facing_both_ways_is_refused() {
    let mut m = tube_mesh();
    for t in m.triangles.iter_mut().step_by(2) {
        t.swap(1, 2);
    }
    let (_, rep, problems) = import(&m, &midline());
    assert!(!rep.oriented && (0.4..0.6).contains(&rep.orientation_agreement), "{rep}");
    assert_eq!(causes(&problems), [Cause::Orientation], "{problems:?}");
    assert!(problems[0].to_string().contains("faces both ways"), "{}", problems[0]);
}

#[test]
fn a_surface_in_metres_is_refused_until_its_units_are_given() {
    let to_m = |p: [f32; 3]| p.map(|x| x * 1e-3);
    let mut m = tube_mesh();
    m.vertices.iter_mut().for_each(|v| *v = to_m(*v));
    let mut line = midline();
    line.points.iter_mut().for_each(|v| *v = to_m(*v));
    let (_, _, problems) = build_tube(&m, &line, &ImportParams { ring_spacing: 2e-3, ..params() })
        .map(|(t, r)| {
            let p = assess(&r, &Thresholds::default());
            (t, r, p)
        })
        .unwrap();
    // Every length the import judges by is wrong in metres, so more checks fail; the unit comes
    // first, with the fix.
    assert_eq!(problems[0].cause, Cause::Radius, "{problems:?}");
    let text = problems[0].to_string();
    assert!(text.contains("mm is not a colon's") && text.contains("--units"), "{text}");
    // Declared, they import as the millimetre tube does.
    let (tube, rep, problems) = import(&m.to_mm(Unit::M), &line.to_mm(Unit::M));
    assert!(problems.is_empty(), "{problems:?}");
    assert!((rep.radius_mm[2] - R as f64).abs() < 0.05);
    assert_eq!(tube.rings(), import(&tube_mesh(), &midline()).0.rings());
}

#[test]
fn a_midline_in_voxels_beside_a_surface_in_mm_is_refused_until_declared() {
    let (size, origin) = ([0.7f32, 0.7, 1.25], [-80.0f32, -40.0, -30.0]);
    let mut line = midline();
    line.points.iter_mut().for_each(|p| *p = [0, 1, 2].map(|d| (p[d] - origin[d]) / size[d]));
    let (_, rep, problems) = build_tube(&tube_mesh(), &line, &params())
        .map(|(t, r)| {
            let p = assess(&r, &Thresholds::default());
            (t, r, p)
        })
        .unwrap();
    let c = causes(&problems);
    assert!(c.contains(&Cause::MidlineBeyond) && c.contains(&Cause::MidlineOutside), "{problems:?}");
    assert!(rep.midline_beyond_surface > 50.0, "{rep}");
    let (_, _, problems) = import(&tube_mesh(), &line.to_mm(Unit::Voxel { size, origin }));
    assert!(problems.is_empty(), "{problems:?}");
}

#[test]
fn a_doubled_wall_is_refused() {
    let m = tube_mesh();
    // The same surface written twice.
    let mut twice = m.clone();
    let off = twice.vertices.len() as u32;
    twice.vertices.extend_from_slice(&m.vertices);
    twice.triangles.extend(m.triangles.iter().map(|t| t.map(|i| i + off)));
    let (_, rep, problems) = import(&twice, &midline());
    assert!(rep.doubled > rep.rays / 2, "{rep}");
    assert!(causes(&problems).contains(&Cause::Doubled), "{problems:?}");
    // A second wall 0.1 mm behind the first, facing the other way (a wall with a thickness).
    let (line, mut shell) = (midline(), m.clone());
    for (n, v) in shell.vertices.iter_mut().enumerate() {
        let (c, _) = centre(length() * (n / AROUND).min(ALONG - 1) as f32 / (ALONG - 1) as f32);
        *v = [0, 1, 2].map(|d| c[d] + (v[d] - c[d]) * (R + 0.1) / R);
    }
    shell.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let mut thick = m.clone();
    let off = thick.vertices.len() as u32;
    thick.vertices.extend_from_slice(&shell.vertices);
    thick.triangles.extend(shell.triangles.iter().map(|t| t.map(|i| i + off)));
    let (_, rep, problems) = import(&thick, &line);
    assert!(rep.doubled > rep.rays / 2, "{rep}");
    let doubled = problems.iter().find(|p| p.cause == Cause::Doubled).expect("a doubled-wall problem");
    assert!(doubled.to_string().contains("doubled wall") && doubled.rings.len() == 1, "{doubled}");
}

#[test]
fn open_pieces_with_gaps_are_refused_at_the_gaps_and_a_triangle_soup_is_not() {
    let m = tube_mesh();
    // Triangle soup: every triangle its own vertices (as STL stores it): same surface.
    let mut soup = Mesh::default();
    for t in &m.triangles {
        let n = soup.vertices.len() as u32;
        soup.vertices.extend(t.map(|i| m.vertices[i as usize]));
        soup.triangles.push([n, n + 1, n + 2]);
    }
    assert!(import(&soup, &midline()).2.is_empty());
    // Three gaps, each a fifth of the tube's length, cut out of the wall (and the caps kept).
    let gap = |i: usize| [(10, 34), (50, 74), (90, 114)].iter().any(|&(a, b)| (a..b).contains(&i));
    let mut open = m.clone();
    open.triangles.retain(|t| t.iter().any(|&v| v as usize >= ALONG * AROUND) || !gap(t.iter().map(|&v| v as usize / AROUND).min().unwrap()));
    let (_, rep, problems) = import(&open, &midline());
    assert!(causes(&problems).contains(&Cause::MidlineOutside), "{problems:?}\n{rep}");
    let outside = problems.iter().find(|p| p.cause == Cause::MidlineOutside).unwrap();
    // Vertex ring i sits at i * length / 120 mm, ring j of the tube at 2 + 2 j mm.
    let ring = |i: usize| ((i as f32 * length() / (ALONG - 1) as f32 - 2.0) / 2.0).round() as usize;
    assert_eq!(outside.rings.len(), 3, "{outside}");
    for (r, (a, b)) in outside.rings.iter().zip([(10, 34), (50, 74), (90, 114)]) {
        assert!(r.start().abs_diff(ring(a)) <= 3 && r.end().abs_diff(ring(b)) <= 3, "{outside}: expected about {}-{}", ring(a), ring(b));
    }
}

#[test]
fn a_reversed_midline_imports_and_one_out_of_order_is_refused() {
    let (good, _, _) = import(&tube_mesh(), &midline());
    // Rays through the facets' shared edges (spoke k of a ring at a vertex ring's corner) are
    // cast again, not lost.
    let mut rev = midline();
    rev.points.reverse();
    let (tube, rep, problems) = import(&tube_mesh(), &rev);
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(rep.repaired(), 0);
    assert_eq!(tube.rings(), good.rings());
    // Rings start from the other end (the midline's points are smoothed with sigma 1 mm first).
    let (first, last) = (tube.points[0], *midline().points.last().unwrap());
    assert!((0..3).all(|d| (first[d] - last[d]).abs() < 1.0), "{first:?} vs {last:?}");
    assert!((rep.radius_mm[0] - R as f64).abs() < 0.05 && (rep.radius_mm[4] - R as f64).abs() < 0.05, "{rep}");
    // A stretch of points in reverse order: the midline runs back and forth over it.
    let mut shuffled = midline();
    shuffled.points[60..120].reverse();
    let (_, rep, problems) = import(&tube_mesh(), &shuffled);
    assert!(rep.turns_back.len() >= 2, "{:?}", rep.turns_back);
    let back = problems.iter().find(|p| p.cause == Cause::TurnsBack).expect("a turns-back problem");
    assert!(back.to_string().contains("are its points in order?"), "{back}");
}

#[test]
fn narrowings_name_the_rings_narrower_than_the_scope() {
    // A straight tube of radius 10 mm, 4 mm over rings 30 to 39 and 6 mm at ring 80.
    let (rings, b) = (100, 16);
    let radius = |i: usize| match i {
        30..=39 => 4.0,
        80 => 6.0,
        _ => 10.0,
    };
    let points: Vec<[f32; 3]> = (0..rings).map(|i| [0.0, 0.0, i as f32]).collect();
    let radial: Vec<[f32; 3]> = (0..rings * b)
        .map(|n| {
            let a = std::f32::consts::TAU * (n % b) as f32 / b as f32;
            [radius(n / b) * a.cos(), radius(n / b) * a.sin(), 0.0]
        })
        .collect();
    let tube = lumen_detect::Tube::new(points, radial, b).unwrap();
    let n = lumen_import::fit::narrowings(&tube, 6.5);
    assert_eq!(n.len(), 2, "{n:?}");
    assert_eq!((n[0].rings.clone(), n[1].rings.clone()), (30..=39, 80..=80));
    assert!((n[0].smallest - 4.0).abs() < 1e-5 && (n[1].smallest - 6.0).abs() < 1e-5);
    assert!(lumen_import::fit::narrowings(&tube, 3.9).is_empty());
}
