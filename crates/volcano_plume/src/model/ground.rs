//! What eruptions leave on the ground and their books, as plain data (many volcanoes on many
//! terrains share nothing): the [`DepositMap`] of one terrain (the
//! pyroclastic flows and the coupled ash fall of the volcanoes standing on it add to it), and
//! the [`PyroclasticBudget`] of one volcano. The plugins keep them as components (on every
//! `Terrain` and on every volcano with an `Eruption`); the pyroclastic domain's step
//! ([`crate::model::flows`]) works on them directly.

use bevy::math::Vec2;
use bevy::prelude::{Component, ReflectComponent, ReflectDefault};
use bevy::reflect::Reflect;
use volcano_core::{Boundary, Grid2, Terrain};

use crate::model::deposit;

/// Ash deposited on one terrain, per terrain node (kg, f64). Every `Terrain` gets one (the
/// plume plugin makes it a required component). Particles run over `surface` (terrain +
/// deposit), and the deposit relaxes toward its angle of repose four passes a second
/// ([`crate::model::deposit`]).
#[derive(Component, Debug, Clone, Default, Reflect)]
#[reflect(opaque)]
#[reflect(Component, Debug, Default)]
pub struct DepositMap {
    /// Deposited mass per node (kg); `None` until the first flow or ash fall reaches it.
    pub mass: Option<Grid2<f64>>,
    /// Terrain height plus deposit thickness (m), what particles collide with.
    pub surface: Option<Grid2<f32>>,
    /// Bulk density used for thickness (kg/m³): that of the last eruption that deposited here.
    pub bulk_density: f64,
    /// Angle of repose the deposit relaxes to (degrees): that of the last eruption that
    /// deposited here (0 until one has).
    pub repose_angle_deg: f64,
    /// Bumped whenever the deposit changes (renderers redraw when it moves).
    pub revision: u64,
    pub(crate) scratch: Vec<f64>,
}

impl DepositMap {
    /// Deposit thickness (m) at world `(x, z)`; 0 off the map.
    pub fn thickness_at(&self, x: f32, z: f32) -> f64 {
        let Some(g) = &self.mass else { return 0.0 };
        let p = Vec2::new(x, z);
        if !g.contains(p) || self.bulk_density <= 0.0 {
            return 0.0;
        }
        deposit::thickness(g.nearest(p, Boundary::Clamp), g.cell(), self.bulk_density)
    }
    /// Deposit thickness (m) at node `(i, j)` of the terrain grid; 0 outside.
    pub fn thickness_at_node(&self, i: usize, j: usize) -> f64 {
        match &self.mass {
            Some(g) if i < g.nx() && j < g.ny() => {
                deposit::thickness(g.get(i, j), g.cell(), self.bulk_density)
            }
            _ => 0.0,
        }
    }
    /// Total deposited mass (kg).
    pub fn total(&self) -> f64 {
        self.mass.as_ref().map_or(0.0, |g| g.data().iter().sum())
    }
    /// Creates the grids over `terrain` if they do not exist yet, or anew (emptied) if the
    /// terrain's grid changed size, with the relaxation's scratch, every page of them written
    /// once now: zeroed memory is mapped on first write, and the first relaxation after the
    /// first deposit writes the whole mass grid and its scratch, ≈ 1,000 page faults at 513²,
    /// which would make that one tick take 3–18 ms (`volcano bench`'s tick 107 of `eruption`). The
    /// plugin calls this for the terrains erupting volcanoes stand on before their first tick.
    pub fn ensure(&mut self, terrain: &Terrain) {
        if !self.fits(terrain) {
            let h = terrain.heights();
            self.mass = Grid2::new(h.nx(), h.ny(), h.cell(), h.origin(), 0.0).ok();
            self.surface = Some(h.clone());
            self.scratch = vec![0.0; h.nx() * h.ny()];
            if let Some(m) = self.mass.as_mut() {
                touch_pages(m.data_mut());
            }
            touch_pages(&mut self.scratch);
        }
    }
    /// Whether the grids exist and match `terrain`'s size.
    pub fn fits(&self, terrain: &Terrain) -> bool {
        let h = terrain.heights();
        self.mass.as_ref().is_some_and(|g| g.nx() == h.nx() && g.ny() == h.ny())
    }
    /// Adds `mass` kg at world `(x, z)` = `p` on `terrain` (this map's terrain; the grids are
    /// created over it if needed; `bulk_density` kg/m³ is used if the map has none yet).
    /// Returns false, adding nothing, where `p` is off the terrain. Used for ash fall from the
    /// coupled atmosphere.
    pub fn add_on(&mut self, terrain: &Terrain, p: Vec2, mass: f64, bulk_density: f64) -> bool {
        if mass.is_nan() || mass <= 0.0 || !terrain.contains(p.x, p.y) {
            return false;
        }
        self.ensure(terrain);
        if self.bulk_density <= 0.0 {
            self.bulk_density = bulk_density;
        }
        self.add(p, mass);
        true
    }
    /// Lets the deposit slide to its angle of repose: `passes` Jacobi passes of
    /// [`deposit::relax_to_repose`] (the angle of the last eruption that deposited here, the
    /// default [`crate::PyroclasticParams`]' for a map that only received ash fall), then the
    /// collision surface follows. Returns whether anything moved (the revision is bumped). A
    /// map without grids, or whose grids no longer match `terrain`, is left alone.
    pub fn relax(&mut self, terrain: &Terrain, passes: usize) -> bool {
        let h = terrain.heights();
        if self.mass.as_ref().is_none_or(|m| h.nx() != m.nx() || h.ny() != m.ny()) {
            return false;
        }
        let (Some(mass), Some(surface)) = (self.mass.as_mut(), self.surface.as_mut()) else { return false };
        let angle = if self.repose_angle_deg > 0.0 {
            self.repose_angle_deg
        } else {
            crate::model::pyroclastic::PyroclasticParams::default().repose_angle_deg
        };
        let tan = angle.to_radians().tan();
        let (dims, cell) = ((mass.nx(), mass.ny()), mass.cell());
        let mut moved = 0.0;
        for _ in 0..passes {
            moved += deposit::relax_to_repose(
                h.data(),
                mass.data_mut(),
                dims,
                cell,
                self.bulk_density,
                tan,
                &mut self.scratch,
            );
        }
        if moved > 0.0 {
            deposit::deposit_surface(h.data(), mass.data(), cell, self.bulk_density, surface.data_mut());
            self.revision += 1;
        }
        moved > 0.0
    }
    /// Adds mass to the nearest node and raises the surface there.
    /// Adds `mass` kg spread evenly over the terrain nodes in the square of half-side `half` m
    /// around world `(x, z)` = `centre` (nodes on its west and south edges included, on its
    /// east and north edges not, so the squares of neighbouring cells share no node): ash fall
    /// from an atmosphere cell lands uniformly over the cell's footprint, not on the one node
    /// nearest its centre. Where no node lies in the square (a terrain coarser than the cell),
    /// the nearest node takes it all. Grids and bulk density as in [`Self::add_on`]; returns
    /// false, adding nothing, where `centre` is off the terrain.
    pub fn add_over(
        &mut self,
        terrain: &Terrain,
        centre: Vec2,
        half: f32,
        mass: f64,
        bulk_density: f64,
    ) -> bool {
        if !half.is_finite() || half <= 0.0 {
            return self.add_on(terrain, centre, mass, bulk_density);
        }
        if mass.is_nan() || mass <= 0.0 || !terrain.contains(centre.x, centre.y) {
            return false;
        }
        self.ensure(terrain);
        if self.bulk_density <= 0.0 {
            self.bulk_density = bulk_density;
        }
        let (Some(g), Some(s)) = (self.mass.as_mut(), self.surface.as_mut()) else { return false };
        // Node indices whose positions lie in [centre - half, centre + half).
        let span = |lo: f64, n: usize| {
            let first = lo.ceil().max(0.0);
            let last = (lo + 2.0 * half as f64 / g.cell()).ceil() - 1.0;
            let last = last.min(n as f64 - 1.0);
            (first <= last).then_some((first as usize, last as usize))
        };
        let (gx, gy) = g.to_grid(centre);
        let half_cells = half as f64 / g.cell();
        let (Some((i0, i1)), Some((j0, j1))) = (span(gx - half_cells, g.nx()), span(gy - half_cells, g.ny()))
        else {
            self.add(centre, mass);
            return true;
        };
        let share = mass / ((i1 - i0 + 1) * (j1 - j0 + 1)) as f64;
        let rise = deposit::thickness(share, g.cell(), self.bulk_density) as f32;
        for j in j0..=j1 {
            for i in i0..=i1 {
                g.set(i, j, g.get(i, j) + share);
                s.set(i, j, s.get(i, j) + rise);
            }
        }
        self.revision += 1;
        true
    }

    pub(crate) fn add(&mut self, p: Vec2, mass: f64) {
        let (Some(g), Some(s)) = (self.mass.as_mut(), self.surface.as_mut()) else { return };
        let (fx, fy) = g.to_grid(p);
        let i = (fx.round().max(0.0) as usize).min(g.nx() - 1);
        let j = (fy.round().max(0.0) as usize).min(g.ny() - 1);
        g.set(i, j, g.get(i, j) + mass);
        let rise = deposit::thickness(mass, g.cell(), self.bulk_density) as f32;
        s.set(i, j, s.get(i, j) + rise);
        self.revision += 1;
    }
}

/// Writes a zero into every 4 KiB page of `data` (already zero: `black_box` keeps the compiler
/// from dropping stores it knows change nothing), so the pages are mapped now, not in a tick.
fn touch_pages(data: &mut [f64]) {
    for v in data.iter_mut().step_by(4096 / std::mem::size_of::<f64>()) {
        *v = std::hint::black_box(0.0);
    }
}

/// Mass accounting of one volcano's pyroclastic flows (kg): `collapsed = airborne + deposited +
/// lifted + lost`, with airborne the mass of its live particles. On every volcano with an
/// `Eruption` (a required component).
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component, Debug, Default)]
pub struct PyroclasticBudget {
    /// Mass of slices handed over to particles.
    pub collapsed: f64,
    /// Mass deposited on the terrain.
    pub deposited: f64,
    /// Mass lifted into secondary columns.
    pub lifted: f64,
    /// Mass of particles that left the volcano's terrain (or a volcano on no terrain).
    pub lost: f64,
    /// Particles spawned so far.
    pub spawned: u64,
    /// Secondary columns formed so far.
    pub secondary_columns: u64,
    /// Of `deposited`, `lost` and `lifted`, the mass the caps removed (particles settled by
    /// [`crate::caps::PlumeCaps::max_particles`], clusters lifted without a column by
    /// [`crate::caps::PlumeCaps::max_secondary_per_step`]).
    pub capped: f64,
    /// Particles settled by that cap.
    pub capped_particles: u64,
}

impl std::ops::AddAssign for PyroclasticBudget {
    /// Sums two volcanoes' books (for reports over every volcano).
    fn add_assign(&mut self, o: Self) {
        self.collapsed += o.collapsed;
        self.deposited += o.deposited;
        self.lifted += o.lifted;
        self.lost += o.lost;
        self.spawned += o.spawned;
        self.secondary_columns += o.secondary_columns;
        self.capped += o.capped;
        self.capped_particles += o.capped_particles;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat 2 km terrain of 10 m cells, its first node at (-1000, -1000).
    fn flat() -> Terrain {
        Terrain::flat(201, 10.0, 0.0).unwrap()
    }

    #[test]
    fn ash_from_a_cell_lands_evenly_over_its_footprint() {
        let (terrain, mut map) = (flat(), DepositMap::default());
        // The ash of one 200 m atmosphere cell centred on (100, 100): 10⁶ kg at 1,000 kg/m³ is a
        // uniform layer of 10⁶ / (200² · 1,000) = 2.5 cm over the cell, nothing beside it.
        assert!(map.add_over(&terrain, Vec2::new(100.0, 100.0), 100.0, 1e6, 1_000.0));
        for (x, z) in [(100.0, 100.0), (10.0, 190.0), (0.0, 0.0), (190.0, 5.0)] {
            assert!((map.thickness_at(x, z) - 0.025).abs() < 1e-12, "({x}, {z}): {}", map.thickness_at(x, z));
        }
        for (x, z) in [(200.0, 100.0), (-10.0, 100.0), (100.0, 200.0), (100.0, -10.0)] {
            assert_eq!(map.thickness_at(x, z), 0.0, "({x}, {z}) is in the neighbouring cells");
        }
        assert!((map.total() - 1e6).abs() <= 1e-9, "mass kept: {}", map.total());
        // The neighbouring cell's footprint shares no node with this one: a second cell beside
        // it doubles no node.
        assert!(map.add_over(&terrain, Vec2::new(300.0, 100.0), 100.0, 1e6, 1_000.0));
        assert!((map.thickness_at(190.0, 100.0) - 0.025).abs() < 1e-12);
        assert!((map.thickness_at(200.0, 100.0) - 0.025).abs() < 1e-12);
        let surface = map.surface.as_ref().unwrap();
        assert!((surface.nearest(Vec2::new(250.0, 50.0), Boundary::Clamp) - 0.025).abs() < 1e-6);
    }

    #[test]
    fn at_the_terrain_edge_and_below_its_resolution_no_ash_is_lost() {
        let (terrain, mut map) = (flat(), DepositMap::default());
        // A cell hanging over the east edge: all of its ash lands on the nodes it covers.
        assert!(map.add_over(&terrain, Vec2::new(950.0, 0.0), 100.0, 5e5, 1_000.0));
        assert!((map.total() - 5e5).abs() <= 1e-9);
        assert!(map.thickness_at(1_000.0, 0.0) > 0.0 && map.thickness_at(840.0, 0.0) == 0.0);
        // A cell smaller than the terrain's spacing with no node inside: the nearest node.
        let mut fine = DepositMap::default();
        assert!(fine.add_over(&terrain, Vec2::new(4.0, 4.0), 0.5, 100.0, 1_000.0));
        assert_eq!(fine.mass.as_ref().unwrap().nearest(Vec2::ZERO, Boundary::Clamp), 100.0);
        // Off the terrain or not a mass: nothing.
        assert!(!fine.add_over(&terrain, Vec2::new(5_000.0, 0.0), 100.0, 1.0, 1_000.0));
        assert!(!fine.add_over(&terrain, Vec2::ZERO, 100.0, f64::NAN, 1_000.0));
        assert_eq!(fine.total(), 100.0);
    }
}
