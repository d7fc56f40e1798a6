//! The lava field: a local grid of lava thickness and temperature over a ground heightfield
//! (terrain resampled + lava frozen so far), its edges, sources and volume budget.

use bevy::math::Vec2;
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::error::{in_range, positive};
use volcano_core::{Boundary, ConfigError, Grid2, Terrain};

use super::budget::VolumeBudget;

/// What happens at one side of the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect, Serialize, Deserialize)]
pub enum Edge {
    /// No flux (a wall).
    #[default]
    Wall,
    /// Lava leaves freely (ground extrapolated linearly beyond the edge; nothing flows in).
    /// What leaves is booked as `outflow`.
    Open,
    /// Wraps to the opposite side (both opposite sides must be periodic).
    Periodic,
}

/// Edge behaviour of the four sides (west = −x, east = +x, south = −y, north = +y).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect, Serialize, Deserialize)]
pub struct Edges {
    /// Side at i = 0.
    pub west: Edge,
    /// Side at i = nx − 1.
    pub east: Edge,
    /// Side at j = 0.
    pub south: Edge,
    /// Side at j = ny − 1.
    pub north: Edge,
}

impl Edges {
    fn validate(&self) -> Result<(), ConfigError> {
        let bad = |a: Edge, b: Edge| (a == Edge::Periodic) != (b == Edge::Periodic);
        if bad(self.west, self.east) || bad(self.south, self.north) {
            return Err(ConfigError::InvalidParameter {
                name: "edges",
                value: f64::NAN,
                reason: "periodic edges must come in opposite pairs (west+east, south+north)".into(),
            });
        }
        Ok(())
    }
}

/// Where a lava grid sits on a terrain: centre (x, z), size and cell (thesis: 0.5 m). On a
/// [`crate::LavaField`] the centre is relative to the entity's `Transform` translation.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub struct Placement {
    /// (x, z) of the grid centre (world, or relative to a field entity's `Transform`).
    pub centre: Vec2,
    /// Cells along x.
    pub nx: usize,
    /// Cells along z.
    pub ny: usize,
    /// Cell size (m).
    pub cell: f64,
}

impl Default for Placement {
    fn default() -> Self {
        Self { centre: Vec2::ZERO, nx: 512, ny: 512, cell: 0.5 }
    }
}

impl Placement {
    /// World position of cell (0, 0)'s centre.
    pub fn origin(&self) -> Vec2 {
        let half = Vec2::new((self.nx - 1) as f32, (self.ny - 1) as f32) * (0.5 * self.cell as f32);
        self.centre - half
    }

    /// A patch of `n × n` cells of `cell` m on `terrain` that holds the point `source` (world
    /// x, z), centred a third of its width downslope of it so the lava has room to run, then
    /// shifted as little as needed to lie inside the terrain. Errors if the source is off the
    /// terrain or the patch is larger than the terrain.
    pub fn downslope_of(terrain: &Terrain, source: Vec2, n: usize, cell: f64) -> Result<Self, ConfigError> {
        let p = Self { centre: source, nx: n, ny: n, cell };
        p.validate()?;
        if !terrain.contains(source.x, source.y) {
            return Err(ConfigError::InvalidParameter {
                name: "lava patch source",
                value: source.x as f64,
                reason: format!("({}, {}) is off the terrain", source.x, source.y),
            });
        }
        let half = 0.5 * (n - 1) as f64 * cell;
        let n3 = terrain.normal_at(source.x, source.y);
        let down = Vec2::new(n3.x, n3.z).normalize_or_zero();
        let want = source.as_dvec2() + down.as_dvec2() * (2.0 * half / 3.0);
        let g = terrain.heights();
        let (lo, size) = (g.origin().as_dvec2(), g.extent().as_dvec2());
        // A hair inside, so the f32 corners still test as contained.
        let margin = 1e-4 * (size.x.max(size.y) + 1.0);
        let fit = |want: f64, lo: f64, size: f64| -> Option<f64> {
            let (a, b) = (lo + half + margin, lo + size - half - margin);
            (a <= b).then(|| want.clamp(a, b))
        };
        match (fit(want.x, lo.x, size.x), fit(want.y, lo.y, size.y)) {
            (Some(x), Some(y)) => Ok(Self { centre: Vec2::new(x as f32, y as f32), ..p }),
            _ => Err(ConfigError::InvalidParameter {
                name: "lava patch size",
                value: 2.0 * half,
                reason: format!(
                    "a {:.0} m patch does not fit on a {:.0} × {:.0} m terrain",
                    2.0 * half,
                    size.x,
                    size.y
                ),
            }),
        }
    }

    /// Checks sizes (1..=8192 cells a side, cell in [0.01, 100] m).
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("nx", self.nx as f64, 1.0, 8192.0)?;
        in_range("ny", self.ny as f64, 1.0, 8192.0)?;
        in_range("cell", self.cell, 0.01, 100.0)?;
        if !self.centre.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "centre",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        Ok(())
    }
}

/// A validated volume source on the grid: a set of cells sharing a rate.
#[derive(Debug, Clone, PartialEq, Reflect)]
pub struct Source {
    pub(crate) cells: Vec<usize>,
    /// Volume rate (m³/s), ≥ 0.
    pub(crate) rate: f64,
    /// Temperature of the emitted lava (K).
    pub(crate) temperature: f64,
}

impl Source {
    /// Volume rate (m³/s).
    pub fn rate(&self) -> f64 {
        self.rate
    }
    /// Emission temperature (K).
    pub fn temperature(&self) -> f64 {
        self.temperature
    }
    /// Number of cells it feeds.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }
}

fn check_source(rate: f64, temperature: f64) -> Result<(), ConfigError> {
    in_range("source rate", rate, 0.0, 1e6)?;
    in_range("source temperature", temperature, 300.0, 2500.0)?;
    Ok(())
}

/// The state of one lava field. Thickness, ground and budgets are f64.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowField {
    /// Ground altitude under the lava: terrain + solidified lava (m).
    pub(crate) ground: Grid2<f64>,
    /// Lava frozen so far (m), included in `ground`.
    pub(crate) solid: Grid2<f64>,
    /// Liquid lava thickness, vertical (m).
    pub(crate) h: Grid2<f64>,
    /// Depth-averaged lava temperature (K); `air_temperature` where there is no lava.
    pub(crate) temp: Grid2<f64>,
    /// Cell-centred depth-averaged velocity over the last step (m/s), x and y.
    pub(crate) vel: [Grid2<f64>; 2],
    pub(crate) edges: Edges,
    pub(crate) budget: VolumeBudget,
    /// Simulated time (s).
    pub(crate) time: f64,
    pub(crate) scratch: super::scratch::Scratch,
    /// Per-cell mobility multiplier from the crust (1 = free surface, 1/4 = rigid crust).
    pub(crate) mob_factor: Vec<f64>,
}

impl FlowField {
    /// A field over the given ground heights (row-major `nx × ny`, m), with no lava.
    /// `air_temperature` fills the temperature of empty cells.
    pub fn new(ground: Grid2<f64>, edges: Edges, air_temperature: f64) -> Result<Self, ConfigError> {
        edges.validate()?;
        in_range("air_temperature", air_temperature, 150.0, 1000.0)?;
        if let Some(bad) = ground.data().iter().find(|v| !v.is_finite()) {
            return Err(ConfigError::InvalidParameter {
                name: "ground height",
                value: *bad,
                reason: "must be finite".into(),
            });
        }
        let (nx, ny, cell, origin) = (ground.nx(), ground.ny(), ground.cell(), ground.origin());
        let zero = Grid2::new(nx, ny, cell, origin, 0.0)?;
        let scratch = super::scratch::Scratch::new(&zero);
        Ok(Self {
            solid: zero.clone(),
            h: zero.clone(),
            temp: Grid2::new(nx, ny, cell, origin, air_temperature)?,
            vel: [zero.clone(), zero],
            ground,
            edges,
            budget: VolumeBudget::default(),
            time: 0.0,
            scratch,
            mob_factor: vec![1.0; nx * ny],
        })
    }

    /// A flat field at altitude 0 (walls all round).
    pub fn flat(nx: usize, ny: usize, cell: f64) -> Result<Self, ConfigError> {
        Self::new(Grid2::new(nx, ny, cell, Vec2::ZERO, 0.0)?, Edges::default(), 300.0)
    }

    /// A field placed on `terrain`, resampling its heights bilinearly. Errors if the grid
    /// does not lie entirely over the terrain.
    pub fn on_terrain(terrain: &Terrain, placement: Placement, edges: Edges) -> Result<Self, ConfigError> {
        placement.validate()?;
        let origin = placement.origin();
        let far =
            origin + Vec2::new((placement.nx - 1) as f32, (placement.ny - 1) as f32) * placement.cell as f32;
        if !terrain.contains(origin.x, origin.y) || !terrain.contains(far.x, far.y) {
            return Err(ConfigError::InvalidParameter {
                name: "lava field placement",
                value: placement.centre.x as f64,
                reason: format!("grid [{origin}, {far}] must lie inside the terrain"),
            });
        }
        let mut ground = Grid2::new(placement.nx, placement.ny, placement.cell, origin, 0.0)?;
        for j in 0..placement.ny {
            for i in 0..placement.nx {
                let p = ground.position(i, j);
                ground.set(i, j, terrain.heights().sample(p, Boundary::Clamp) as f64);
            }
        }
        Self::new(ground, edges, 300.0)
    }

    /// Cells along x.
    pub fn nx(&self) -> usize {
        self.h.nx()
    }
    /// Cells along y.
    pub fn ny(&self) -> usize {
        self.h.ny()
    }
    /// Cell size (m).
    pub fn cell(&self) -> f64 {
        self.h.cell()
    }
    /// Lava thickness (m).
    pub fn thickness(&self) -> &Grid2<f64> {
        &self.h
    }
    /// Lava temperature (K).
    pub fn temperature(&self) -> &Grid2<f64> {
        &self.temp
    }
    /// Ground altitude including frozen lava (m).
    pub fn ground(&self) -> &Grid2<f64> {
        &self.ground
    }
    /// Frozen lava thickness (m).
    pub fn solid(&self) -> &Grid2<f64> {
        &self.solid
    }
    /// Depth-averaged velocity components (m/s) over the last step.
    pub fn velocity(&self) -> (&Grid2<f64>, &Grid2<f64>) {
        (&self.vel[0], &self.vel[1])
    }
    /// Per-cell mobility multiplier set by the crust (1 where free, 1/4 under rigid crust).
    pub fn mobility_factor(&self) -> &[f64] {
        &self.mob_factor
    }
    /// Edge behaviour.
    pub fn edges(&self) -> Edges {
        self.edges
    }
    /// The volume accounts.
    pub fn budget(&self) -> &VolumeBudget {
        &self.budget
    }
    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Total liquid lava volume (m³), summed in row order.
    pub fn lava_volume(&self) -> f64 {
        let a = self.cell() * self.cell();
        self.h.data().iter().sum::<f64>() * a
    }

    /// Cell index containing world point `p`, or `None` off the grid.
    pub fn cell_at(&self, p: Vec2) -> Option<(usize, usize)> {
        let (gx, gy) = self.h.to_grid(p);
        let (i, j) = (gx.round(), gy.round());
        if !(gx.is_finite() && gy.is_finite()) || i < 0.0 || j < 0.0 {
            return None;
        }
        let (i, j) = (i as usize, j as usize);
        (i < self.nx() && j < self.ny()).then_some((i, j))
    }

    /// Cells whose centres lie within `radius` of `centre` (at least the cell containing it).
    fn disc(&self, centre: Vec2, radius: f64) -> Result<Vec<usize>, ConfigError> {
        let (ci, cj) = self.cell_at(centre).ok_or_else(|| ConfigError::InvalidParameter {
            name: "source position",
            value: centre.x as f64,
            reason: format!("({}, {}) is off the lava grid", centre.x, centre.y),
        })?;
        in_range("source radius", radius, 0.0, 1e4)?;
        let r = (radius / self.cell()).ceil() as i64;
        let mut cells = Vec::new();
        for dj in -r..=r {
            for di in -r..=r {
                let (i, j) = (ci as i64 + di, cj as i64 + dj);
                if i < 0 || j < 0 || i >= self.nx() as i64 || j >= self.ny() as i64 {
                    continue;
                }
                let p = self.h.position(i as usize, j as usize);
                if (p.distance(centre) as f64) <= radius {
                    cells.push(self.h.index(i as usize, j as usize));
                }
            }
        }
        if cells.is_empty() {
            cells.push(self.h.index(ci, cj));
        }
        Ok(cells)
    }

    /// A source feeding the cells within `radius` of world point `centre`. Errors on a
    /// negative or non-finite rate, a bad temperature, or a position off the grid.
    pub fn point_source(
        &self,
        centre: Vec2,
        radius: f64,
        rate: f64,
        temperature: f64,
    ) -> Result<Source, ConfigError> {
        check_source(rate, temperature)?;
        Ok(Source { cells: self.disc(centre, radius)?, rate, temperature })
    }

    /// A line source along row `j` across the whole width, `rate_per_width` in m³/s per metre.
    pub fn row_source(&self, j: usize, rate_per_width: f64, temperature: f64) -> Result<Source, ConfigError> {
        check_source(rate_per_width, temperature)?;
        if j >= self.ny() {
            return Err(ConfigError::InvalidParameter {
                name: "source row",
                value: j as f64,
                reason: format!("must be < {}", self.ny()),
            });
        }
        let cells = (0..self.nx()).map(|i| self.h.index(i, j)).collect();
        let rate = rate_per_width * self.cell() * self.nx() as f64;
        Ok(Source { cells, rate, temperature })
    }

    /// Places `volume` m³ of lava at `temperature` uniformly on the cells within `radius` of
    /// `centre` (a cylinder), booked as `initial` in the budget.
    pub fn place_volume(
        &mut self,
        centre: Vec2,
        radius: f64,
        volume: f64,
        temperature: f64,
    ) -> Result<(), ConfigError> {
        positive("volume", volume)?;
        check_source(0.0, temperature)?;
        let cells = self.disc(centre, radius)?;
        self.budget.initial += volume;
        self.deposit(&cells, volume, temperature);
        Ok(())
    }

    /// Adds `volume` spread evenly over `cells`, mixing temperature by volume.
    pub(crate) fn deposit(&mut self, cells: &[usize], volume: f64, temperature: f64) {
        let dh = volume / (cells.len() as f64 * self.cell() * self.cell());
        let (h, t) = (self.h.data_mut(), self.temp.data_mut());
        for &k in cells {
            let new_h = h[k] + dh;
            if new_h > 0.0 {
                t[k] = (h[k] * t[k] + dh * temperature) / new_h;
            }
            h[k] = new_h;
        }
    }

    /// Lava thickness, temperature and depth-averaged speed at a world point (nearest cell).
    pub fn probe(&self, p: Vec2) -> Option<CellProbe> {
        let (i, j) = self.cell_at(p)?;
        let k = self.h.index(i, j);
        Some(CellProbe {
            thickness: self.h.data()[k],
            temperature: self.temp.data()[k],
            ground: self.ground.data()[k],
            speed: self.vel[0].data()[k].hypot(self.vel[1].data()[k]),
        })
    }

    /// Whether every value of the state is finite and every thickness non-negative.
    pub fn is_valid(&self) -> bool {
        self.h.data().iter().all(|v| v.is_finite() && *v >= 0.0)
            && self.temp.data().iter().all(|v| v.is_finite())
            && self.ground.data().iter().all(|v| v.is_finite())
    }
}

/// One cell's state, for gameplay queries.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize)]
pub struct CellProbe {
    /// Lava thickness (m).
    pub thickness: f64,
    /// Lava temperature (K).
    pub temperature: f64,
    /// Ground altitude including frozen lava (m).
    pub ground: f64,
    /// Depth-averaged speed (m/s).
    pub speed: f64,
}
