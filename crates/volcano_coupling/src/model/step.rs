//! The coupling's two steps (thesis §4.3.3; docs/ARCHITECTURE.md §2.1, §3.3): everything the
//! coupling does to one atmosphere just before a weather step ([`plume_to_air`]) and just
//! after it ([`air_to_plume`]), on plain data, called by `CouplingPlugin`, the tests and the
//! bench alike. The coupling acts at two moments of a base tick, so its domain step comes in
//! these two halves; each covers every volcano over the atmosphere.
//!
//! - [`plume_to_air`]: frees the cells the last transfer held ([`release_columns`]), then for
//!   each column in the caller's order imposes the slice nearest each layer
//!   ([`nearest_slice_per_layer`], [`impose`]), then hands each parcel of shed ash to the
//!   layer it is in ([`inject_ash`]; outside the grid it is booked as outflow), then lifts the
//!   ground's heat sources (fountains, sea entries) into the layers ([`inject_source`]).
//! - [`air_to_plume`]: after a weather step, collects the ash the step dropped on the ground
//!   grid into the books and onto the terrain below (through the caller's `deposit`), then
//!   builds the ambient levels each requesting column reads ([`ambient_levels`]).

use bevy::math::{DVec2, DVec3};
use volcano_atmosphere::model::fields::{GridSpec, LayerFields};
use volcano_plume::AmbientLevel;

use super::books::CouplingBudget;
use super::column::{ColumnSlice, ambient_levels, impose, nearest_slice_per_layer, release_columns};
use super::heat::{GroundSource, inject_source};
use super::inject::{Delivered, inject_ash};

/// One atmosphere as the coupling sees it (borrowed from its components for a step).
#[derive(Debug)]
pub struct AirSide<'a> {
    /// The atmosphere's grid.
    pub grid: GridSpec,
    /// Its layers, bottom to top.
    pub layers: &'a mut [LayerFields],
    /// Ash on its ground grid (g/m² per cell, `grid.n²` values): what the weather dropped and
    /// the coupling has not collected yet.
    pub ground_ash: &'a mut [f64],
    /// Its books.
    pub books: &'a mut CouplingBudget,
}

/// What [`air_to_plume`] works on: like [`AirSide`], but it only reads the layers (so the
/// plugin reads them in place while a weather step holds them, without a copy).
pub struct AirReadSide<'a> {
    /// The atmosphere's grid.
    pub grid: GridSpec,
    /// Its layers, bottom to top.
    pub layers: &'a [&'a LayerFields],
    /// Ash on its ground grid (g/m² per cell, `grid.n²` values): what the weather dropped and
    /// the coupling has not collected yet.
    pub ground_ash: &'a mut [f64],
    /// Its books.
    pub books: &'a mut CouplingBudget,
}

/// One volcano's column over the atmosphere: its rising slices in emission order.
#[derive(Debug, Clone, Copy)]
pub struct CoupledColumn<'a> {
    /// Jet and buoyant slices, by emission index.
    pub slices: &'a [ColumnSlice],
    /// The column imposes its temperature and moisture (`CouplingSettings::plume_to_air`).
    pub plume_to_air: bool,
}

/// Ash a slice or umbrella sphere shed, handed to the air (world `(x, altitude, z)`, m; kg).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AshParcel {
    /// Where it is, world `(x, altitude, z)` (m).
    pub at: DVec3,
    /// Its mass (kg).
    pub kg: f64,
}

/// The ground's heat sources over an atmosphere for one weather step.
#[derive(Debug, Clone, Copy, Default)]
pub struct GroundHeat<'a> {
    /// The sources, in the caller's order.
    pub sources: &'a [GroundSource],
    /// Seconds of their rates the step receives (the weather step's length).
    pub seconds: f64,
}

/// What [`plume_to_air`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlumeToAirReport {
    /// Heat the ground's sources gave the layers (J).
    pub heat_in_j: f64,
    /// Sources whose air was neutral or unstable, their rise computed with the floor
    /// ([`super::heat::MIN_BUOYANCY_FREQUENCY`]; a limiter).
    pub stability_floored: u32,
    /// Columns imposed.
    pub columns: u32,
    /// Ash handed to the layers or the ground grid (kg).
    pub ash_in_kg: f64,
    /// Ash handed over outside the grid, booked as outflow (kg).
    pub ash_outside_kg: f64,
}

/// Plume → air, just before a weather step (see the module docs). `parcels` are taken in
/// their order (the plugin: slices by volcano and emission index, umbrella spheres by id, then
/// what expired spheres released), so the sums are the same bits every run.
pub fn plume_to_air(
    air: &mut AirSide,
    columns: &[CoupledColumn],
    parcels: &[AshParcel],
    heat: GroundHeat,
) -> PlumeToAirReport {
    let mut report = PlumeToAirReport::default();
    release_columns(air.layers);
    for column in columns.iter().filter(|c| c.plume_to_air) {
        let nearest = nearest_slice_per_layer(air.layers, column.slices);
        let r = impose(air.layers, air.grid, column.slices, &nearest);
        air.books.water_written_g += r.water_written_g;
        air.books.last_transfer = r;
        report.columns += 1;
    }
    for p in parcels {
        air.books.ash_received_kg += p.kg;
        let to = inject_ash(air.layers, air.ground_ash, air.grid, (p.at.x, p.at.y, p.at.z), p.kg * 1e3);
        if to == Delivered::Outside {
            air.books.ash_outflow_kg += p.kg;
            report.ash_outside_kg += p.kg;
        } else {
            report.ash_in_kg += p.kg;
        }
    }
    for source in heat.sources {
        let r = inject_source(air.layers, air.grid, source, heat.seconds);
        air.books.heat_received_j += r.heat_j;
        air.books.vapour_received_kg += r.vapour_g * 1e-3;
        air.books.heat_outflow_j += r.outside.0;
        air.books.vapour_outflow_kg += r.outside.1 * 1e-3;
        report.heat_in_j += r.heat_j;
        report.stability_floored += u32::from(r.stability_floored);
    }
    report
}

/// A column asking for its ambient (air → plume).
#[derive(Debug, Clone, Copy)]
pub struct AmbientRequest<'a> {
    /// Its rising slices, by emission index.
    pub slices: &'a [ColumnSlice],
    /// Its vent, world `(x, z)` (m): the annulus centre in layers no slice reaches.
    pub vent: DVec2,
    /// Its vent radius (m): the column's radius there.
    pub r0: f64,
}

/// What [`air_to_plume`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AirToPlumeReport {
    /// Ash collected from the ground grid (kg).
    pub ash_fallen_kg: f64,
    /// Of it, what fell where `deposit` found no terrain (kg).
    pub ash_off_terrain_kg: f64,
    /// Per request, in order: the ambient levels its slices read (bottom to top; layers with
    /// no free cell in the annulus skipped).
    pub ambients: Vec<Vec<AmbientLevel>>,
}

/// Air → plume, just after a weather step (see the module docs). With `collect_ash`, every
/// cell of the ground grid holding ash is emptied into the books and handed to
/// `deposit(x, z, kg)` at the cell's centre (world `(x, z)`), which returns whether a terrain
/// took it. Then each request gets its ambient levels.
pub fn air_to_plume(
    air: &mut AirReadSide,
    collect_ash: bool,
    requests: &[AmbientRequest],
    mut deposit: impl FnMut(f64, f64, f64) -> bool,
) -> AirToPlumeReport {
    let mut report = AirToPlumeReport::default();
    if collect_ash {
        let area = air.grid.dx * air.grid.dx;
        for (k, a) in air.ground_ash.iter_mut().enumerate() {
            if *a > 0.0 {
                let kg = *a * area * 1e-3;
                *a = 0.0;
                air.books.ash_deposited_kg += kg;
                report.ash_fallen_kg += kg;
                let (x, z) = air.grid.centre(k);
                if !deposit(x, z, kg) {
                    air.books.ash_off_terrain_kg += kg;
                    report.ash_off_terrain_kg += kg;
                }
            }
        }
    }
    report.ambients = requests
        .iter()
        .map(|r| {
            let nearest = nearest_slice_per_layer(air.layers, r.slices);
            ambient_levels(air.layers, air.grid, r.slices, &nearest, r.vent, r.r0)
        })
        .collect();
    report
}
