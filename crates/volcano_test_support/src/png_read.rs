//! PNG read-back and the frame statistics the render tests assert on.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// Reads an 8-bit PNG as `(width, height, RGB bytes)` (grey and alpha are expanded/dropped).
pub fn read_png_rgb(path: impl AsRef<Path>) -> Result<(u32, u32, Vec<u8>), String> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("PNG too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    buf.truncate(info.buffer_size());
    let rgb = match info.color_type {
        png::ColorType::Rgb => buf,
        png::ColorType::Rgba => buf.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect(),
        png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g, g, g]).collect(),
        png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|p| [p[0], p[0], p[0]]).collect(),
        png::ColorType::Indexed => return Err("indexed PNG was not expanded".into()),
    };
    Ok((info.width, info.height, rgb))
}

/// Mean RGB of the pixel rectangle `[x0, x1) × [y0, y1)` of a `width`-pixel-wide RGB image.
pub fn rgb_region_mean(rgb: &[u8], width: u32, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for y in y0..y1 {
        for x in x0..x1 {
            let i = ((y * width + x) * 3) as usize;
            for c in 0..3 {
                sum[c] += rgb[i + c] as f64;
            }
        }
    }
    let n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
    sum.map(|s| s / n)
}

/// Mean over the R, G, B channels of each channel's standard deviation across pixels (0–255
/// scale) of an RGB buffer. A one-colour frame gives 0 whatever the colour.
pub fn rgb_stddev(rgb: &[u8]) -> f64 {
    let n = (rgb.len() / 3) as f64;
    if n == 0.0 {
        return 0.0;
    }
    let mut sum = [0f64; 3];
    let mut sq = [0f64; 3];
    for p in rgb.chunks_exact(3) {
        for c in 0..3 {
            let v = p[c] as f64;
            sum[c] += v;
            sq[c] += v * v;
        }
    }
    (0..3).map(|c| (sq[c] / n - (sum[c] / n).powi(2)).max(0.0).sqrt()).sum::<f64>() / 3.0
}

/// [`rgb_stddev`] of a PNG file: a blank-frame check for render tests.
pub fn png_pixel_stddev(path: impl AsRef<Path>) -> Result<f64, String> {
    read_png_rgb(path).map(|(_, _, rgb)| rgb_stddev(&rgb))
}

/// Luminance of an sRGB-encoded mean colour, Rec. 709 weights on the encoded values (what the
/// tests compare, not a photometric quantity).
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use bevy::image::Image;
    use bevy::render::render_resource::TextureFormat;
    use bevy::render::render_resource::{Extent3d, TextureDimension};
    use volcano_render::write_png_rgb;

    #[test]
    fn png_round_trip_and_stddev() {
        let dir = std::env::temp_dir().join(format!("volcano_test_support_png_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        let (w, h) = (4u32, 2u32);
        // Left half pure blue, right half black: not blank.
        let data: Vec<u8> =
            (0..w * h).flat_map(|i| if i % w < 2 { [0, 0, 255, 255] } else { [0, 0, 0, 255] }).collect();
        let size = Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let img = Image::new(
            size,
            TextureDimension::D2,
            data,
            TextureFormat::Rgba8UnormSrgb,
            RenderAssetUsages::all(),
        );
        write_png_rgb(&img, &path).unwrap();
        let (rw, rh, rgb) = read_png_rgb(&path).unwrap();
        assert_eq!((rw, rh), (w, h));
        assert_eq!(&rgb[..6], &[0, 0, 255, 0, 0, 255]);
        // Blue channel: half 0, half 255 → σ = 127.5; R and G: 0. Mean of the three: 42.5.
        assert!((png_pixel_stddev(&path).unwrap() - 42.5).abs() < 1e-9);
        // One colour, whichever: zero.
        assert_eq!(rgb_stddev(&[0, 0, 255].repeat(10)), 0.0);
        assert!(png_pixel_stddev(dir.join("missing.png")).is_err());
        let bad = dir.join("no_such_dir").join("x.png");
        assert!(write_png_rgb(&img, &bad).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
