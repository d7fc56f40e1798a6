//! 16-bit greyscale PNG heightmaps: height = `base + value · metres_per_unit`. Real DEMs are
//! commonly shared this way (e.g. exports of SRTM tiles). 8-bit greyscale is accepted too.

use std::io::Cursor;
use std::path::Path;

use super::{LandCover, Terrain, centred_origin};
use crate::error::{ConfigError, finite, positive};
use crate::grid::Grid2;

/// How PNG samples map to a terrain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightmapScale {
    /// Metres per PNG unit (per 1/65535 of the range for 16-bit files).
    pub metres_per_unit: f64,
    /// Altitude of PNG value 0 (m).
    pub base_altitude: f64,
    /// Horizontal distance between samples (m).
    pub cell: f64,
    /// Sea level (m); cells below it are water.
    pub sea_level: f32,
}

impl HeightmapScale {
    fn validate(&self) -> Result<(), ConfigError> {
        positive("metres_per_unit", self.metres_per_unit)?;
        finite("base_altitude", self.base_altitude)?;
        positive("cell", self.cell)?;
        finite("sea_level", self.sea_level as f64)?;
        Ok(())
    }
}

fn img_err(e: impl std::fmt::Display) -> ConfigError {
    ConfigError::Image(e.to_string())
}

/// Land cover from heights alone (the stratovolcano generator's rules without its cone): water
/// below `sea_level`, snow above `snow_line`, bare ground where the slope is steeper than
/// `bare_slope_deg`, vegetation elsewhere.
pub fn cover_from_relief(
    heights: &Grid2<f32>,
    sea_level: f32,
    snow_line: f32,
    bare_slope_deg: f32,
) -> Result<Grid2<LandCover>, ConfigError> {
    finite("snow_line", snow_line as f64)?;
    crate::error::in_range("bare_slope_deg", bare_slope_deg as f64, 0.0, 90.0)?;
    let max_tan = (bare_slope_deg as f64).to_radians().tan();
    let data = (0..heights.ny())
        .flat_map(|j| (0..heights.nx()).map(move |i| (i, j)))
        .map(|(i, j)| {
            let h = heights.get(i, j);
            let slope = heights.gradient(i, j, crate::Boundary::Clamp).length() as f64;
            if h < sea_level {
                LandCover::Water
            } else if h > snow_line {
                LandCover::Snow
            } else if slope > max_tan {
                LandCover::Ground
            } else {
                LandCover::Vegetation
            }
        })
        .collect();
    Grid2::from_vec(heights.nx(), heights.ny(), heights.cell(), heights.origin(), data)
}

/// The largest heightmap side a PNG may declare (a 16-bit 8192² map is 128 MiB).
pub const MAX_HEIGHTMAP_SIDE: usize = 8192;

impl Terrain {
    /// Decodes a greyscale PNG (16- or 8-bit) into a terrain centred on the origin. Land
    /// cover is water below sea level, ground elsewhere.
    pub fn from_png_bytes(bytes: &[u8], scale: HeightmapScale) -> Result<Terrain, ConfigError> {
        scale.validate()?;
        let limits = png::Limits { bytes: MAX_HEIGHTMAP_SIDE * MAX_HEIGHTMAP_SIDE * 2 };
        let decoder = png::Decoder::new_with_limits(Cursor::new(bytes), limits);
        let mut reader = decoder.read_info().map_err(img_err)?;
        // The declared size is checked before anything is allocated for it.
        let (w, h) = (reader.info().width as usize, reader.info().height as usize);
        if w > MAX_HEIGHTMAP_SIDE || h > MAX_HEIGHTMAP_SIDE {
            return Err(img_err(format!(
                "heightmap {w}×{h} is larger than {MAX_HEIGHTMAP_SIDE}×{MAX_HEIGHTMAP_SIDE}"
            )));
        }
        let size = reader.output_buffer_size().ok_or_else(|| img_err("image too large"))?;
        let mut buf = vec![0u8; size];
        let info = reader.next_frame(&mut buf).map_err(img_err)?;
        if info.color_type != png::ColorType::Grayscale {
            return Err(img_err(format!(
                "heightmaps must be greyscale, got {:?} (convert with e.g. `convert in.png -colorspace Gray -depth 16 out.png`)",
                info.color_type
            )));
        }
        let (w, h) = (info.width as usize, info.height as usize);
        if w < 2 || h < 2 {
            return Err(img_err(format!("heightmap must be at least 2×2, got {w}×{h}")));
        }
        let values: Vec<f32> = match info.bit_depth {
            png::BitDepth::Sixteen => buf[..w * h * 2]
                .chunks_exact(2)
                .map(|c| {
                    (scale.base_altitude + u16::from_be_bytes([c[0], c[1]]) as f64 * scale.metres_per_unit)
                        as f32
                })
                .collect(),
            png::BitDepth::Eight => buf[..w * h]
                .iter()
                .map(|&v| (scale.base_altitude + v as f64 * scale.metres_per_unit) as f32)
                .collect(),
            other => return Err(img_err(format!("unsupported bit depth {other:?}; use 8 or 16"))),
        };
        // Centre the footprint on the origin (square or not).
        let origin = centred_origin(w, scale.cell);
        let origin = bevy::math::Vec2::new(origin.x, centred_origin(h, scale.cell).y);
        let heights = Grid2::from_vec(w, h, scale.cell, origin, values)?;
        let cover_data = heights
            .data()
            .iter()
            .map(|&z| if z < scale.sea_level { LandCover::Water } else { LandCover::Ground })
            .collect();
        let cover = Grid2::from_vec(w, h, scale.cell, origin, cover_data)?;
        Terrain::new(heights, cover, scale.sea_level)
    }

    /// This terrain with its land cover recomputed from its relief
    /// ([`cover_from_relief`]): what a heightmap, which carries heights only, needs to render
    /// as rock, vegetation and snow.
    pub fn with_relief_cover(self, snow_line: f32, bare_slope_deg: f32) -> Result<Terrain, ConfigError> {
        let cover = cover_from_relief(self.heights(), self.sea_level(), snow_line, bare_slope_deg)?;
        Terrain::new(self.heights().clone(), cover, self.sea_level())
    }

    /// Reads a greyscale PNG heightmap from a file; an error names the file.
    pub fn from_png_file(path: impl AsRef<Path>, scale: HeightmapScale) -> Result<Terrain, ConfigError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path)
            .map_err(|e| ConfigError::Io { path: path.display().to_string(), message: e.to_string() })?;
        Self::from_png_bytes(&bytes, scale).map_err(|e| e.in_file(path))
    }

    /// Encodes the heights as a 16-bit greyscale PNG with `value = round((h − base) / mpu)`,
    /// clamped to 0..=65535 (the inverse of [`Terrain::from_png_bytes`]).
    pub fn to_png16(&self, metres_per_unit: f64, base_altitude: f64) -> Result<Vec<u8>, ConfigError> {
        positive("metres_per_unit", metres_per_unit)?;
        finite("base_altitude", base_altitude)?;
        let g = self.heights();
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, g.nx() as u32, g.ny() as u32);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Sixteen);
            let mut writer = enc.write_header().map_err(img_err)?;
            let data: Vec<u8> = g
                .data()
                .iter()
                .flat_map(|&h| {
                    let v = ((h as f64 - base_altitude) / metres_per_unit).round().clamp(0.0, 65535.0) as u16;
                    v.to_be_bytes()
                })
                .collect();
            writer.write_image_data(&data).map_err(img_err)?;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::StratovolcanoParams;

    #[test]
    fn png16_round_trip_within_one_unit() {
        let t = StratovolcanoParams { resolution: 64, cell: 200.0, ..Default::default() }.generate().unwrap();
        let mpu = 0.1;
        let base = -500.0;
        let bytes = t.to_png16(mpu, base).unwrap();
        let scale = HeightmapScale { metres_per_unit: mpu, base_altitude: base, cell: 200.0, sea_level: 0.0 };
        let back = Terrain::from_png_bytes(&bytes, scale).unwrap();
        assert_eq!(back.heights().nx(), 64);
        assert_eq!(back.heights().origin(), t.heights().origin());
        let max_err = t
            .heights()
            .data()
            .iter()
            .zip(back.heights().data())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        // Quantisation error is at most half a unit (plus f32 rounding).
        assert!(max_err <= 0.05 + 1e-3, "max round-trip error {max_err} m");
    }

    #[test]
    fn synthetic_png_maps_values_to_heights() {
        // A 3×2 16-bit image written by hand.
        let mut bytes = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut bytes, 3, 2);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Sixteen);
            let mut w = enc.write_header().unwrap();
            let vals: [u16; 6] = [0, 1000, 65535, 20, 30, 40];
            let data: Vec<u8> = vals.iter().flat_map(|v| v.to_be_bytes()).collect();
            w.write_image_data(&data).unwrap();
        }
        let scale = HeightmapScale { metres_per_unit: 0.5, base_altitude: 10.0, cell: 30.0, sea_level: 12.0 };
        let t = Terrain::from_png_bytes(&bytes, scale).unwrap();
        assert_eq!(t.heights().get(1, 0), 510.0);
        assert_eq!(t.heights().get(2, 0), 10.0 + 65535.0 * 0.5);
        assert_eq!(t.heights().get(0, 1), 20.0);
        assert_eq!(t.cover().get(0, 0), LandCover::Water);
        assert_eq!(t.cover().get(1, 0), LandCover::Ground);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let scale = HeightmapScale { metres_per_unit: 1.0, base_altitude: 0.0, cell: 1.0, sea_level: 0.0 };
        assert!(matches!(Terrain::from_png_bytes(b"not a png", scale), Err(ConfigError::Image(_))));
        let bad = HeightmapScale { metres_per_unit: -1.0, ..scale };
        assert!(Terrain::from_png_bytes(b"", bad).unwrap_err().to_string().contains("metres_per_unit"));
        assert!(matches!(Terrain::from_png_file("/nonexistent/x.png", scale), Err(ConfigError::Io { .. })));
    }
}
