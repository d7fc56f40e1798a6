//! Volcanic ash in the layers (thesis §4.3: the plume feeds the layers' ash, which the wind
//! carries): settling through the layers to the ground, and an open rim.
//!
//! Ash is a passive tracer like H and W (concentration in g/m³, amounts = concentration × free
//! air volume σ h dx²), advected in flux form with the layer wind and carried between layers by
//! the vertical exchange (eq 4.6). Beyond the thesis, which renders ash but does not say where
//! it goes:
//! - it **settles** at a speed `w_s` (a parameter standing for a grain size: about 0.1 m/s for
//!   fine ash, 1 m/s for coarse ash) from each layer into the free layer below, and from the
//!   lowest free layer of a column onto the ground, where it is booked as fall deposit;
//! - the domain is a torus for the weather, but ash blown past the **rim** leaves: what reaches
//!   the outermost ring of cells is removed and booked as outflow, so ash carried downwind does
//!   not re-enter upwind. This is exact as long as ash moves less than one cell per step (the
//!   report says when it could move more).

use bevy::math::Vec2;
use volcano_core::grid::Boundary;

use super::fields::LayerFields;

/// Which layers' fields make a tracer at altitude `z`: `(lower, upper, weight of upper)`,
/// linear in altitude between the centres (`altitude`) of adjacent layers, the nearest layer's
/// own value between its centre and its slab's outer boundary, `None` outside the stack.
/// The layers are a stack of slabs, lowest first. (The thesis' layers hold one value per
/// slab; the blend is this project's reading for a point inside the stack, so a curtain
/// sheared by the winds leans smoothly instead of in steps.)
pub fn layer_blend(layers: &[&LayerFields], z: f64) -> Option<(usize, usize, f64)> {
    let (first, last) = (layers.first()?, layers.last()?);
    if !(z >= first.bottom && z < last.bottom + last.thickness) {
        return None;
    }
    let above = layers.iter().position(|l| l.altitude > z);
    Some(match above {
        None => (layers.len() - 1, layers.len() - 1, 0.0),
        Some(0) => (0, 0, 0.0),
        Some(u) => {
            let (a, b) = (layers[u - 1].altitude, layers[u].altitude);
            (u - 1, u, ((z - a) / (b - a)).clamp(0.0, 1.0))
        }
    })
}

/// Ash concentration (g/m³) at grid position `p` (world x, z) for the blend `(lower, upper,
/// w)` of [`layer_blend`]: bilinear in each layer's field, linear between the two layers.
/// Non-finite or negative values count as no ash.
pub fn ash_blended(layers: &[&LayerFields], (lo, hi, w): (usize, usize, f64), p: Vec2) -> f64 {
    blend_layers(layer_ash(layers[lo], p), || layer_ash(layers[hi], p), w)
}

/// One layer's ash concentration (g/m³) at grid position `p` (world x, z), bilinear in its
/// field; non-finite or negative values count as no ash.
pub fn layer_ash(layer: &LayerFields, p: Vec2) -> f64 {
    let c = layer.ash.sample(p, Boundary::Clamp);
    if c.is_finite() && c > 0.0 { c } else { 0.0 }
}

/// Linear between a lower layer's value and an upper one's at weight `w` of the upper (the
/// blend of [`layer_blend`]); `upper` is read only when `w > 0`. [`ash_blended`]'s blend, for
/// callers that sampled the layers beforehand.
pub fn blend_layers(lower: f64, upper: impl FnOnce() -> f64, w: f64) -> f64 {
    if w > 0.0 { lower + w * (upper() - lower) } else { lower }
}

/// Ash concentration (g/m³) in the air at world `(x, altitude, z)` — "is ash falling on the
/// player?": [`ash_blended`] at the blend of [`layer_blend`]; 0 outside the layer stack.
/// Positions beyond the grid take the nearest edge cell.
pub fn ash_at(layers: &[&LayerFields], x: f32, altitude: f64, z: f32) -> f64 {
    layer_blend(layers, altitude).map_or(0.0, |b| ash_blended(layers, b, Vec2::new(x, z)))
}

/// What one ash pass did (grams).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct AshReport {
    /// Ash that settled onto the ground this step (g).
    pub deposited: f64,
    /// Ash that left the domain through the rim this step (g).
    pub outflow: f64,
    /// Largest horizontal wind × Δt / dx over the layers holding ash: above 1, ash could skip
    /// the one-cell rim and wrap around the torus within a step.
    pub max_cells_per_step: f64,
}

/// Fraction of a free air column of thickness `column` (m) that particles settling at `w_s`
/// (m/s) leave through its bottom in `dt` seconds, `1 − exp(−w_s Δt / column)`: a well-mixed
/// layer draining at its base, exact for any step and never more than the layer holds.
pub fn settled_fraction(w_s: f64, dt: f64, column: f64) -> f64 {
    if !(w_s > 0.0 && dt > 0.0 && column > 0.0) {
        return 0.0;
    }
    1.0 - (-w_s * dt / column).exp()
}

/// Settles ash for `dt` seconds at `w_s` m/s in every column: each layer, bottom first, passes
/// its settled fraction to the free layer below, or to `ground` (g/m², added) if it is the
/// lowest free layer of that column (σ of the layer below is 0, or it is layer 0). Each layer
/// drains its own content once per step, so ash crosses at most one interface per step.
/// Amounts are conserved exactly (up to rounding). Returns the grams deposited (cell area
/// `area` m²).
pub fn settle(layers: &mut [LayerFields], ground: &mut [f64], w_s: f64, dt: f64, area: f64) -> f64 {
    let mut deposited = 0.0;
    for i in 0..layers.len() {
        let (below, rest) = layers.split_at_mut(i);
        let layer = &mut rest[0];
        let h = layer.thickness;
        let sigma = layer.sigma.data();
        let ash = layer.ash.data_mut();
        let mut below = below.last_mut();
        for k in 0..ash.len() {
            let s = sigma[k] as f64;
            if ash[k] <= 0.0 || s <= 0.0 {
                continue;
            }
            let column = s * h;
            let moved = ash[k] * column * settled_fraction(w_s, dt, column); // g/m²
            if moved <= 0.0 {
                continue;
            }
            ash[k] = (ash[k] - moved / column).max(0.0);
            match below.as_ref().map(|b| (b.sigma.data()[k] as f64, b.thickness)) {
                Some((sb, hb)) if sb > 0.0 => {
                    let b = below.as_deref_mut().expect("checked above");
                    b.ash.data_mut()[k] += moved / (sb * hb);
                }
                _ => {
                    ground[k] += moved;
                    deposited += moved * area;
                }
            }
        }
    }
    deposited
}

/// Removes the ash in the outermost ring of cells of every layer (grid `n × n`, cell area
/// `area` m²) and returns the grams removed: the domain's open rim for ash.
pub fn drain_rim(layers: &mut [LayerFields], n: usize, area: f64) -> f64 {
    let mut out = 0.0;
    if n < 2 {
        return out;
    }
    for layer in layers.iter_mut() {
        let column = layer.thickness;
        let LayerFields { ash, sigma, .. } = layer;
        let (ash, sigma) = (ash.data_mut(), sigma.data());
        let mut take = |k: usize| {
            if ash[k] > 0.0 {
                out += ash[k] * sigma[k] as f64 * column * area;
                ash[k] = 0.0;
            }
        };
        for i in 0..n {
            take(i);
            take((n - 1) * n + i);
        }
        for j in 1..n - 1 {
            take(j * n);
            take(j * n + n - 1);
        }
    }
    out
}

/// Largest `|wind| Δt / dx` over the layers that hold any ash (staggered components taken
/// separately, which is what the flux advection moves per face).
pub fn max_cells_per_step(layers: &[LayerFields], dt: f64, dx: f64) -> f64 {
    layers
        .iter()
        .filter(|l| l.ash.data().iter().any(|&a| a > 0.0))
        .map(|l| {
            let m = l.u.data().iter().chain(l.v.data()).fold(0.0f32, |m, &w| m.max(w.abs()));
            m as f64 * dt / dx
        })
        .fold(0.0, f64::max)
}

/// Total ash in the air (g).
pub fn airborne(layers: &[LayerFields], dx: f64) -> f64 {
    layers
        .iter()
        .map(|l| {
            let vol = l.thickness * dx * dx;
            l.ash.data().iter().zip(l.sigma.data()).map(|(a, &s)| a * s as f64).sum::<f64>() * vol
        })
        .sum()
}

/// One ash pass after the weather's transport: settling, then the open rim.
pub fn step_ash(
    layers: &mut [LayerFields],
    ground: &mut [f64],
    n: usize,
    dx: f64,
    w_s: f64,
    open_rim: bool,
    dt: f64,
) -> AshReport {
    let area = dx * dx;
    let max_cells_per_step = max_cells_per_step(layers, dt, dx);
    let deposited = settle(layers, ground, w_s, dt, area);
    let outflow = if open_rim { drain_rim(layers, n, area) } else { 0.0 };
    AshReport { deposited, outflow, max_cells_per_step }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fields::{GridSpec, layer_geometry};

    fn layers(n: usize, alts: &[f64]) -> Vec<LayerFields> {
        let g = GridSpec::new(n, 100.0).unwrap();
        let geo = layer_geometry(alts).unwrap();
        alts.iter().zip(geo).map(|(&a, (b, h))| LayerFields::new(g, a, b, h, 280.0)).collect()
    }

    #[test]
    fn ash_at_a_point_blends_layers_and_maps_world_z_to_grid_y() {
        // Layers centred at 500, 1,500 and 3,000 m on a 16² grid of 100 m cells.
        let mut ls = layers(16, &[500.0, 1500.0, 3000.0]);
        let g = GridSpec::new(16, 100.0).unwrap();
        // Ash only in layer 1, only where world z > 0 (grid y), 4 g/m³; a bad cell elsewhere.
        for k in 0..g.cells() {
            ls[1].ash.data_mut()[k] = if g.centre(k).1 > 0.0 { 4.0 } else { 0.0 };
        }
        ls[2].ash.data_mut()[0] = f64::NAN;
        let refs: Vec<&LayerFields> = ls.iter().collect();
        // Halfway between the centres of layers 0 (no ash) and 1: half of layer 1's value.
        assert!((ash_at(&refs, 0.0, 1000.0, 500.0) - 2.0).abs() < 1e-12);
        assert!((ash_at(&refs, 0.0, 1500.0, 500.0) - 4.0).abs() < 1e-12);
        // A quarter of the way from layer 1's centre to layer 2's.
        assert!((ash_at(&refs, 0.0, 1875.0, 500.0) - 3.0).abs() < 1e-12);
        // The other side of z = 0 (grid y < 0) holds none, nor does the air above the stack.
        assert_eq!(ash_at(&refs, 0.0, 1500.0, -500.0), 0.0);
        assert_eq!(ash_at(&refs, 0.0, 1e5, 500.0), 0.0);
        // The NaN cell of layer 2 (grid corner −x, −y) counts as no ash.
        assert_eq!(ash_at(&refs, -750.0, 3000.0, -750.0), 0.0);
    }

    #[test]
    fn settling_matches_the_exponential_drain_of_a_layer() {
        // One loaded top layer over two empty ones: after t seconds the top layer holds
        // exp(−w t / h) of its ash whatever the step (exact solution of dA/dt = −(w/h) A).
        let w = 0.5;
        for dt in [1.0, 30.0] {
            let mut l = layers(16, &[500.0, 1500.0, 2500.0]);
            l[2].ash.data_mut()[40] = 2.0;
            let mut ground = vec![0.0; 256];
            let steps = (600.0 / dt) as usize;
            for _ in 0..steps {
                settle(&mut l, &mut ground, w, dt, 1e4);
            }
            let want = 2.0 * (-w * 600.0 / l[2].thickness).exp();
            assert!((l[2].ash.data()[40] - want).abs() < 1e-12, "dt {dt}: {} vs {want}", l[2].ash.data()[40]);
        }
    }

    #[test]
    fn settling_and_the_rim_conserve_ash_and_terrain_catches_it_higher_up() {
        let n = 16;
        let mut l = layers(n, &[500.0, 1500.0, 2500.0]);
        // A mountain closes layer 0 at cell 100: its ash lands on the ground from layer 1.
        l[0].sigma.data_mut()[100] = 0.0;
        l[1].sigma.data_mut()[100] = 0.4;
        for (i, layer) in l.iter_mut().enumerate() {
            for (k, a) in layer.ash.data_mut().iter_mut().enumerate() {
                *a = ((k * 7 + i * 3) % 5) as f64 * 0.1;
            }
        }
        l[0].ash.data_mut()[100] = 0.0;
        let area = 1e4;
        let before = airborne(&l, 100.0);
        let mut ground = vec![0.0; n * n];
        let mut gone = 0.0;
        for _ in 0..50 {
            let r = step_ash(&mut l, &mut ground, n, 100.0, 2.0, true, 20.0);
            gone += r.outflow;
        }
        let landed: f64 = ground.iter().sum::<f64>() * area;
        let after = airborne(&l, 100.0);
        assert!(((after + landed + gone) - before).abs() / before < 1e-12);
        assert!(gone > 0.0 && landed > 0.0);
        assert!(ground[100] > 0.0, "ash lands on the mountain from layer 1");
        // The rim is empty in every layer.
        assert!(l.iter().all(|x| (0..n).all(|i| x.ash.data()[i] == 0.0 && x.ash.data()[i * n] == 0.0)));
    }

    #[test]
    fn no_settling_without_speed_or_time() {
        assert_eq!(settled_fraction(0.0, 10.0, 100.0), 0.0);
        assert_eq!(settled_fraction(1.0, f64::NAN, 100.0), 0.0);
        assert!((settled_fraction(1.0, 1.0, 1.0) - (1.0 - (-1.0f64).exp())).abs() < 1e-15);
    }
}
