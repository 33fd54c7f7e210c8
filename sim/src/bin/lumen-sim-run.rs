//! Runs the scripted colonoscopy with in-process detection and prints its figures: the
//! physics developer's variant of `lumen sim` (which runs the same [`World`] against the daemon,
//! see `cli/src/commands/sim.rs`), with the tuning and tracing flags below.
//!
//! `cargo run --release -p lumen-sim --bin lumen-sim-run -- --help` lists the flags.

use clap::{Parser, ValueEnum};
use lumen_scene::ColonKind;
use lumen_sim::{setup, SimConfig, World};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ScriptKind {
    /// The 3,000-frame colonoscopy with the hard push at the sigmoid.
    Default,
    /// The 600-frame version the tests run.
    Short,
}

/// The scripted colonoscopy with in-process detection, and its figures.
#[derive(Debug, Parser)]
#[command(name = "lumen-sim-run")]
struct Args {
    /// Frames to run (1 ms each).
    #[arg(long, default_value_t = 3000)]
    frames: u64,
    /// The colon: generated (seeded), one of its variants, gca (needs its files, see --data) or
    /// insufflated (seeded, imported).
    #[arg(long, default_value = "generated")]
    scene: ColonKind,
    /// Directory of the GCA colon's files (default ../shared/data/colon-gca00090).
    #[arg(long)]
    data: Option<PathBuf>,
    /// A colon model written by `lumen import` (native, or the text format when it ends in
    /// `.txt`), in mm; replaces --scene.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Inflation of the GCA colon.
    #[arg(long, default_value_t = setup::GCA_INFLATE)]
    inflate: f32,
    /// Seed of the generated colon.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of the generated colon, mm.
    #[arg(long, default_value_t = 1500.0)]
    length: f32,
    /// Print a line every K frames (0: none).
    #[arg(long, default_value_t = 0)]
    every: u64,
    /// Print the deepest contact of every frame deeper than this, mm, with what the same sample
    /// had at the frame's start.
    #[arg(long)]
    trace_pen: Option<f32>,
    #[arg(long, value_enum, default_value = "default")]
    script: ScriptKind,
    /// Seconds the scope rests before the script starts.
    #[arg(long)]
    relax: Option<f64>,
    /// No rod self-contact.
    #[arg(long)]
    no_self: bool,
    #[arg(long)]
    substeps: Option<u32>,
    /// Axial re-projections of the detector.
    #[arg(long)]
    refine: Option<u32>,
    /// Contacts from the sections' own readings, not moved to the nearest point of the
    /// continuous wall (the spec's `nearest` off).
    #[arg(long)]
    sections: bool,
    /// No crease faces beside the contacts of the scope's end segments (see `lumen_sim::crease`).
    #[arg(long)]
    no_crease_faces: bool,
    #[arg(long)]
    stretch_passes: Option<u32>,
    /// Contact projections per substep.
    #[arg(long)]
    contact_passes: Option<u32>,
    /// Speed limit of the rod's points, mm/s.
    #[arg(long)]
    max_speed: Option<f64>,
    /// Contact margin, mm.
    #[arg(long)]
    margin: Option<f32>,
    /// Largest outward displacement of the wall, mm.
    #[arg(long)]
    wall_max: Option<f64>,
    /// Spacing of the wall's nodes, mm.
    #[arg(long)]
    wall_node: Option<f64>,
    /// Membrane stiffness as a ratio of the spring stiffness.
    #[arg(long)]
    wall_membrane: Option<f64>,
    /// Wall stiffness, kPa per mm.
    #[arg(long)]
    wall_stiffness: Option<f64>,
    /// Moves the scope's start deeper by this many micrometres (default 0): a trajectory of the
    /// same colonoscopy that differs from the first frame on.
    #[arg(long, default_value_t = 0)]
    start_offset_um: u32,
    /// Runs the colonoscopy this many times, from start offsets of 0, 1, ... micrometres (after
    /// --start-offset-um), two at a time, and reports each run's deepest frame and the worst:
    /// soundness over an ensemble of trajectories, not one draw.
    #[arg(long, default_value_t = 1)]
    ensemble: u32,
}

fn main() {
    let a = Args::parse();
    let (frames, every, trace_pen) = (a.frames, a.every, a.trace_pen);
    let mut config = SimConfig::default();
    if a.script == ScriptKind::Short {
        config.script = lumen_sim::Script::short_colonoscopy();
    }
    let sim = &mut config.sim;
    sim.self_contact &= !a.no_self;
    if let Some(v) = a.relax {
        sim.relax_s = v
    }
    if let Some(v) = a.substeps {
        sim.substeps = v
    }
    if let Some(v) = a.refine {
        sim.refine = v
    }
    sim.nearest &= !a.sections;
    sim.crease_faces &= !a.no_crease_faces;
    if let Some(v) = a.stretch_passes {
        sim.stretch_passes = v
    }
    if let Some(v) = a.contact_passes {
        sim.contact_passes = v
    }
    if let Some(v) = a.max_speed {
        sim.max_speed_mm_s = v
    }
    if let Some(v) = a.margin {
        sim.margin_mm = v
    }
    let wall = &mut config.wall;
    if let Some(v) = a.wall_max {
        wall.max_out_mm = v
    }
    if let Some(v) = a.wall_node {
        wall.node_spacing_mm = v
    }
    if let Some(v) = a.wall_membrane {
        wall.membrane_ratio = v
    }
    if let Some(v) = a.wall_stiffness {
        wall.stiffness_kpa_per_mm = v
    }
    let scene = match &a.model {
        Some(p) => format!("model {}", p.display()),
        None => a.scene.name().to_string(),
    };
    let t0 = Instant::now();
    let colon = match (&a.model, a.scene.generated(a.seed)) {
        (Some(path), _) => setup::model_colon(path).unwrap_or_else(|e| {
            eprintln!("{}: {e}", path.display());
            std::process::exit(2)
        }),
        (None, Some(p)) => lumen_scene::generate(&lumen_scene::ColonParams { length_mm: a.length, ..p }),
        (None, None) => lumen_sim::setup::colon_inflated(a.scene, a.seed, a.data.as_deref(), a.inflate).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        }),
    };
    if a.model.is_none() && a.scene == ColonKind::Gca {
        println!("data: {}", lumen_scene::gca::attribution());
    }
    let bend = setup::sigmoid_bend_mm(&colon);
    println!("{scene} colon: {} rings x {} spokes, built in {:.2?}; hard push at the bend {bend:.0} mm from the anus", colon.rings(), colon.spokes, t0.elapsed());
    let start = setup::start_depth_mm(&colon);
    let depth_mm = |k: u32| start + (a.start_offset_um + k) as f64 * 1e-3;
    if a.ensemble > 1 {
        ensemble(&colon, &config, a.ensemble, frames, depth_mm);
        return;
    }
    config.start_depth_mm = Some(depth_mm(0));
    let mut world = World::in_process(&colon, config).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    let r0 = world.report().clone();
    println!("start: initial fit {} detections; {} contacts, max penetration {:.3} mm, escaped {}", world.fit_iterations(), r0.contacts, r0.max_penetration_mm, r0.escaped);
    struct Phase {
        name: &'static str,
        frames: u64,
        pen: f32,
        escaped: u32,
    }
    let mut phases: Vec<Phase> = Vec::new();
    let (mut pen, mut worst_frame, mut esc_frames, mut esc_max, mut contacts_max) = (0.0f32, 0u64, 0u64, 0u32, 0u32);
    let mut creases = (0u32, 0u64);
    let (mut self_pen, mut max_force, mut max_wall, mut min_len, mut max_nodes) = (0.0f32, 0.0f64, 0.0f32, 0.0f64, 0u32);
    let (mut limited_frames, mut body_flagged, mut physics, mut detect) = (0u64, 0u32, 0.0f64, 0.0f64);
    let t = Instant::now();
    for _ in 0..frames {
        let before: Vec<lumen_proto::Contact> = if trace_pen.is_some() { world.contacts().to_vec() } else { Vec::new() };
        let r = match world.step() {
            Ok(r) => r.clone(),
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        physics += r.physics_s;
        detect += r.detect_s;
        if trace_pen.is_some_and(|t| r.max_penetration_mm > t) {
            // The deepest contact, and what the same sample had at the frame's start.
            let c = world.contacts().iter().find(|c| c.sample == r.deepest_sample && c.kind == 0).expect("deepest contact");
            let was: Vec<String> = before
                .iter()
                .filter(|p| p.sample == c.sample && p.kind == 0)
                .map(|p| format!("depth {:.3} mm flags {} normal {:?} at ring {} spoke {}", p.depth, p.flags, p.normal, p.index_b, p.spoke_b))
                .collect();
            println!(
                "frame {} ({}): sample {} depth {:.3} mm flags {} normal {:?} at ring {} spoke {}; at the frame's start: {}",
                r.frame,
                r.phase_name,
                c.sample,
                c.depth,
                c.flags,
                c.normal,
                c.index_b,
                c.spoke_b,
                if was.is_empty() { "no contact".to_string() } else { was.join("; ") }
            );
        }
        if r.max_penetration_mm > pen {
            (pen, worst_frame) = (r.max_penetration_mm, r.frame);
        }
        esc_frames += (r.escaped > 0) as u64;
        esc_max = esc_max.max(r.escaped);
        contacts_max = contacts_max.max(r.contacts);
        creases = (creases.0.max(r.crease_faces), creases.1 + r.crease_faces as u64);
        self_pen = self_pen.max(r.max_self_penetration_mm);
        max_force = max_force.max(r.hand_force_n);
        max_wall = max_wall.max(r.max_wall_mm);
        max_nodes = max_nodes.max(r.active_nodes);
        min_len = min_len.min(r.length_error);
        limited_frames += (r.speed_limited > 0) as u64;
        body_flagged = body_flagged.max(r.outside_body_flagged);
        match phases.last_mut() {
            Some(p) if p.name == r.phase_name => {
                p.frames += 1;
                p.pen = p.pen.max(r.max_penetration_mm);
                p.escaped = p.escaped.max(r.escaped);
            }
            _ => phases.push(Phase { name: r.phase_name, frames: 1, pen: r.max_penetration_mm, escaped: r.escaped }),
        }
        if every > 0 && r.frame % every == 0 {
            println!(
                "frame {:5} {:>11}: contacts {:3} touching {:3} pen {:.3} mm esc {} self {:.2} mm | wall nodes {:4} up to {:5.2} mm | hand {:6.2} N, handle {:8.2} mm | dL/L {:+.1e} | {:4.0} + {:4.0} us",
                r.frame,
                r.phase_name,
                r.contacts,
                r.touching,
                r.max_penetration_mm,
                r.escaped,
                r.max_self_penetration_mm,
                r.active_nodes,
                r.max_wall_mm,
                r.hand_force_n,
                r.handle_mm,
                r.length_error,
                r.physics_s * 1e6,
                r.detect_s * 1e6
            );
        }
    }
    let wall_s = t.elapsed().as_secs_f64();
    let n = frames.max(1) as f64;
    println!("{frames} frames: {:.0} frames/s ({:.1} us/frame: physics {:.1} us, detection {:.1} us)", frames as f64 / wall_s, wall_s / n * 1e6, physics / n * 1e6, detect / n * 1e6);
    println!("max penetration {pen:.3} mm (frame {worst_frame}); frames with escaped samples {esc_frames} (at most {esc_max} in a frame); contacts at most {contacts_max}; crease faces at most {}, {:.1} a frame; self penetration at most {self_pen:.3} mm; no NaN", creases.0, creases.1 as f64 / frames.max(1) as f64);
    println!("hand force up to {max_force:.1} N; wall displaced up to {max_wall:.2} mm, at most {max_nodes} wall nodes active; scope length error down to {min_len:+.2e}");
    println!("frames where the speed limit engaged {limited_frames}; samples behind the anus flagged outside by the detector (not escapes) at most {body_flagged} per frame");
    for p in phases {
        println!("  {:>11} ({:4} frames): max penetration {:.3} mm, escaped at most {}", p.name, p.frames, p.pen, p.escaped);
    }
}

/// One run of an ensemble: its deepest penetration (mm), that frame, and the frames with an
/// escaped sample.
struct Outcome {
    pen: f32,
    frame: u64,
    escaped_frames: u64,
    error: Option<String>,
}

/// `n` runs of the colonoscopy from start depths `depth_mm(k)`, two at a time; prints each and
/// the worst, and exits 1 if any run went deeper than 1 mm, let a sample escape or failed.
fn ensemble(colon: &lumen_detect::Tube, config: &SimConfig, n: u32, frames: u64, depth_mm: impl Fn(u32) -> f64 + Sync) {
    let next = std::sync::atomic::AtomicU32::new(0);
    let outcomes = std::sync::Mutex::new(Vec::new());
    let workers = std::thread::available_parallelism().map_or(1, |p| p.get()).min(n as usize);
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if k >= n {
                    break;
                }
                let config = SimConfig { start_depth_mm: Some(depth_mm(k)), ..config.clone() };
                let o = run_quiet(colon, config, frames);
                println!(
                    "start {:+.3} mm: max penetration {:.3} mm (frame {}), frames with escaped samples {}{}",
                    depth_mm(k) - depth_mm(0),
                    o.pen,
                    o.frame,
                    o.escaped_frames,
                    o.error.as_deref().map(|e| format!(", stopped: {e}")).unwrap_or_default()
                );
                outcomes.lock().unwrap().push((k, o));
            });
        }
    });
    let outcomes = outcomes.into_inner().unwrap();
    let (k, worst) = outcomes.iter().max_by(|a, b| a.1.pen.total_cmp(&b.1.pen)).expect("n > 1 runs");
    let over = outcomes.iter().filter(|(_, o)| o.pen > 1.0 || o.escaped_frames > 0 || o.error.is_some()).count();
    let mean = outcomes.iter().map(|(_, o)| o.pen as f64).sum::<f64>() / outcomes.len() as f64;
    println!(
        "ensemble of {n}: worst max penetration {:.3} mm (start {:+.3} mm, frame {}), mean {mean:.3} mm; runs over 1 mm, escaped or stopped: {over}",
        worst.pen,
        depth_mm(*k) - depth_mm(0),
        worst.frame
    );
    if over > 0 {
        std::process::exit(1);
    }
}

/// One colonoscopy, silent.
fn run_quiet(colon: &lumen_detect::Tube, config: SimConfig, frames: u64) -> Outcome {
    let mut o = Outcome { pen: 0.0, frame: 0, escaped_frames: 0, error: None };
    let mut world = match World::in_process(colon, config) {
        Ok(w) => w,
        Err(e) => return Outcome { error: Some(e.to_string()), ..o },
    };
    for _ in 0..frames {
        match world.step() {
            Ok(r) => {
                if r.max_penetration_mm > o.pen {
                    (o.pen, o.frame) = (r.max_penetration_mm, r.frame);
                }
                o.escaped_frames += (r.escaped > 0) as u64;
            }
            Err(e) => {
                o.error = Some(e.to_string());
                break;
            }
        }
    }
    o
}
