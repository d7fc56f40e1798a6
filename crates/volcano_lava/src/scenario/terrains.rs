//! Ground heightfields of the test scenarios: the three terrains of thesis Fig 5.10 (a slope
//! with a long obstacle, a slope with a small obstacle that splits the flow, a slope with a
//! canyon), a uniform incline and flat ground. The slope descends toward +y (rows of
//! increasing `j`).

use bevy::math::Vec2;
use volcano_core::error::{in_range, positive};
use volcano_core::terrain::centred_origin;
use volcano_core::{ConfigError, Grid2, LandCover, Terrain};

use super::ScenarioKind;

/// Uniform incline of `slope_deg`, descending toward +y, `nx × ny` cells of `cell` m.
pub fn incline(nx: usize, ny: usize, cell: f64, slope_deg: f64) -> Result<Grid2<f64>, ConfigError> {
    let tan = slope_deg.to_radians().tan();
    let mut g = Grid2::new(nx, ny, cell, Vec2::ZERO, 0.0)?;
    for j in 0..ny {
        for i in 0..nx {
            g.set(i, j, -(j as f64) * cell * tan);
        }
    }
    Ok(g)
}

/// Flat ground at altitude 0.
pub fn flat(n: usize, cell: f64) -> Result<Grid2<f64>, ConfigError> {
    Grid2::new(n, n, cell, Vec2::ZERO, 0.0)
}

/// Raises a smooth-edged box `[x0, x1] × [y0, y1]` (grid fractions) by `height` m.
fn raise_box(g: &mut Grid2<f64>, (x0, x1): (f64, f64), (y0, y1): (f64, f64), height: f64) {
    let (nx, ny) = (g.nx(), g.ny());
    for j in 0..ny {
        for i in 0..nx {
            let (fx, fy) = (i as f64 / (nx - 1).max(1) as f64, j as f64 / (ny - 1).max(1) as f64);
            if fx >= x0 && fx <= x1 && fy >= y0 && fy <= y1 {
                let v = g.get(i, j);
                g.set(i, j, v + height);
            }
        }
    }
}

/// Fig 5.10 left: a slope with a long obstacle across 70 % of the width at 60 % of the
/// length, 3 m high (the lava is blocked and spreads sideways).
pub fn long_obstacle(n: usize, cell: f64, slope_deg: f64) -> Result<Grid2<f64>, ConfigError> {
    let mut g = incline(n, n, cell, slope_deg)?;
    raise_box(&mut g, (0.15, 0.85), (0.6, 0.66), 3.0);
    Ok(g)
}

/// Fig 5.10 middle: a slope with a small square obstacle (12 % of the width) in the flow's
/// path at 45 % of the length, 3 m high: the flow splits around it and may rejoin.
pub fn small_obstacle(n: usize, cell: f64, slope_deg: f64) -> Result<Grid2<f64>, ConfigError> {
    let mut g = incline(n, n, cell, slope_deg)?;
    raise_box(&mut g, (0.44, 0.56), (0.45, 0.53), 3.0);
    Ok(g)
}

/// Fig 5.10 right: a slope with a canyon along the slope, 20 % of the width wide and 2 m deep
/// with sloping walls, guiding the flow into a river.
pub fn canyon(n: usize, cell: f64, slope_deg: f64) -> Result<Grid2<f64>, ConfigError> {
    let mut g = incline(n, n, cell, slope_deg)?;
    let (nx, ny) = (g.nx(), g.ny());
    for j in 0..ny {
        for i in 0..nx {
            let fx = i as f64 / (nx - 1).max(1) as f64;
            let d = (fx - 0.5).abs();
            // flat floor |d| < 0.1, walls rising linearly to 0.15
            let depth = if d < 0.1 {
                2.0
            } else if d < 0.15 {
                2.0 * (0.15 - d) / 0.05
            } else {
                0.0
            };
            let v = g.get(i, j);
            g.set(i, j, v - depth);
        }
    }
    Ok(g)
}

/// Ground of scenario `kind` on an `n × n` grid (the sloping kinds; `incline` is the plain
/// slope of `slope`, `spread` flat ground).
pub fn scenario_ground(
    kind: ScenarioKind,
    n: usize,
    cell: f64,
    slope_deg: f64,
) -> Result<Grid2<f64>, ConfigError> {
    match kind {
        ScenarioKind::Obstacle => long_obstacle(n, cell, slope_deg),
        ScenarioKind::Split => small_obstacle(n, cell, slope_deg),
        ScenarioKind::Canyon => canyon(n, cell, slope_deg),
        ScenarioKind::Slope | ScenarioKind::Incline => incline(n, n, cell, slope_deg),
        ScenarioKind::Spread => flat(n, cell),
    }
}

/// A [`Terrain`] (for rendering and for placing a `LavaField` on) of scenario `kind`: its
/// `n × n` ground centred on the world origin, surrounded by `margin` cells on every side that
/// continue it (edge values carried outward, the slope continued downhill), bare ground. A
/// field of `n × n` cells of `cell` m centred on the origin samples it exactly.
pub fn scenario_terrain(
    kind: ScenarioKind,
    n: usize,
    cell: f64,
    slope_deg: f64,
    margin: usize,
) -> Result<Terrain, ConfigError> {
    if margin > 4096 {
        return Err(ConfigError::InvalidParameter {
            name: "margin",
            value: margin as f64,
            reason: "must be at most 4096 cells".into(),
        });
    }
    let g = scenario_ground(kind, n, cell, slope_deg)?;
    let tan = slope_deg.to_radians().tan();
    let nt = n + 2 * margin;
    let origin = centred_origin(nt, cell);
    let mut heights = Grid2::new(nt, nt, cell, origin, 0.0f32)?;
    for jt in 0..nt {
        for it in 0..nt {
            let (i, j) = (it as i64 - margin as i64, jt as i64 - margin as i64);
            let (ic, jc) = (i.clamp(0, n as i64 - 1), j.clamp(0, n as i64 - 1));
            let h = g.get(ic as usize, jc as usize) - (j - jc) as f64 * cell * tan;
            heights.set(it, jt, h as f32);
        }
    }
    let cover = Grid2::new(nt, nt, cell, origin, LandCover::Ground)?;
    Terrain::new(heights, cover, f32::MIN)
}

/// A long valley for kilometre flows: `nx × ny` nodes of `cell` m centred on the origin, an
/// incline of `slope_deg` descending toward +z from `top` m at the first row, with a gully
/// along its middle `gully_depth` m deep (a cosine cross-section `gully_width` m wide; 0 = a
/// plane). With `sea`, ground below 0 m is sea (water cover, sea level 0 m).
pub fn runout_valley(
    (nx, ny, cell): (usize, usize, f64),
    slope_deg: f64,
    top: f64,
    (gully_depth, gully_width): (f64, f64),
    sea: bool,
) -> Result<Terrain, ConfigError> {
    in_range("runout slope", slope_deg, 0.0, 60.0)?;
    in_range("gully depth", gully_depth, 0.0, 1_000.0)?;
    if gully_depth > 0.0 {
        positive("gully width", gully_width)?;
    }
    let tan = slope_deg.to_radians().tan();
    let origin =
        Vec2::new(-(((nx - 1) as f64) * cell * 0.5) as f32, -(((ny - 1) as f64) * cell * 0.5) as f32);
    let mut heights = Grid2::new(nx, ny, cell, origin, 0.0f32)?;
    let mut cover = Grid2::new(nx, ny, cell, origin, LandCover::Ground)?;
    for j in 0..ny {
        for i in 0..nx {
            let x = (i as f64 - (nx - 1) as f64 * 0.5) * cell;
            let gully = if x.abs() < 0.5 * gully_width {
                0.5 * gully_depth * (1.0 + (std::f64::consts::TAU * x / gully_width).cos())
            } else {
                0.0
            };
            let h = top - j as f64 * cell * tan - gully;
            heights.set(i, j, h as f32);
            if sea && h < 0.0 {
                cover.set(i, j, LandCover::Water);
            }
        }
    }
    Terrain::new(heights, cover, if sea { 0.0 } else { f32::MIN })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padded_terrain_matches_the_scenario_ground_and_continues_the_slope() {
        let (n, cell, m) = (32, 0.5, 8);
        let g = scenario_ground(ScenarioKind::Obstacle, n, cell, 3.0).unwrap();
        let t = scenario_terrain(ScenarioKind::Obstacle, n, cell, 3.0, m).unwrap();
        assert_eq!(t.heights().nx(), n + 2 * m);
        // Cell (i, j) of a field of n cells centred on the origin sits on terrain sample (i+m, j+m).
        let field_origin = centred_origin(n, cell);
        for (i, j) in [(0, 0), (5, 20), (16, 19), (31, 31)] {
            let p = field_origin + Vec2::new(i as f32, j as f32) * cell as f32;
            assert!((t.height_at(p.x, p.y) as f64 - g.get(i, j)).abs() < 1e-4, "({i}, {j})");
        }
        // Below the grid the slope keeps descending.
        let last = t.heights().get(m + 3, n + m - 1);
        let below = t.heights().get(m + 3, n + 2 * m - 1);
        let drop = (m as f64 * cell * 3f64.to_radians().tan()) as f32;
        assert!((last - below - drop).abs() < 1e-4);
        assert!(scenario_terrain(ScenarioKind::Canyon, n, cell, 3.0, 100_000).is_err());
    }
}
