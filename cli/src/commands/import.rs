//! `lumen import <mesh> --centerline <csv> [--spokes B] [--ring-spacing D] [--inflate F] -o <model>`:
//! a tube model from a triangle surface and its midline, by ray casting
//! ([`lumen_import`] does the work and counts every repaired spoke).

use crate::commands::{CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lumen_detect::model::{save_native, to_text};
use lumen_detect::Body;
use lumen_import::{build_tube, load_centerline_csv, load_mesh, ImportError, ImportParams};
use std::path::PathBuf;
use std::time::Duration;

#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The wall: a triangle surface (`.obj`, or `.stl` binary or ASCII), in the unit the model
    /// will have (mm for the GCA colon).
    pub mesh: PathBuf,
    /// The midline: a CSV of points in order (`x,y,z` columns, or a header naming them).
    #[arg(long)]
    pub centerline: PathBuf,
    /// Radial vectors per ring.
    #[arg(long, default_value_t = 32)]
    pub spokes: usize,
    /// Arc length between rings, in the mesh's unit.
    #[arg(long, default_value_t = 1.0)]
    pub ring_spacing: f32,
    /// Factor on every radial vector (2 turns the collapsed CT lumen of the GCA colon into an
    /// insufflated one).
    #[arg(long, default_value_t = 1.0)]
    pub inflate: f32,
    /// Gaussian smoothing of the midline's tangents along the arc, sigma, in the mesh's unit.
    /// Raise it where the midline bends tighter than the lumen is wide (the report counts those
    /// rings): the `gca` scene uses 24 mm.
    #[arg(long, default_value_t = 4.0)]
    pub tangent_smoothing: f32,
    /// Gaussian smoothing of the midline's points, sigma, in the mesh's unit.
    #[arg(long, default_value_t = 1.0)]
    pub point_smoothing: f32,
    /// The model to write: the method's text format when the name ends in `.txt`, else Lumen's
    /// native format.
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn run(a: ImportArgs) -> CliResult {
    let params = ImportParams { spokes: a.spokes, ring_spacing: a.ring_spacing, inflate: a.inflate, tangent_smoothing_mm: a.tangent_smoothing, point_smoothing_mm: a.point_smoothing };
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
    let mesh = load_mesh(&a.mesh)?;
    let centerline = load_centerline_csv(&a.centerline)?;
    spinner.set_message(format!("casting {} rays per ring along {:.0} of midline", a.spokes, centerline.length()));
    let built = build_tube(&mesh, &centerline, &params);
    spinner.finish_and_clear();
    let (tube, report) = built?;
    let text = a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("txt"));
    let bytes = if text { to_text(&tube).into_bytes() } else { save_native(&Body::Tube(tube)) };
    std::fs::write(&a.output, bytes).map_err(|source| CliError::Write { path: a.output.clone(), source })?;
    println!("{report}");
    println!("wrote {} ({})", a.output.display(), if text { "text format" } else { "native format" });
    Ok(())
}
