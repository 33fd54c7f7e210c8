//! `lumen import <mesh> --centerline <csv> [--units U] [--spokes B] [--ring-spacing D]
//! [--inflate F] [--force] -o <model>`: a tube model from a triangle surface and its midline, by
//! ray casting ([`lumen_import`] does the work and counts every repaired spoke). A model that is
//! not a usable tube ([`lumen_import::quality`]) is refused with every problem named, unless
//! `--force`.

use crate::commands::{CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lumen_detect::model::{save_native_with, to_text};
use lumen_detect::Body;
use lumen_import::{assess, build_tube, load_centerline, load_mesh, ImportError, ImportParams, Thresholds, Unit};
use std::path::PathBuf;
use std::time::Duration;

#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The wall: a triangle surface (OBJ, STL, PLY, VTK legacy `.vtk` or XML `.vtp` polydata).
    pub mesh: PathBuf,
    /// The midline, points in order: CSV (`x,y,z` columns, or a header naming them) or JSON
    /// (an array of `[x, y, z]` or of objects with `x`, `y`, `z`, or 3D Slicer markups).
    #[arg(long)]
    pub centerline: PathBuf,
    /// The unit of the surface's coordinates: mm, cm, m, um, or voxel (with --voxel-size).
    /// Everything is converted to mm, the model's unit.
    #[arg(long, default_value = "mm")]
    pub units: String,
    /// The unit of the midline's coordinates, when it differs from the surface's (a midline in
    /// voxel indices beside a surface in mm, say).
    #[arg(long)]
    pub centerline_units: Option<String>,
    /// Voxel size in mm for `voxel` units: one value, or three as `x,y,z`.
    #[arg(long)]
    pub voxel_size: Option<String>,
    /// Position in mm of voxel (0, 0, 0) for `voxel` units, as `x,y,z`.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub voxel_origin: String,
    /// Write the model even when the import's quality checks refuse it (the problems are still
    /// printed).
    #[arg(long)]
    pub force: bool,
    /// Radial vectors per ring (the first count tried, with --fidelity).
    #[arg(long, default_value_t = 32)]
    pub spokes: usize,
    /// Raise the spokes 8 at a time (up to 64) while the wall lies farther than this from the
    /// surface at p99, in the mesh's unit after --units (0.5 is the mm Lumen aims for; the
    /// report says which counts it tried). Each try casts the whole colon again.
    #[arg(long)]
    pub fidelity: Option<f32>,
    /// Arc length between rings, in the mesh's unit.
    #[arg(long, default_value_t = 1.0)]
    pub ring_spacing: f32,
    /// Factor on every radial vector (2 turns the collapsed CT lumen of the GCA colon into an
    /// insufflated one).
    #[arg(long, default_value_t = 1.0)]
    pub inflate: f32,
    /// Gaussian smoothing of the midline's tangents along the arc, sigma, in the mesh's unit.
    /// The narrowest width tried (see --widest-smoothing).
    #[arg(long, default_value_t = 4.0)]
    pub tangent_smoothing: f32,
    /// Gaussian smoothing of the midline's points, sigma, in the mesh's unit.
    #[arg(long, default_value_t = 1.0)]
    pub point_smoothing: f32,
    /// The widest smoothing of the midline's tangents tried for the ring planes, in the mesh's
    /// unit: the import slices the tube at widths from --tangent-smoothing up to this and keeps
    /// the wall truest to the surface with the fewest spokes clipped at a crossing. Equal to
    /// --tangent-smoothing, the planes follow that one smoothing.
    #[arg(long, default_value_t = 64.0)]
    pub widest_smoothing: f32,
    /// The model to write: the method's text format when the name ends in `.txt`, else Lumen's
    /// native format (which also keeps the import's fidelity, for `lumen bench detect --model`).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn run(a: ImportArgs) -> CliResult {
    let params = ImportParams {
        spokes: a.spokes,
        fidelity_mm: a.fidelity.unwrap_or(0.0),
        ring_spacing: a.ring_spacing,
        inflate: a.inflate,
        tangent_smoothing_mm: a.tangent_smoothing,
        point_smoothing_mm: a.point_smoothing,
        widest_smoothing_mm: a.widest_smoothing,
    };
    // Refused before the files are read, naming the flag: a wrong flag should not cost a mesh
    // load.
    if let Err(e) = params.validate() {
        return Err(match e {
            ImportError::Param { name, value, expected } => CliError::bad_flag(format!("--{}", name.replace('_', "-")), value, expected),
            e => e.into(),
        });
    }
    let spinner = ProgressBar::new_spinner().with_style(ProgressStyle::with_template("{spinner} {msg} ({elapsed})").expect("a valid template"));
    spinner.enable_steady_tick(Duration::from_millis(120));
    spinner.set_message(format!("reading {}", a.mesh.display()));
    let mesh_unit = unit(&a.units, "--units", &a)?;
    let line_unit = match &a.centerline_units {
        Some(u) => unit(u, "--centerline-units", &a)?,
        None => mesh_unit,
    };
    let mesh = load_mesh(&a.mesh)?.to_mm(mesh_unit);
    let centerline = load_centerline(&a.centerline)?.to_mm(line_unit);
    let more = if params.fidelity_mm > 0.0 { " (more where the wall is not true to the surface)" } else { "" };
    spinner.set_message(format!("casting {} rays per ring{more} along {:.0} of midline", params.spokes, centerline.length()));
    let built = build_tube(&mesh, &centerline, &params);
    spinner.finish_and_clear();
    let (tube, report) = built?;
    println!("{report}");
    let problems = assess(&report, &Thresholds::default());
    for p in &problems {
        eprintln!("problem: {p}");
    }
    if !problems.is_empty() && !a.force {
        return Err(CliError::ImportRefused { mesh: a.mesh.clone(), problems: problems.len() });
    }
    let text = a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("txt"));
    // The native format keeps the import's fidelity beside the tube (`lumen bench detect
    // --model` reports it); the text format holds the tube alone.
    let bytes = if text { to_text(&tube).into_bytes() } else { save_native_with(&Body::Tube(tube), Some(&report.info())) };
    std::fs::write(&a.output, bytes).map_err(|source| CliError::Write { path: a.output.clone(), source })?;
    println!("wrote {} ({})", a.output.display(), if text { "text format: the tube alone, without the import's fidelity" } else { "native format, with the import's fidelity" });
    Ok(())
}

/// The unit a flag names; `voxel` takes `--voxel-size` and `--voxel-origin`.
fn unit(name: &str, flag: &str, a: &ImportArgs) -> CliResult<Unit> {
    if !name.eq_ignore_ascii_case("voxel") {
        return name.parse().map_err(|_| CliError::bad_flag(flag, name, "mm, cm, m, um or voxel"));
    }
    let Some(size) = &a.voxel_size else {
        return Err(CliError::bad_flag(flag, name, "--voxel-size too (the voxel's size in mm)"));
    };
    let size = match triple(size) {
        Some([x, y, z]) if [x, y, z].iter().all(|v| v.is_finite() && *v != 0.0) => [x, y, z],
        _ => match size.trim().parse::<f32>() {
            Ok(v) if v.is_finite() && v > 0.0 => [v; 3],
            _ => return Err(CliError::bad_flag("--voxel-size", size, "a size in mm, or three as x,y,z, none zero")),
        },
    };
    let origin = triple(&a.voxel_origin).filter(|o| o.iter().all(|v| v.is_finite())).ok_or_else(|| CliError::bad_flag("--voxel-origin", &a.voxel_origin, "three numbers in mm as x,y,z"))?;
    Ok(Unit::Voxel { size, origin })
}

/// Three comma-separated numbers.
fn triple(s: &str) -> Option<[f32; 3]> {
    let v: Vec<f32> = s.split(',').map(|x| x.trim().parse().ok()).collect::<Option<_>>()?;
    v.try_into().ok()
}
