//! Terrain ↔ layer geometry: σ is the free fraction of each layer's slab, ℓ(p) is the layer
//! whose slab holds the ground, and the projected wind does not cross the terrain.

use volcano_atmosphere::AtmosphereState;
use volcano_atmosphere::model::advection::apertures;
use volcano_atmosphere::model::run::run;
use volcano_atmosphere::model::scenario::WeatherScenario;
use volcano_atmosphere::model::step::{Workspace, step};
use volcano_atmosphere::model::terrain::update_masks;

/// Sets the ground to `height`, recomputes σ and ℓ(p) and clears water and ash inside rock
/// (as a scenario's build does).
fn reshape_ground(st: &mut AtmosphereState, height: impl Fn(usize, usize) -> f32) {
    let n = st.grid.n;
    for (k, h) in st.ground.height.data_mut().iter_mut().enumerate() {
        *h = height(k % n, k / n);
    }
    update_masks(st);
    for l in st.layers.iter_mut() {
        for k in 0..n * n {
            if l.sigma.data()[k] <= 0.0 {
                (l.h.data_mut()[k], l.w.data_mut()[k], l.ash.data_mut()[k]) = (0.0, 0.0, 0.0);
            }
        }
    }
}

/// On the orographic ridge (0–1500 m, smooth slopes; slabs 0–800, 800–1700, 1700–2850 and
/// 2850–4150 m) every cell's free air column, summed over the layers, is the geometric air
/// column between the ground and the top of the model, and the ground exchanges with the
/// layer whose slab contains the ground.
#[test]
fn free_fraction_is_the_slab_above_the_ground_and_lowest_layer_holds_the_ground() {
    let s = WeatherScenario::builtin("orographic").unwrap();
    let st = s.build(Some(64)).unwrap();
    let heights = st.ground.height.data();
    let (bottom, last) = (st.layers[0].bottom, st.layers.last().unwrap());
    let top = last.bottom + last.thickness;
    let mut on_slope = 0;
    let mut at_1100 = None;
    for (k, &t) in heights.iter().enumerate() {
        let t = t as f64;
        let column: f64 = st.layers.iter().map(|l| l.sigma.data()[k] as f64 * l.thickness).sum();
        let geometric = top - t.max(bottom);
        assert!(
            (column - geometric).abs() < 0.05,
            "cell {k}, ground {t:.1} m: free column {column:.2} m, geometric {geometric:.2} m"
        );
        let l = st.ground.lowest[k] as usize;
        let layer = &st.layers[l];
        assert!(
            (layer.bottom <= t || l == 0) && t < layer.bottom + layer.thickness,
            "cell {k}, ground {t:.1} m: ℓ = {l} with slab {}–{} m",
            layer.bottom,
            layer.bottom + layer.thickness
        );
        // Every layer below ℓ(p) is rock; ℓ(p) holds some air.
        assert!(st.layers[..l].iter().all(|b| b.sigma.data()[k] == 0.0));
        assert!(layer.sigma.data()[k] > 0.0);
        if t > 100.0 && t < 1400.0 {
            on_slope += 1;
        }
        if (t - 1100.0).abs() < 100.0 {
            at_1100 = Some((k, l));
        }
    }
    assert!(on_slope > 20, "the ridge must give sloping cells ({on_slope})");
    let (k, l) = at_1100.expect("a cell near 1,100 m on the ridge");
    assert_eq!(l, 1, "ground at {} m lies in layer 1's slab (800–1700 m)", heights[k]);
    // Amounts stay conserved with this geometry (rain, ground exchange, transfers, transport).
    let r = run(&s, Some(40), None, Some(32)).unwrap();
    assert!(r.summary.valid);
    assert!(r.summary.water_air_rel_error < 1e-9, "water drift {:e}", r.summary.water_air_rel_error);
}

/// A 2,000 m block (taller than the 0–800 and 800–1,700 m slabs, cutting into the third) in
/// an 8 m/s westerly. After a step, no wind blows through a closed face (both sides rock or
/// one side rock), and the face fluxes `a·V` (aperture × wind) meet the continuity target
/// −(D_i − D_{i−1})/h_i in every open cell (its mean over the open cells removed, as the
/// torus requires) — computed here independently of the model's own diagnostics.
#[test]
fn projected_wind_does_not_blow_into_a_block_of_terrain() {
    let s = WeatherScenario::builtin("orographic").unwrap();
    let mut st = s.build(Some(32)).unwrap();
    reshape_ground(&mut st, |i, j| if (12..18).contains(&i) && (10..22).contains(&j) { 2000.0 } else { 0.0 });
    let mut work = Workspace::new(&st).unwrap();
    for _ in 0..3 {
        step(&mut st, &s.params, &mut work, s.dt).unwrap();
    }
    let (n, dx) = (st.grid.n, st.grid.dx);
    let speed = 8.0 / dx; // the wind's scale of divergence (1/s)
    let (mut ax, mut ay) = (vec![0.0f32; n * n], vec![0.0f32; n * n]);
    let mut solid_faces = 0;
    for (li, l) in st.layers.iter().enumerate() {
        apertures(l.sigma.data(), n, &mut ax, &mut ay);
        let (u, v) = (l.u.data(), l.v.data());
        let mut worst_solid = 0.0f32;
        for k in 0..n * n {
            if ax[k] == 0.0 {
                worst_solid = worst_solid.max(u[k].abs());
                solid_faces += 1;
            }
            if ay[k] == 0.0 {
                worst_solid = worst_solid.max(v[k].abs());
                solid_faces += 1;
            }
        }
        assert!(worst_solid < 1e-6, "layer {li}: {worst_solid} m/s through rock");
        let d_below = |k: usize| if li == 0 { 0.0 } else { st.layers[li - 1].d.data()[k] as f64 };
        let target: Vec<f64> =
            (0..n * n).map(|k| -(l.d.data()[k] as f64 - d_below(k)) / l.thickness).collect();
        let east = |k: usize| (k / n) * n + (k % n + 1) % n;
        let north = |k: usize| ((k / n + 1) % n) * n + k % n;
        let open: Vec<usize> =
            (0..n * n).filter(|&k| ax[k] + ax[east(k)] + ay[k] + ay[north(k)] > 0.0).collect();
        let mean = open.iter().map(|&k| target[k]).sum::<f64>() / open.len() as f64;
        let mut worst = 0.0f64;
        for &k in &open {
            let flux = |a: f32, w: f32| a as f64 * w as f64;
            let div = (flux(ax[east(k)], u[east(k)]) - flux(ax[k], u[k]) + flux(ay[north(k)], v[north(k)])
                - flux(ay[k], v[k]))
                / dx;
            worst = worst.max((div - (target[k] - mean)).abs());
        }
        assert!(worst < 1e-3 * speed, "layer {li}: |∇·(aV) − target| up to {worst:e} 1/s");
    }
    assert!(solid_faces > 100, "the block must close faces ({solid_faces})");
}
