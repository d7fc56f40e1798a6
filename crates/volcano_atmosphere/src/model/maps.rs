//! 2D maps of layer fields (the per-layer views of thesis Fig 4.6) as plain arrays and
//! 8-bit grayscale PNG bytes, so the CLI's "PNG maps of each field of each layer" is a loop.

use serde::{Deserialize, Serialize};
use volcano_core::ConfigError;

use super::fields::LayerFields;

/// A field of a layer that can be mapped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MapField {
    /// T (K).
    Temperature,
    /// H (g/m³).
    Humidity,
    /// W (g/m³).
    Water,
    /// Ash (g/m³).
    Ash,
    /// Wind x component at cell centres (m/s).
    WindX,
    /// Wind y component at cell centres (m/s).
    WindY,
    /// P (projection potential, m²/s).
    Pressure,
    /// C (m/s).
    Convection,
    /// U (m/s).
    Uplift,
    /// D (m/s).
    Vertical,
    /// σ.
    Damping,
}

impl MapField {
    /// Every field, in a fixed order.
    pub const ALL: [MapField; 11] = [
        MapField::Temperature,
        MapField::Humidity,
        MapField::Water,
        MapField::Ash,
        MapField::WindX,
        MapField::WindY,
        MapField::Pressure,
        MapField::Convection,
        MapField::Uplift,
        MapField::Vertical,
        MapField::Damping,
    ];
}

/// The field's values at cell centres, row-major (n × n).
pub fn field_values(layer: &LayerFields, field: MapField) -> Vec<f64> {
    let n = layer.t.nx();
    let f32s = |g: &[f32]| g.iter().map(|&x| x as f64).collect::<Vec<f64>>();
    match field {
        MapField::Temperature => f32s(layer.t.data()),
        MapField::Humidity => layer.h.data().to_vec(),
        MapField::Water => layer.w.data().to_vec(),
        MapField::Ash => layer.ash.data().to_vec(),
        MapField::WindX => {
            let u = layer.u.data();
            (0..n * n).map(|k| 0.5 * (u[k] + u[(k / n) * n + (k % n + 1) % n]) as f64).collect()
        }
        MapField::WindY => {
            let v = layer.v.data();
            (0..n * n).map(|k| 0.5 * (v[k] + v[((k / n + 1) % n) * n + k % n]) as f64).collect()
        }
        MapField::Pressure => layer.p.data().to_vec(),
        MapField::Convection => f32s(layer.c.data()),
        MapField::Uplift => f32s(layer.up.data()),
        MapField::Vertical => f32s(layer.d.data()),
        MapField::Damping => f32s(layer.sigma.data()),
    }
}

/// 8-bit grayscale PNG of `values` (n × n, row 0 at the bottom so north is up), scaled from
/// its minimum (black) to its maximum (white); returns the bytes and the (min, max) used.
pub fn png_bytes(values: &[f64], n: usize) -> Result<(Vec<u8>, (f64, f64)), ConfigError> {
    if values.len() != n * n || n == 0 {
        return Err(ConfigError::InvalidParameter {
            name: "map size",
            value: values.len() as f64,
            reason: format!("must be n² = {}", n * n),
        });
    }
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let span = if hi > lo { hi - lo } else { 1.0 };
    let mut pixels = vec![0u8; n * n];
    for j in 0..n {
        for i in 0..n {
            let v = values[(n - 1 - j) * n + i];
            pixels[j * n + i] =
                if v.is_finite() { ((v - lo) / span * 255.0).round().clamp(0.0, 255.0) as u8 } else { 0 };
        }
    }
    let img_err = |e: png::EncodingError| ConfigError::Image(e.to_string());
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, n as u32, n as u32);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(img_err)?;
        writer.write_image_data(&pixels).map_err(img_err)?;
    }
    Ok((out, (lo.min(hi), hi.max(lo))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fields::GridSpec;

    #[test]
    fn maps_have_the_grid_shape_and_decode() {
        let g = GridSpec::new(16, 100.0).unwrap();
        let mut layer = LayerFields::new(g, 500.0, 0.0, 1000.0, 285.0);
        layer.t.data_mut()[3] = 290.0;
        let vals = field_values(&layer, MapField::Temperature);
        assert_eq!(vals.len(), 256);
        let (bytes, (lo, hi)) = png_bytes(&vals, 16).unwrap();
        assert_eq!((lo, hi), (285.0, 290.0));
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (16, 16));
        // Cell 3 of row 0 is in the bottom image row.
        assert_eq!(buf[15 * 16 + 3], 255);
        assert_eq!(buf[0], 0);
        assert!(png_bytes(&vals, 15).is_err());
        for f in MapField::ALL {
            assert_eq!(field_values(&layer, f).len(), 256);
        }
    }
}
