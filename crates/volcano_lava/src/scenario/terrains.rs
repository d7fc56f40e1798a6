//! Ground heightfields of the test scenarios: the three terrains of thesis Fig 5.10 (a slope
//! with a long obstacle, a slope with a small obstacle that splits the flow, a slope with a
//! canyon), a uniform incline and flat ground. The slope descends toward +y (rows of
//! increasing `j`).

use bevy::math::Vec2;
use volcano_core::{ConfigError, Grid2};

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
