//! PNG maps of a lava field: thickness, crust (thesis Figs 5.11–5.13 debug colours), speed.

use std::path::{Path, PathBuf};

use volcano_core::ConfigError;

use super::crust_colour;
use crate::model::field::FlowField;
use crate::model::folds::FoldSystem;
use crate::model::surface::SurfaceState;

fn ramp(x: f64) -> [u8; 3] {
    // black → red → yellow → white
    let x = x.clamp(0.0, 1.0) * 3.0;
    let c = |v: f64| (v.clamp(0.0, 1.0) * 255.0) as u8;
    [c(x), c(x - 1.0), c(x - 2.0)]
}

fn write_rgb(path: &Path, nx: usize, ny: usize, rgb: &[u8]) -> Result<(), ConfigError> {
    let io = |e: std::io::Error| ConfigError::Io { path: path.display().to_string(), message: e.to_string() };
    let img = |e: png::EncodingError| ConfigError::Image(e.to_string());
    let file = std::fs::File::create(path).map_err(io)?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), nx as u32, ny as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(img)?;
    w.write_image_data(rgb).map_err(img)?;
    Ok(())
}

/// Writes `thickness.png`, `crust.png`, `velocity.png` into `dir` (created if missing), one
/// pixel per cell, +y (downslope) toward the bottom of the image; lava in [`crust_colour`] on
/// the crust map, dark grey where there is no lava, light grey for frozen lava. Returns the
/// paths.
pub fn write_maps(
    field: &FlowField,
    surface: &SurfaceState,
    folds: &FoldSystem,
    dir: &Path,
) -> Result<Vec<PathBuf>, ConfigError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| ConfigError::Io { path: dir.display().to_string(), message: e.to_string() })?;
    let (nx, ny) = (field.nx(), field.ny());
    let h = field.thickness().data();
    let solid = field.solid().data();
    let (u, v) = field.velocity();
    let (u, v) = (u.data(), v.data());
    let hmax = h.iter().cloned().fold(1e-9, f64::max);
    let smax = u.iter().zip(v).map(|(a, b)| a.hypot(*b)).fold(1e-9, f64::max);
    let (mut th, mut cr, mut ve) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..nx * ny {
        let wet = h[k] >= 1e-3;
        let bg = if solid[k] > 0.0 { [150, 150, 150] } else { [30, 30, 30] };
        th.extend(if wet { ramp(h[k] / hmax) } else { bg });
        cr.extend(if wet { crust_colour(surface.crust[k]) } else { bg });
        ve.extend(if wet { ramp(u[k].hypot(v[k]) / smax) } else { bg });
    }
    let mut fo = cr.clone();
    for q in &folds.particles {
        if let Some((i, j)) = field.cell_at(bevy::math::Vec2::new(q.pos.x as f32, q.pos.y as f32)) {
            let k = 3 * (j * nx + i);
            let c = if q.roll_height > 1e-6 {
                [255, 230, 0]
            } else if q.roll_height < -1e-6 {
                [0, 0, 0]
            } else {
                [255, 255, 255]
            };
            fo[k..k + 3].copy_from_slice(&c);
        }
    }
    let mut out = Vec::new();
    for (name, data) in [("thickness.png", th), ("crust.png", cr), ("velocity.png", ve), ("folds.png", fo)] {
        let p = dir.join(name);
        write_rgb(&p, nx, ny, &data)?;
        out.push(p);
    }
    Ok(out)
}
