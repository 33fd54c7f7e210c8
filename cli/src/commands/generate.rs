//! `lumen generate --seed N -o DIR`: a seeded insufflated colon as a surface and a midline
//! ([`lumen_scene::insufflated`]), written as `surface.obj` and `midline.csv` for
//! `lumen import`: the hard class of colon (lumens wider than their bends, elliptical sections,
//! deep haustral folds, an anal canal narrower than a scope) without a CT scan.

use crate::commands::{CliError, CliResult};
use clap::Args;
use lumen_import::{write_centerline_csv, write_obj};
use lumen_scene::insufflated::{generate, SurfaceParams};
use std::io::Write;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// The seed: the same seed and flags write the same files.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Smallest and largest lumen radius outside the anal canal, mm, as `min,max`.
    #[arg(long, default_value = "25,50")]
    pub radius: String,
    /// Radius of the anal canal over its first 30 mm, mm (half a 13 mm scope's radius).
    #[arg(long, default_value_t = 3.25)]
    pub canal_radius: f32,
    /// Depth of the haustral folds, a fraction of the radius.
    #[arg(long, default_value_t = 0.3)]
    pub fold_depth: f32,
    /// Spacing of the haustral folds along the midline, mm.
    #[arg(long, default_value_t = 35.0)]
    pub fold_spacing: f32,
    /// Grid spacing of the surface mesh, mm.
    #[arg(long, default_value_t = 1.5)]
    pub voxel: f32,
    /// The folder to write `surface.obj` and `midline.csv` into (made if missing).
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn run(a: GenerateArgs) -> CliResult {
    let radius = match a.radius.split(',').map(|x| x.trim().parse::<f32>().ok()).collect::<Option<Vec<_>>>().as_deref() {
        Some(&[lo, hi]) => [lo, hi],
        _ => return Err(CliError::bad_flag("--radius", &a.radius, "two radii in mm as min,max")),
    };
    let p = SurfaceParams { seed: a.seed, radius_mm: radius, canal_radius_mm: a.canal_radius, fold_depth: a.fold_depth, fold_spacing_mm: a.fold_spacing, voxel_mm: a.voxel };
    let colon = generate(&p).map_err(|e| CliError::bad_flag(format!("--{}", e.name.replace('_', "-")), e.value, e.expected))?;
    std::fs::create_dir_all(&a.output).map_err(|source| CliError::Write { path: a.output.clone(), source })?;
    let write = |name: &str, f: &dyn Fn(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>| -> CliResult<PathBuf> {
        let path = a.output.join(name);
        let file = std::fs::File::create(&path).map_err(|source| CliError::Write { path: path.clone(), source })?;
        let mut w = std::io::BufWriter::new(file);
        f(&mut w).and_then(|()| w.flush()).map_err(|source| CliError::Write { path: path.clone(), source })?;
        Ok(path)
    };
    let surface = write("surface.obj", &|w| write_obj(&colon.mesh, w))?;
    let midline = write("midline.csv", &|w| write_centerline_csv(&colon.line, w))?;
    println!("insufflated colon, seed {}: {:.0} mm of midline, {} triangles", a.seed, colon.length_mm, colon.mesh.triangles.len());
    for b in &colon.bends {
        println!(
            "  {} {:.0} mm in: turns {:.0} degrees at a bend radius of {:.1} mm, a lumen of radius {:.1} mm ({:.2} of it), rolled {:.0} degrees",
            b.name,
            b.at_mm,
            b.turn_deg,
            b.radius_mm,
            b.lumen_mm,
            b.radius_mm / b.lumen_mm,
            b.roll_deg
        );
    }
    println!("wrote {} and {}", surface.display(), midline.display());
    println!("next: lumen import {} --centerline {} -o colon.lumen", surface.display(), midline.display());
    Ok(())
}
