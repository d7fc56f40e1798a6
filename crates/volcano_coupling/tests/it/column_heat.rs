//! What a steady column does to the air around it (plume → air, thesis §4.3.3), on the
//! engine-free models: a fixed column of slices imposed before every weather step.
//!
//! The column is an entraining plume: below its umbrella it draws air in and carries its heat
//! up, so the air it reads as its surroundings (the annulus of the air → plume transfer) must
//! stay near the undisturbed air. Imposing the slice's temperature on whole grid cells when the
//! column is narrower than a cell gives the layers the heat of a column `dx² / (π r²)` times too
//! wide: in the coupled `eruption` scene the vent layer's annulus then reads 789 K after 2
//! minutes (the undisturbed air 275 K) and the column collapses.

use bevy::math::DVec2;
use volcano_atmosphere::model::step::{Workspace, step};
use volcano_atmosphere::{AtmosphereState, WeatherScenario};
use volcano_coupling::model::column::{
    ColumnSlice, ambient_levels, annulus_bounds, for_cells_within, impose, nearest_slice_per_layer,
    release_columns,
};

/// Light wind, moist low layers, flat ground at sea level, `n`² cells over 25.6 km.
fn air(n: usize) -> WeatherScenario {
    let text = format!(
        "Scenario(name: \"column\", grid: {n}, extent_m: 25600.0, dt: 1.0, steps: 1, start_hour: 12.0, \
         day_of_year: 172.0, latitude_deg: 43.0, profile: UsStandard1976, terrain: Flat(height_m: 0.0, cover: Ground), \
         layers: [\
         (altitude_m: 1000.0, relative_humidity: (base: 0.8), wind: (2.0, 0.0), wind_relaxation_s: Some(600.0)), \
         (altitude_m: 3000.0, relative_humidity: (base: 0.6), wind: (2.0, 0.0), wind_relaxation_s: Some(600.0)), \
         (altitude_m: 6000.0, relative_humidity: (base: 0.4), wind: (3.0, 0.0), wind_relaxation_s: Some(600.0)), \
         (altitude_m: 10000.0, relative_humidity: (base: 0.3), wind: (3.0, 0.0), wind_relaxation_s: Some(600.0))])"
    );
    ron::from_str(&text).expect("valid scenario")
}

/// A Plinian column of the thesis' kind over the centre: a 100 m vent at 1,270 K widening to
/// 1.6 km at 12 km, still 520 K there (the dense mixture keeps its heat), one slice every 100 m.
fn column() -> Vec<ColumnSlice> {
    (0..120)
        .map(|i| {
            let z = 50.0 + 100.0 * i as f64;
            ColumnSlice {
                centre: DVec2::ZERO,
                altitude: z,
                radius: 100.0 + 0.125 * z,
                temperature: 1270.0 - 0.0625 * z,
                water_fraction: 0.03,
            }
        })
        .collect()
}

/// Mean temperature (K) of layer `l`'s cells beyond 10 km of the column.
fn far_air(state: &AtmosphereState, l: usize) -> f64 {
    let f = &state.layers[l];
    let (mut sum, mut count) = (0.0, 0.0);
    for (k, &t) in f.t.data().iter().enumerate() {
        let (x, z) = state.grid.centre(k);
        if DVec2::new(x, z).length() > 10_000.0 {
            sum += t as f64;
            count += 1.0;
        }
    }
    sum / count
}

/// Heat the imposition added to layer `l` over the free cells within `radius` of the column,
/// as `Σ (T − T_before) σ dx²` (K m², per metre of slab).
fn imposed_excess(before: &AtmosphereState, after: &AtmosphereState, l: usize, radius: f64) -> f64 {
    let (b, a) = (&before.layers[l], &after.layers[l]);
    let area = after.grid.dx * after.grid.dx;
    let mut excess = 0.0;
    for_cells_within(after.grid, DVec2::ZERO, radius, |k, _| {
        excess += (a.t.data()[k] - b.t.data()[k]) as f64 * a.sigma.data()[k] as f64 * area;
    });
    excess
}

#[test]
fn a_narrow_column_gives_a_layer_the_heat_of_its_own_cross_section_whatever_the_grid() {
    // The vent layer: a 100–250 m column, narrower than the cells of all three grids.
    let slices = column();
    let mut per_grid = Vec::new();
    for n in [64, 128, 256] {
        let before = air(n).build(None).unwrap();
        let mut after = before.clone();
        let near = nearest_slice_per_layer(&after.layers, &slices);
        let report = impose(&mut after.layers, after.grid, &slices, &near);
        assert!(report.cells_imposed > 0);
        let s = slices[near[0].unwrap()];
        let t_air = far_air(&before, 0);
        // The column's own cross-section: π r² (T_s − T_air).
        let own = std::f64::consts::PI * s.radius * s.radius * (s.temperature - t_air);
        let got = imposed_excess(&before, &after, 0, annulus_bounds(s.radius, after.grid.dx).0);
        per_grid.push((after.grid.dx, got / own));
    }
    eprintln!("imposed heat / the column's own, per cell size: {per_grid:?}");
    for &(dx, ratio) in &per_grid {
        assert!((0.8..=1.25).contains(&ratio), "dx {dx} m: the layer took {ratio:.2}× the column's heat");
    }
}

#[test]
fn a_steady_column_does_not_heat_the_air_it_reads_as_its_surroundings() {
    let scenario = air(64);
    let mut state = scenario.build(None).unwrap();
    let mut work = Workspace::new(&state).unwrap();
    let slices = column();
    let far0: Vec<f64> = (0..state.layers.len()).map(|l| far_air(&state, l)).collect();
    // Four minutes of weather steps, the column imposed before each (as the plugin does).
    for _ in 0..240 {
        let near = nearest_slice_per_layer(&state.layers, &slices);
        release_columns(&mut state.layers);
        impose(&mut state.layers, state.grid, &slices, &near);
        step(&mut state, &scenario.params, &mut work, 1.0).unwrap();
    }
    let near = nearest_slice_per_layer(&state.layers, &slices);
    let ambient = ambient_levels(&state.layers, state.grid, &slices, &near, DVec2::ZERO, 100.0);
    let rise: Vec<(f64, f64)> =
        ambient.iter().zip(&far0).map(|(a, f)| (a.altitude, a.temperature - f)).collect();
    eprintln!("annulus minus the undisturbed air after 240 s (altitude, K): {rise:?}");
    // The column is at 520–1,270 K: a surrounding that warmed by tens of kelvin would already
    // take a large share of its buoyancy.
    for (z, dt) in rise {
        assert!(dt.abs() < 10.0, "the air around the column at {z} m warmed by {dt:.1} K");
    }
}

/// Mean temperature (K) and water (vapour + condensed, g/m³) of layer `l`'s cells within
/// `radius` of the column's axis.
fn near_axis(state: &AtmosphereState, l: usize, radius: f64) -> (f64, f64) {
    let f = &state.layers[l];
    let (mut t, mut water, mut count) = (0.0, 0.0, 0.0);
    for_cells_within(state.grid, DVec2::ZERO, radius, |k, _| {
        t += f.t.data()[k] as f64;
        water += f.h.data()[k] + f.w.data()[k];
        count += 1.0;
    });
    (t / count, water / count)
}

#[test]
fn a_column_that_stops_below_a_layer_does_not_heat_it() {
    // The column's heat rises in its slices; where no slice reaches (above the top, or before
    // the column has climbed), the layers must not carry it up a second time. Layers that do
    // carry it put the 12 km layer of the `cloud-cap` CLI run on 200 m cells at 586 K around
    // the vent after 60 s, before any slice gets there, and the column then stops at 7.3 km.
    let scenario = air(128);
    let mut state = scenario.build(None).unwrap();
    let mut work = Workspace::new(&state).unwrap();
    // The same column, topped at 7 km: the 10 km layer has no slice.
    let slices: Vec<ColumnSlice> = column().into_iter().filter(|s| s.altitude < 7000.0).collect();
    let top = state.layers.len() - 1;
    let far0 = far_air(&state, top);
    let (_, water0) = near_axis(&state, top, 3000.0);
    for _ in 0..120 {
        let near = nearest_slice_per_layer(&state.layers, &slices);
        assert!(near[top].is_none());
        release_columns(&mut state.layers);
        impose(&mut state.layers, state.grid, &slices, &near);
        step(&mut state, &scenario.params, &mut work, 1.0).unwrap();
    }
    let (t_near, water) = near_axis(&state, top, 3000.0);
    eprintln!(
        "top layer within 3 km of the axis after 120 s: {:.1} K above the far air (which moved {:.2} K), \
         water {water0:.4} -> {water:.4} g/m³",
        t_near - far_air(&state, top),
        far_air(&state, top) - far0
    );
    assert!(
        (t_near - far_air(&state, top)).abs() < 10.0,
        "the layer above the column's top warmed by {:.1} K",
        t_near - far_air(&state, top)
    );
}
