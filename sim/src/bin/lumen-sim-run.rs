//! Runs the scripted colonoscopy with in-process detection and prints its figures (until
//! `lumen sim` takes over with the daemon).
//!
//! `lumen-sim-run [--frames N] [--scene generated|gca] [--data DIR] [--seed S] [--length MM]
//! [--every K] [--no-self]`

use lumen_sim::{setup, SimConfig, World};
use std::time::Instant;

fn main() {
    let mut frames = 3000u64;
    let mut scene = "generated".to_string();
    let mut data = None;
    let mut seed = 1u64;
    let mut length = 1500.0f32;
    let mut every = 0u64;
    let mut config = SimConfig::default();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--frames" => frames = val().parse().expect("--frames N"),
            "--scene" => scene = val(),
            "--data" => data = Some(std::path::PathBuf::from(val())),
            "--seed" => seed = val().parse().expect("--seed S"),
            "--length" => length = val().parse().expect("--length MM"),
            "--every" => every = val().parse().expect("--every K"),
            "--substeps" => config.sim.substeps = val().parse().expect("--substeps N"),
            "--no-self" => config.sim.self_contact = false,
            "--wall-max" => config.wall.max_out_mm = val().parse().expect("mm"),
            "--wall-membrane" => config.wall.membrane_ratio = val().parse().expect("ratio"),
            "--wall-k" => config.wall.stiffness_kpa_per_mm = val().parse().expect("kPa/mm"),
            "--wall-mass" => config.wall.areal_mass_kg_m2 = val().parse().expect("kg/m2"),
            "--wall-node" => config.wall.node_spacing_mm = val().parse().expect("mm"),
            "--wall-damping" => config.wall.damping_per_s = val().parse().expect("1/s"),
            "--ei" => config.rod.flexural_rigidity_nm2 = val().parse().expect("N m2"),
            "--relax" => config.sim.relax_s = val().parse().expect("s"),
            "--margin" => config.sim.margin_mm = val().parse().expect("mm"),
            "--passes" => config.sim.contact_passes = val().parse().expect("n"),
            "--gravity" => config.sim.gravity_mm_s2[1] = -val().parse::<f64>().expect("mm/s2"),
            "--max-speed" => config.sim.max_speed_mm_s = val().parse().expect("mm/s"),
            "--rod-damping" => config.rod.damping_per_s = val().parse().expect("1/s"),
            "--rod" => {
                let l: f64 = val().parse().expect("--rod MM");
                config.rod.length_mm = l;
                config.rod.points = ((l / 1600.0 * 159.0).round() as usize + 1).max(3);
            }
            other => panic!("unknown argument {other}"),
        }
    }
    let t0 = Instant::now();
    let colon = match scene.as_str() {
        "generated" => setup::generated_colon(seed, length),
        "gca" => setup::gca_colon(data.as_deref()).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        }),
        other => panic!("unknown scene {other}"),
    };
    if scene == "gca" {
        eprintln!("data: {}", lumen_scene::gca_attribution());
    }
    if std::env::var("DEBUG_BEND").is_ok() {
        let lm = lumen_scene::probe::Lumen::new(&colon);
        let n = lm.rings();
        let arc = lm.arc().to_vec();
        let pts: Vec<_> = (0..n).map(|i| lm.point(i)).collect();
        let mut bad = Vec::new();
        for i in 0..n {
            let r = lm.max_radius(i);
            let (a, b) = (arc[i] - r, arc[i] + r);
            if a < 0.0 || b > arc[n - 1] { continue; }
            let pa = lumen_scene::geom::at_arc(&pts, &arc, a);
            let pb = lumen_scene::geom::at_arc(&pts, &arc, b);
            let pc = pts[i];
            let (x, y, z) = ((pa - pc).norm(), (pb - pc).norm(), (pa - pb).norm());
            let area2 = (pa - pc).cross(&(pb - pc)).norm();
            let rc = if area2 > 1e-12 { x * y * z / (2.0 * area2) } else { f64::INFINITY };
            if rc / r < 1.0 { bad.push((i, rc / r)); }
        }
        eprintln!("{} rings with bend ratio < 1:", bad.len());
        let mut k = 0;
        while k < bad.len() {
            let mut e = k;
            while e + 1 < bad.len() && bad[e + 1].0 == bad[e].0 + 1 { e += 1; }
            let m = bad[k..=e].iter().map(|b| b.1).fold(f64::MAX, f64::min);
            eprintln!("  rings {}..={} (arc {:.0}..{:.0} mm), min ratio {:.2}", bad[k].0, bad[e].0, arc[bad[k].0], arc[bad[e].0], m);
            k = e + 1;
        }
        return;
    }
    if std::env::var("DEBUG_STATIC").is_ok() {
        let spec = setup::scene_spec(&colon, &config.rod, &config.sim);
        let lm = lumen_scene::probe::Lumen::new(&colon);
        for depth in (50..=900).step_by(50) {
            let pts = setup::insertion_pose(&colon, &config.rod, depth as f64);
            for rev in [false, true] {
                let mut det = lumen_detect::Detector::new(&spec).unwrap();
                let mut state = Vec::new();
                colon.write_state(&mut state);
                let order: Vec<_> = if rev { pts.iter().rev().collect() } else { pts.iter().collect() };
                for p in order { state.extend_from_slice(&[p.x as f32, p.y as f32, p.z as f32]); }
                let cs = det.detect(&state).unwrap().to_vec();
                let out: Vec<_> = cs.iter().filter(|c| c.kind == 0 && c.flags & 2 != 0).collect();
                let maxd = cs.iter().filter(|c| c.kind == 0).map(|c| c.depth).fold(f32::MIN, f32::max);
                // probe: control points inside?
                let mut probe_out = 0;
                for p in &pts { if let Some(pr) = lm.locate([p.x as f32, p.y as f32, p.z as f32], 0) { if pr.gap() < 0.0 { probe_out += 1; } } }
                eprintln!("depth {depth} {}: {} contacts, outside {} (max depth {:.2}) {:?}; probe: {} control points outside", if rev { "handle-first" } else { "tip-first" }, cs.len(), out.len(), maxd, out.iter().take(4).map(|c| (c.sample, c.index_b, c.depth)).collect::<Vec<_>>(), probe_out);
            }
        }
        return;
    }
    if std::env::var("DEBUG_CLEAR2").is_ok() {
        let c = lumen_scene::probe::clearance(&colon);
        eprintln!("{c:?}");
        return;
    }
    if std::env::var("DEBUG_CLEAR").is_ok() {
        let p: Vec<[f32; 3]> = colon.points.clone();
        let rmax: Vec<f32> = (0..colon.rings()).map(|i| (0..colon.spokes).map(|k| { let v = colon.spoke(i, k); (v[0]*v[0]+v[1]*v[1]+v[2]*v[2]).sqrt() }).fold(0.0, f32::max)).collect();
        let rmin: Vec<f32> = (0..colon.rings()).map(|i| (0..colon.spokes).map(|k| { let v = colon.spoke(i, k); (v[0]*v[0]+v[1]*v[1]+v[2]*v[2]).sqrt() }).fold(f32::MAX, f32::min)).collect();
        for i in (0..colon.rings()).step_by(10) {
            let mut best = (f32::MAX, 0);
            for j in 0..colon.rings() {
                if (i as i64 - j as i64).abs() < 80 { continue; }
                let d = ((p[i][0]-p[j][0]).powi(2)+(p[i][1]-p[j][1]).powi(2)+(p[i][2]-p[j][2]).powi(2)).sqrt() - rmax[i] - rmax[j];
                if d < best.0 { best = (d, j); }
            }
            eprintln!("ring {i}: rmin {:.1} rmax {:.1}; nearest far ring {} gap {:.1}", rmin[i], rmax[i], best.1, best.0);
        }
        return;
    }
    let bend = setup::sigmoid_bend_mm(&colon);
    eprintln!("{scene} colon: {} rings x {} spokes; sigmoid bend at {bend:.0} mm; built in {:.2?}", colon.rings(), colon.spokes, t0.elapsed());
    let mut world = World::in_process(&colon, config).expect("world");
    let r0 = world.report().clone();
    eprintln!("initial fit: {} detections", world.fit_iterations());
    if std::env::var("DEBUG_INIT").is_ok() {
        for c in world.contacts() {
            eprintln!("  kind {} sample {} seg {} b {} depth {:.3} n {:?} pa {:?}", c.kind, c.sample, c.segment_a, c.index_b, c.depth, c.normal, c.point_a);
        }
        let (o, a) = setup::insertion_axis(&colon);
        eprintln!("axis o {:?} a {:?}", o.as_slice(), a.as_slice());
        for (i, p) in world.rod().x.iter().enumerate().step_by(5) {
            eprintln!("  x[{i}] {:?} s {:.1}", p.as_slice(), a.dot(&(p - o)));
        }
    }
    eprintln!("initial: {} contacts, max penetration {:.3} mm, escaped {}", r0.contacts, r0.max_penetration_mm, r0.escaped);
    let (mut pen, mut esc_frames, mut esc_max, mut contacts_max, mut self_pen) = (0.0f32, 0u64, 0u32, 0u32, 0.0f32);
    let (mut physics, mut detect) = (0.0f64, 0.0f64);
    let (mut limited_frames, mut body_flagged) = (0u64, 0u32);
    let (mut worst_frame, mut max_force, mut max_wall, mut min_len, mut max_len, mut max_nodes) = (0u64, 0.0f64, 0.0f32, 0.0f64, 0.0f64, 0u32);
    let mut phase_pen: Vec<(&str, f32, u32)> = Vec::new();
    let t = Instant::now();
    let debug_pen: Option<f32> = std::env::var("DEBUG_PEN").ok().map(|v| v.parse().unwrap());
    for _ in 0..frames {
        let prev: Vec<lumen_proto::Contact> = if debug_pen.is_some() { world.contacts().to_vec() } else { Vec::new() };
        let r = match world.step() {
            Ok(r) => r.clone(),
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        if let Ok(range) = std::env::var("DEBUG_TIP") {
            let (a, b) = range.split_once('-').unwrap();
            if r.frame >= a.parse().unwrap() && r.frame <= b.parse().unwrap() {
                let rod = world.rod();
                let cs: Vec<String> = world.contacts().iter().filter(|c| c.sample <= 1 && c.kind == 0).map(|c| format!("s{} d{:+.3} n[{:+.2},{:+.2},{:+.2}] r{} k{}", c.sample, c.depth, c.normal[0], c.normal[1], c.normal[2], c.index_b, c.spoke_b)).collect();
                eprintln!("{} x0 [{:.2},{:.2},{:.2}] v0 [{:+.0},{:+.0},{:+.0}] | {}", r.frame, rod.x[0].x, rod.x[0].y, rod.x[0].z, rod.v[0].x, rod.v[0].y, rod.v[0].z, cs.join(" | "));
            }
        }
        if let Some(th) = debug_pen {
            if r.max_penetration_mm > th {
                let c = world.contacts().iter().find(|c| c.sample == r.deepest_sample && c.kind == 0).unwrap();
                let p = prev.iter().find(|p| p.sample == c.sample && p.kind == 0);
                let v = world.rod().v[c.segment_a as usize].norm();
                eprintln!("frame {} ({}): sample {} depth {:.3} flags {} n {:?} seg {} ring {} spoke {} w {:?}; v {:.0} mm/s; before: {}", r.frame, r.phase_name, c.sample, c.depth, c.flags, c.normal, c.segment_a, c.index_b, c.spoke_b, c.weights_b, v,
                    p.map_or("none".to_string(), |p| format!("depth {:.3} n {:?} ring {} spoke {}", p.depth, p.normal, p.index_b, p.spoke_b)));
            }
        }
        physics += r.physics_s;
        limited_frames += (r.speed_limited > 0) as u64;
        body_flagged = body_flagged.max(r.outside_body_flagged);
        detect += r.detect_s;
        if r.max_penetration_mm > pen {
            pen = r.max_penetration_mm;
            worst_frame = r.frame;
        }
        if r.escaped > 0 {
            esc_frames += 1;
            if esc_frames <= 5 {
                eprintln!("frame {}: {} escaped samples ({})", r.frame, r.escaped, r.phase_name);
            }
        }
        esc_max = esc_max.max(r.escaped);
        contacts_max = contacts_max.max(r.contacts);
        self_pen = self_pen.max(r.max_self_penetration_mm);
        max_force = max_force.max(r.hand_force_n);
        max_wall = max_wall.max(r.max_wall_mm);
        max_nodes = max_nodes.max(r.active_nodes);
        min_len = min_len.min(r.length_error);
        max_len = max_len.max(r.length_error);
        match phase_pen.last_mut() {
            Some(p) if p.0 == r.phase_name => {
                p.1 = p.1.max(r.max_penetration_mm);
                p.2 = p.2.max(r.escaped);
            }
            _ => phase_pen.push((r.phase_name, r.max_penetration_mm, r.escaped)),
        }
        if std::env::var("DEBUG_FAST").is_ok() {
            let rod = world.rod();
            let (i, v) = rod.v.iter().enumerate().map(|(i, v)| (i, v.norm())).fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
            eprintln!("   fastest point {i} at {v:.0} mm/s, pos {:?}", rod.x[i].as_slice());
        }
        if every > 0 && r.frame % every == 0 {
            eprintln!(
                "frame {:5} {:>11}: contacts {:3} touching {:3} pen {:.3} mm @{} esc {} ({} body) self {:.2} | v {:6.0} lim {} | nodes {:4} wall {:5.2} mm | hand {:6.2} N handle {:8.2} mm | dL {:+.2e} | phys {:5.0} us det {:5.0} us",
                r.frame, r.phase_name, r.contacts, r.touching, r.max_penetration_mm, r.deepest_sample as i64, r.escaped, r.outside_body_flagged, r.max_self_penetration_mm, r.max_speed_mm_s, r.speed_limited, r.active_nodes, r.max_wall_mm, r.hand_force_n, r.handle_mm, r.length_error, r.physics_s * 1e6, r.detect_s * 1e6
            );
        }
    }
    let wall_s = t.elapsed().as_secs_f64();
    println!("frames {frames}: {:.0} frames/s wall ({:.1} us/frame: physics {:.1} us, detection {:.1} us)", frames as f64 / wall_s, wall_s / frames as f64 * 1e6, physics / frames as f64 * 1e6, detect / frames as f64 * 1e6);
    println!("max penetration {pen:.3} mm (frame {worst_frame}); frames with escaped samples {esc_frames} (max {esc_max}); contacts max {contacts_max}; self penetration max {self_pen:.3} mm");
    println!("frames with the speed limit engaged {limited_frames}; outside-body samples flagged by the detector (max per frame) {body_flagged}");
    println!("hand force max {max_force:.1} N; wall displacement max {max_wall:.2} mm; active nodes max {max_nodes}; length error {min_len:+.2e} .. {max_len:+.2e}");
    for (name, p, e) in phase_pen {
        println!("  {name:>11}: max penetration {p:.3} mm, max escaped {e}");
    }
}
