//! Every loader of a file a user edits, fuzzed: scenes, volcano specs, plume presets, eruption
//! timelines, lava presets, atmosphere scenarios (RON) and heightmaps (PNG). Each loader gets
//! `VOLCANO_FUZZ_CASES` (default 1,000) seeded cases: random bytes, and the shipped files and
//! valid images mutated (bit flips, bytes replaced by characters and numbers that matter to the
//! format, spans deleted, duplicated or spliced from another file, truncations), plus crafted
//! PNGs (wrong bit depths and colour types, 1 × N, huge declared sizes). A loader must return
//! an error with a message, never panic; what it accepts must pass its own validation; a
//! heightmap that declares a huge size is refused before it is allocated.

use std::panic::{AssertUnwindSafe, catch_unwind};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use volcano::scenes::SceneSpec;
use volcano_atmosphere::WeatherScenario;
use volcano_core::terrain::png_io::HeightmapScale;
use volcano_core::{ConfigError, Terrain, VolcanoSpec};
use volcano_lava::LavaParams;
use volcano_plume::PlumeParams;
use volcano_plume::model::timeline::EruptionTimeline;

/// Cases per loader: `VOLCANO_FUZZ_CASES`, 1,000 by default (the CI run).
fn cases() -> usize {
    std::env::var("VOLCANO_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000)
}

/// What a RON mutation may write in: the format's punctuation, names, and numbers at the edges
/// of what parameters accept.
const TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    ",",
    ":",
    "\"",
    "Some(",
    "None",
    "-",
    "1e308",
    "-1e308",
    "NaN",
    "inf",
    "-inf",
    "0",
    "-1",
    "4294967296",
    "18446744073709551616",
    "1e-320",
    "0.0",
    "true",
    "r#\"",
    "/*",
    "//",
    "\n",
    "\u{0}",
    "é",
];

/// One mutation of `seed` (or, one case in eight, random bytes), from `rng`; `other` is a second
/// valid input to splice from.
fn mutate(rng: &mut ChaCha8Rng, seed: &[u8], other: &[u8]) -> Vec<u8> {
    if rng.random_range(0..8) == 0 {
        let n = rng.random_range(0..256);
        return (0..n).map(|_| rng.random::<u8>()).collect();
    }
    let mut b = seed.to_vec();
    for _ in 0..rng.random_range(1..5) {
        let at = |rng: &mut ChaCha8Rng, len: usize| rng.random_range(0..=len);
        match rng.random_range(0..7) {
            0 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                b[i] ^= 1 << rng.random_range(0..8);
            }
            1 => {
                let i = at(rng, b.len());
                let t = TOKENS[rng.random_range(0..TOKENS.len())].as_bytes();
                b.splice(i..i, t.iter().copied());
            }
            2 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                let j = (i + rng.random_range(1..64)).min(b.len());
                b.drain(i..j);
            }
            3 if !b.is_empty() => {
                let i = rng.random_range(0..b.len());
                let j = (i + rng.random_range(1..64)).min(b.len());
                let chunk: Vec<u8> = b[i..j].to_vec();
                let k = at(rng, b.len());
                b.splice(k..k, chunk);
            }
            4 => {
                let n = at(rng, b.len());
                b.truncate(n);
            }
            5 if !other.is_empty() => {
                let i = rng.random_range(0..other.len());
                let j = (i + rng.random_range(1..128)).min(other.len());
                let k = at(rng, b.len());
                b.splice(k..k, other[i..j].iter().copied());
            }
            _ if !b.is_empty() => {
                // A digit replaced by another: a plausible but different value.
                let i = rng.random_range(0..b.len());
                if b[i].is_ascii_digit() {
                    b[i] = b'0' + rng.random_range(0..10u8);
                }
            }
            _ => {}
        }
    }
    b
}

/// Runs `load` on `cases()` mutations of `seeds`: no panic, an error with a message, and
/// what is accepted passes `valid`. Returns (accepted, rejected).
fn fuzz<T>(
    name: &str,
    stream: u64,
    seeds: &[Vec<u8>],
    load: impl Fn(&[u8]) -> Result<T, ConfigError>,
    valid: impl Fn(&T) -> bool,
) -> (usize, usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(0xF022 ^ stream);
    let (mut ok, mut err) = (0, 0);
    for case in 0..cases() {
        let seed = &seeds[case % seeds.len()];
        let other = &seeds[(case / seeds.len()) % seeds.len()];
        let input = mutate(&mut rng, seed, other);
        let outcome = catch_unwind(AssertUnwindSafe(|| load(&input)));
        match outcome {
            Err(_) => panic!("{name}: case {case} panicked on {:?}", String::from_utf8_lossy(&input)),
            Ok(Ok(v)) => {
                assert!(valid(&v), "{name}: case {case} was accepted but is not valid");
                ok += 1;
            }
            Ok(Err(e)) => {
                assert!(!e.to_string().trim().is_empty(), "{name}: case {case}: an empty error");
                err += 1;
            }
        }
    }
    eprintln!("fuzz {name}: {} cases, {ok} accepted, {err} rejected", cases());
    (ok, err)
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn files(dir: &str, suffix: &str) -> Vec<Vec<u8>> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(suffix))
        .map(|p| (p.display().to_string(), std::fs::read(&p).unwrap()))
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no {suffix} in {dir}");
    out.into_iter().map(|(_, b)| b).collect()
}

#[test]
fn scene_files() {
    let seeds = files("assets/scenes", ".ron");
    let (ok, _) = fuzz("scene", 1, &seeds, |b| SceneSpec::from_ron(&text(b)), |s| s.validate().is_ok());
    assert!(ok > 0, "some mutations keep a scene valid (the fuzzer reaches past the parser)");
}

#[test]
fn volcano_specs() {
    let seeds = vec![ron::to_string(&VolcanoSpec::default()).unwrap().into_bytes()];
    fuzz("volcano spec", 2, &seeds, |b| VolcanoSpec::from_ron(&text(b)), |s| s.validate().is_ok());
}

#[test]
fn plume_presets() {
    let seeds = files("crates/volcano_plume/presets", ".ron");
    let (ok, _) =
        fuzz("plume preset", 3, &seeds, |b| PlumeParams::from_ron(&text(b)), |p| p.validate().is_ok());
    assert!(ok > 0);
}

#[test]
fn eruption_timelines() {
    let seeds = files("assets/timelines", ".ron");
    fuzz("timeline", 4, &seeds, |b| EruptionTimeline::from_ron(&text(b)), |t| t.validate().is_ok());
}

#[test]
fn lava_presets() {
    let seeds = files("crates/volcano_lava/presets", ".ron");
    let (ok, _) =
        fuzz("lava preset", 5, &seeds, |b| LavaParams::from_ron(&text(b)), |p| p.validate().is_ok());
    assert!(ok > 0);
}

#[test]
fn atmosphere_scenarios() {
    let seeds = files("crates/volcano_atmosphere/scenarios", ".ron");
    let (ok, _) = fuzz(
        "atmosphere scenario",
        6,
        &seeds,
        |b| WeatherScenario::from_ron(&text(b)),
        |s| s.validate().is_ok(),
    );
    assert!(ok > 0);
}

/// A PNG of `w × h` pixels of `colour` at `depth` bits, pixels from `rng`.
fn encode(rng: &mut ChaCha8Rng, w: u32, h: u32, colour: png::ColorType, depth: png::BitDepth) -> Vec<u8> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(colour);
    enc.set_depth(depth);
    if colour == png::ColorType::Indexed {
        enc.set_palette(vec![0u8; 3 * 256]);
    }
    let mut writer = enc.write_header().unwrap();
    let bits = colour.samples() * depth as usize;
    let row = (w as usize * bits).div_ceil(8);
    let data: Vec<u8> = (0..row * h as usize).map(|_| rng.random::<u8>()).collect();
    writer.write_image_data(&data).unwrap();
    writer.finish().unwrap();
    out
}

/// `png` with the IHDR's width and height replaced (and its CRC recomputed), so the image
/// declares a size its data does not have.
fn declaring(mut png: Vec<u8>, w: u32, h: u32) -> Vec<u8> {
    // Signature (8), length (4), "IHDR" (4), width, height at 16 and 20; CRC over type + data.
    png[16..20].copy_from_slice(&w.to_be_bytes());
    png[20..24].copy_from_slice(&h.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    png
}

/// CRC-32 (ISO-HDLC) as PNG chunks use it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

#[test]
fn heightmaps() {
    use png::{BitDepth as D, ColorType as C};
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let scale = HeightmapScale { metres_per_unit: 0.05, base_altitude: 0.0, cell: 30.0, sea_level: 1.0 };
    let load = |b: &[u8]| Terrain::from_png_bytes(b, scale);
    let valid = |t: &Terrain| t.heights().data().iter().all(|h| h.is_finite());
    // What must be refused, each with a message naming the problem.
    let refused = [
        (encode(&mut rng, 8, 8, C::Rgb, D::Eight), "greyscale"),
        (encode(&mut rng, 8, 8, C::Indexed, D::Eight), "greyscale"),
        (encode(&mut rng, 8, 8, C::GrayscaleAlpha, D::Sixteen), "greyscale"),
        (encode(&mut rng, 8, 8, C::Grayscale, D::Four), "bit depth"),
        (encode(&mut rng, 1, 64, C::Grayscale, D::Sixteen), "2×2"),
        (encode(&mut rng, 64, 1, C::Grayscale, D::Eight), "2×2"),
        (declaring(encode(&mut rng, 8, 8, C::Grayscale, D::Sixteen), 60_000, 60_000), "larger than"),
        (declaring(encode(&mut rng, 8, 8, C::Grayscale, D::Eight), u32::MAX >> 1, 2), ""),
        (declaring(encode(&mut rng, 8, 8, C::Grayscale, D::Eight), 4096, 4096), ""),
    ];
    for (k, (bytes, says)) in refused.iter().enumerate() {
        let e = load(bytes).err().unwrap_or_else(|| panic!("crafted heightmap {k} was accepted")).to_string();
        assert!(e.contains(says), "crafted heightmap {k}: {e}");
    }
    let seeds: Vec<Vec<u8>> = vec![
        encode(&mut rng, 16, 12, C::Grayscale, D::Sixteen),
        encode(&mut rng, 9, 9, C::Grayscale, D::Eight),
        encode(&mut rng, 2, 2, C::Grayscale, D::Sixteen),
        refused[0].0.clone(),
        refused[4].0.clone(),
    ];
    let (ok, _) = fuzz("heightmap", 7, &seeds, load, valid);
    assert!(ok > 0);
    // Read from a file, the error names the file.
    let dir = std::env::temp_dir().join(format!("volcano-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("broken.png");
    std::fs::write(&path, &refused[0].0).unwrap();
    let e = Terrain::from_png_file(&path, scale).unwrap_err().to_string();
    assert!(e.contains("broken.png") && e.contains("greyscale"), "{e}");
    let path = dir.join("broken.ron");
    std::fs::write(&path, "(name: \"x\", grid: 3)").unwrap();
    let e = WeatherScenario::load(&path).unwrap_err().to_string();
    assert!(e.contains("broken.ron"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
