//! Lengths as labs write them: millimetres, centimetres, metres, micrometres, or voxel indices
//! of a CT volume; every import works in millimetres.

use crate::{Centerline, ImportError, Mesh};
use std::fmt;
use std::str::FromStr;

/// The unit of a surface's or a midline's coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Unit {
    Mm,
    Cm,
    M,
    Um,
    /// Voxel indices: `origin + index * size` (both in mm, per axis) is the point in mm.
    Voxel {
        size: [f32; 3],
        origin: [f32; 3],
    },
}

impl Unit {
    /// The point `p` in millimetres.
    pub fn to_mm(&self, p: [f32; 3]) -> [f32; 3] {
        match *self {
            Unit::Mm => p,
            Unit::Cm => p.map(|x| x * 10.0),
            Unit::M => p.map(|x| x * 1000.0),
            Unit::Um => p.map(|x| x * 1e-3),
            Unit::Voxel { size, origin } => [0, 1, 2].map(|d| origin[d] + p[d] * size[d]),
        }
    }

    /// Whether the unit mirrors space (a voxel size with an odd number of negative axes), which
    /// turns the surface inside out.
    pub fn mirrors(&self) -> bool {
        matches!(self, Unit::Voxel { size, .. } if size.iter().filter(|s| **s < 0.0).count() % 2 == 1)
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Unit::Mm => write!(f, "mm"),
            Unit::Cm => write!(f, "cm"),
            Unit::M => write!(f, "m"),
            Unit::Um => write!(f, "um"),
            Unit::Voxel { size, origin } => write!(f, "voxel (size {size:?} mm, origin {origin:?} mm)"),
        }
    }
}

/// `mm`, `cm`, `m` or `um`; a voxel unit is built with [`Unit::Voxel`] (it needs its size).
impl FromStr for Unit {
    type Err = ImportError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "mm" => Ok(Unit::Mm),
            "cm" => Ok(Unit::Cm),
            "m" => Ok(Unit::M),
            "um" | "µm" => Ok(Unit::Um),
            _ => Err(ImportError::Param { name: "units", value: s.to_string(), expected: "mm, cm, m, um or voxel".into() }),
        }
    }
}

impl Mesh {
    /// The surface with its vertices in mm; a mirroring unit also reverses the triangles'
    /// winding, so their normals keep facing the same side.
    pub fn to_mm(mut self, unit: Unit) -> Self {
        for v in &mut self.vertices {
            *v = unit.to_mm(*v);
        }
        if unit.mirrors() {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
        self
    }
}

impl Centerline {
    /// The midline with its points (and arc lengths and radii, where a plain length unit
    /// scales them) in mm.
    pub fn to_mm(mut self, unit: Unit) -> Self {
        for p in &mut self.points {
            *p = unit.to_mm(*p);
        }
        let scale = match unit {
            Unit::Mm => Some(1.0),
            Unit::Cm => Some(10.0),
            Unit::M => Some(1000.0),
            Unit::Um => Some(1e-3),
            Unit::Voxel { .. } => None,
        };
        match scale {
            Some(k) => {
                for v in self.s.iter_mut().chain(self.radius_median.iter_mut()) {
                    v.iter_mut().for_each(|x| *x *= k);
                }
            }
            None => {
                self.s = None;
                self.radius_median = None;
            }
        }
        self
    }
}
