//! Terrain–atmosphere interaction (thesis §4.2.5): the free fraction σ of each layer (4.8),
//! terrain self-shadowing and cloud shading, irradiation (4.9), grey-body emission (4.10, T⁴
//! per the erratum), heat (4.11) and water (4.12) exchange with the lowest layer with air, all
//! with a ground heat capacity per m² (docs/physics/atmosphere.md §5.3 erratum: C_p × density × active depth).
//!
//! σ has one definition, used for the amounts (free volume), the face apertures of transport
//! and projection, the damping and ℓ(p): the free fraction of the layer's slab
//! `[bottom, bottom + thickness]` above the ground. The ground temperature is integrated
//! without a clamp: radiation and sensible heat are linearised about the ground temperature
//! (Newton) and the linear ground–air system is integrated exactly over the step, then
//! re-linearised once about the result (docs/physics/atmosphere.md §5).

use volcano_core::parallel;
use volcano_core::{LandCover, Terrain};

use super::fields::{AtmosphereState, GridSpec, Ground, LayerFields, cover_props};
use super::params::AtmosphereParams;
use super::sun::{SunPosition, air_mass};
use super::thermo::{CP_AIR, L_V_PER_G, air_density, saturation_floor, saturation_humidity};

/// Stefan–Boltzmann constant (W/(m²·K⁴)).
pub const STEFAN_BOLTZMANN: f64 = 5.670_374e-8;
/// Free fraction σ_i(p) of layer i's slab `[bottom, bottom + thickness]` above terrain of
/// height `terrain`: `σ_i = clamp((bottom + thickness − Θ_T) / thickness, 0, 1)`. This is
/// thesis eq. (4.8), `σ_i = 1 − min(1, max(0, (Θ_T − Θ_i) / ΔΘ_i))`, with Θ_i read as the
/// layer's lower boundary: the printed form with Θ_i the layer's (centre) altitude makes σ the
/// free fraction of a slab that does not exist (a layer over ground at 1,100 m with its slab
/// at 0–800 m and centre at 400 m keeps σ = 0.125) and disagrees with the volume σ scales
/// (docs/physics/atmosphere.md §5). σ is the layer's damping (4.8), its free volume for the
/// amounts, the source of the face apertures, and picks ℓ(p).
pub fn free_fraction(terrain: f64, bottom: f64, thickness: f64) -> f32 {
    ((bottom + thickness - terrain) / thickness).clamp(0.0, 1.0) as f32
}

/// Fills every layer's σ ([`free_fraction`]) from the terrain, and the ground's `lowest`
/// index ℓ(p): the lowest layer with air (σ > 0), i.e. the layer whose slab contains the
/// ground (the thesis' `argmin_{Θ_i > Θ_T} i` with Θ_i the layer's top). Water and heat in
/// cells that become solid (σ = 0) are cleared by the caller's initialisation, not here.
pub fn update_masks(state: &mut AtmosphereState) {
    let heights = state.ground.height.data();
    for layer in state.layers.iter_mut() {
        let (b, h) = (layer.bottom, layer.thickness);
        for (s, &t) in layer.sigma.data_mut().iter_mut().zip(heights) {
            *s = free_fraction(t as f64, b, h);
        }
    }
    let layers = &state.layers;
    for (k, l) in state.ground.lowest.iter_mut().enumerate() {
        *l = layers.iter().position(|layer| layer.sigma.data()[k] > 0.0).map_or(u8::MAX, |i| i as u8);
    }
}

/// Samples a foundation [`Terrain`] at the atmosphere's cell centres: heights bilinear, land
/// cover nearest, both clamped at the terrain's edges (the atmosphere may be larger than the
/// terrain). Cells below the terrain's sea level are water at sea level.
pub fn sample_terrain(terrain: &Terrain, grid: GridSpec) -> (Vec<f32>, Vec<LandCover>) {
    let sea = terrain.sea_level();
    (0..grid.cells())
        .map(|k| {
            let (x, y) = grid.centre(k);
            let h = terrain.height_at(x as f32, y as f32);
            if h < sea { (sea, LandCover::Water) } else { (h, terrain.cover_at(x as f32, y as f32)) }
        })
        .unzip()
}

/// Heat capacity of the ground per m² (J/(m²·K)): specific heat × density × active depth.
pub fn heat_capacity_per_m2(cover: LandCover, params: &AtmosphereParams) -> f64 {
    let p = cover_props(cover);
    let depth = if cover == LandCover::Water { params.water_depth } else { params.soil_depth };
    p.heat_capacity as f64 * p.density as f64 * depth
}

/// Fraction of direct sunlight at each cell: 0 where the terrain (toroidal) hides the sun,
/// found by marching toward the sun until the ray is above the highest terrain. Rows run in
/// parallel; each cell's answer depends only on the heights.
pub fn sunlit_map(heights: &[f32], n: usize, dx: f64, sun: &SunPosition, out: &mut [f32]) {
    if sun.elevation <= 0.0 {
        out.fill(0.0);
        return;
    }
    let top = heights.iter().cloned().fold(f32::NEG_INFINITY, f32::max) as f64;
    let [e, no, up] = sun.direction;
    let horiz = (e * e + no * no).sqrt();
    if horiz < 1e-9 {
        out.fill(1.0);
        return;
    }
    let (sx, sy) = (e / horiz, no / horiz);
    let rise = up / horiz * dx; // metres gained per cell travelled
    let mask = n as i64 - 1;
    parallel::for_each_row(&mut *out, n, |j, row| {
        for (i, o) in row.iter_mut().enumerate() {
            let h0 = heights[j * n + i] as f64;
            let steps = (((top - h0) / rise).ceil().max(0.0) as usize).min(4 * n);
            let mut lit = 1.0;
            for s in 1..=steps {
                let x = (i as f64 + sx * s as f64).round() as i64 & mask;
                let y = (j as f64 + sy * s as f64).round() as i64 & mask;
                if heights[(y as usize) * n + x as usize] as f64 > h0 + rise * s as f64 {
                    lit = 0.0;
                    break;
                }
            }
            *o = lit;
        }
    });
}

/// Energy budget of the ground for one step, per cell (W/m² terms).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GroundFluxes {
    /// Absorbed sunlight, eq. (4.9) numerator over Δt.
    pub absorbed: f64,
    /// Grey-body emission `ε σ T⁴`, eq. (4.10) with the erratum.
    pub emitted: f64,
    /// Downwelling long-wave from the sky absorbed by the ground.
    pub back_radiation: f64,
    /// Sensible heat to the lowest free layer, eq. (4.11).
    pub sensible: f64,
}

/// Absorbed solar flux (W/m²), eq. (4.9) before dividing by the heat capacity:
/// `F_s (1 − B) cos θ / D(θ)`, with θ the angle between the surface normal and the sun.
pub fn absorbed_flux(solar_constant: f64, albedo: f64, cos_incidence: f64, cos_zenith: f64) -> f64 {
    absorbed_flux_through(solar_constant, albedo, cos_incidence, cos_zenith, air_mass(cos_zenith))
}

/// [`absorbed_flux`] with the sun's air mass `D(θ)` given (the same for every cell of a step).
fn absorbed_flux_through(
    solar_constant: f64,
    albedo: f64,
    cos_incidence: f64,
    cos_zenith: f64,
    air_mass: f64,
) -> f64 {
    if cos_zenith <= 0.0 || cos_incidence <= 0.0 {
        return 0.0;
    }
    solar_constant * (1.0 - albedo) * cos_incidence / air_mass
}

/// Fraction of sunlight a cloud column of liquid water path `lwp` (g/m²) lets through to the
/// ground (the thesis' cloud shadowing): optical depth `τ = 0.15 · LWP` (effective droplet
/// radius 10 µm, `τ = 3 LWP / (2 ρ_w r_e)`) and the two-stream transmission of a
/// non-absorbing cloud, `1 / (1 + 0.75 τ (1 − g))` with asymmetry g = 0.85. Vertical column
/// (the slant path is ignored).
pub fn cloud_transmission(lwp: f64) -> f64 {
    if lwp <= 0.0 {
        // τ = 0: all of it (what the formula gives, without its division).
        return 1.0;
    }
    let tau = 0.15 * lwp.max(0.0);
    1.0 / (1.0 + 0.75 * tau * (1.0 - 0.85))
}

/// Grey-body emission (W/m²), eq. (4.10) with the erratum of docs/physics/atmosphere.md §5.3
/// (T⁴, not T⁸): `ε σ_B T⁴`.
pub fn grey_body(emissivity: f64, t: f64) -> f64 {
    emissivity * STEFAN_BOLTZMANN * t.powi(4)
}

/// Ground and air temperatures after `dt` s of radiation and sensible heat, thesis eqs.
/// (4.9)–(4.11): `C_g dT_g/dt = gain − ε σ_B T_g⁴ − κ (T_g − T_a)` and
/// `C_a dT_a/dt = κ (T_g − T_a)`, with `gain` the absorbed sunlight and sky radiation (W/m²,
/// held over the step), `C_g`/`C_a` the ground's and the air column's heat capacities per m²
/// (`air_cap = ∞` holds the air fixed). The emission is linearised about the ground
/// temperature (Newton) and the linear system integrated exactly over the step (its matrix
/// exponential), then linearised again about that first result and integrated again from the
/// start: unconditionally stable, no overshoot of the common temperature, and independent of
/// the step to well under 1 K for a 20-minute soil time constant and 1 h steps. Replaces the
/// explicit step and its 150–400 K clamp (docs/physics/atmosphere.md §5).
#[allow(clippy::too_many_arguments)]
pub fn ground_heat_step(
    tg: f64,
    ta: f64,
    gain: f64,
    emissivity: f64,
    kappa: f64,
    ground_cap: f64,
    air_cap: f64,
    dt: f64,
) -> (f64, f64) {
    let sys = HeatSystem::new(kappa, ground_cap, air_cap);
    let (t1, _) = sys.linear_step(tg, ta, tg, gain, emissivity, dt);
    let t_lin = if t1.is_finite() && t1 > 0.0 { t1 } else { tg };
    sys.linear_step(tg, ta, t_lin, gain, emissivity, dt)
}

/// The ground–air system of [`ground_heat_step`] without the emission: the coupling κ, the
/// heat capacities, and the parts of its matrix that do not depend on the linearisation
/// (computed once for both integrations).
struct HeatSystem {
    kappa: f64,
    cg: f64,
    ca: f64,
    /// `κ / C_g`.
    a12: f64,
    /// `κ / C_a` (and `a22 = −a21`: IEEE division is symmetric in sign).
    a21: f64,
}

impl HeatSystem {
    fn new(kappa: f64, cg: f64, ca: f64) -> Self {
        Self { kappa, cg, ca, a12: kappa / cg, a21: kappa / ca }
    }

    /// One exact integration of the ground–air system with the emission linearised about
    /// `t_lin`: `ε σ_B T⁴ ≈ R + G (T − t_lin)`, `R = ε σ_B t_lin⁴`, `G = 4R / t_lin`.
    fn linear_step(&self, tg: f64, ta: f64, t_lin: f64, gain: f64, emissivity: f64, dt: f64) -> (f64, f64) {
        let Self { kappa, cg, ca, a12, a21 } = *self;
        let r = grey_body(emissivity, t_lin);
        let g = 4.0 * r / t_lin;
        // C_g T_g' = f − G T_g − κ (T_g − T_a).
        let f = gain - r + g * t_lin;
        if !(kappa > 0.0 && ca.is_finite() && ca > 0.0) {
            // The air is held (or not coupled): one mode.
            let k = g + kappa.max(0.0);
            if k <= 0.0 {
                return (tg + (gain - r) * dt / cg, ta);
            }
            let eq = (f + kappa.max(0.0) * ta) / k;
            return (eq + (tg - eq) * (-k * dt / cg).exp(), ta);
        }
        if g <= 0.0 {
            // No emission: heat only moves between ground and air (their mean is kept).
            let eq = (cg * tg + ca * ta + gain * dt) / (cg + ca);
            let decay = (-kappa * (1.0 / cg + 1.0 / ca) * dt).exp();
            let d = (tg - ta) * decay;
            return (eq + d * ca / (cg + ca), eq - d * cg / (cg + ca));
        }
        // x' = A (x − x*), x* = (f/G, f/G): both at the radiative equilibrium.
        let eq = f / g;
        let (a11, a22) = (-(g + kappa) / cg, -a21);
        let s = 0.5 * (a11 + a22);
        let q = (0.25 * (a11 - a22).powi(2) + a12 * a21).sqrt();
        let (e1, e2) = (((s + q) * dt).exp(), ((s - q) * dt).exp());
        // exp(A t) = e^{st} [cosh(qt) I + sinh(qt)/q (A − s I)].
        let ch = 0.5 * (e1 + e2);
        let sh = if q * dt < 1e-4 {
            (s * dt).exp() * dt * (1.0 + (q * dt).powi(2) / 6.0)
        } else {
            (e1 - e2) / (2.0 * q)
        };
        let (y1, y2) = (tg - eq, ta - eq);
        (eq + (ch + sh * (a11 - s)) * y1 + sh * a12 * y2, eq + sh * a21 * y1 + (ch + sh * (a22 - s)) * y2)
    }
}

/// One step of ground physics under `sun`: radiation (4.9, 4.10 and the sky's back
/// radiation) and sensible heat to the lowest layer with air (4.11), integrated by
/// [`ground_heat_step`]; evaporation or dew (4.12) with the ground's latent heat,
/// linearised-implicit in the ground temperature (the flux is evaluated at the step's end
/// temperature through the slope of the saturation humidity, so evaporative cooling cannot
/// run past the point where the flux vanishes). Returns the grams of water moved from ground
/// to air (negative for dew).
pub fn ground_exchange(
    state: &mut AtmosphereState,
    params: &AtmosphereParams,
    sun: &SunPosition,
    dt: f64,
) -> f64 {
    let n = state.grid.n;
    let dx = state.grid.dx;
    let sun_key = [sun.direction[0] as f32, sun.direction[1] as f32, sun.direction[2] as f32];
    let stale = match state.ground.sunlit_for {
        None => true,
        Some(old) => old.iter().zip(&sun_key).any(|(a, b)| (a - b).abs() > 0.01),
    };
    if stale {
        let heights = state.ground.height.data().to_vec();
        sunlit_map(&heights, n, dx, sun, state.ground.sunlit.data_mut());
        state.ground.sunlit_for = Some(sun_key);
    }
    let cos_zenith = sun.direction[2];
    let sun_air_mass = air_mass(cos_zenith);
    let mask = n - 1;
    // Each cell reads and writes only its own cell of the ground and of its lowest free layer
    // (and reads the heights and every layer's condensed water and σ, which nothing here
    // writes), so the cells are updated in place, bands of rows in parallel.
    let mut columns = Vec::with_capacity(state.layers.len());
    let mut air: Vec<AirRows> = Vec::with_capacity(state.layers.len());
    for l in state.layers.iter_mut() {
        let LayerFields { t, h, w, sigma, thickness, pi, .. } = l;
        // Evaporation's relaxation over a full free column, the same for every open cell.
        let open = 1.0 - (-params.ground_evaporation_velocity * dt / *thickness).exp();
        columns.push(Column { w: w.data(), sigma: sigma.data(), thickness: *thickness, pi: *pi, open });
        air.push((t.data_mut(), h.data_mut()));
    }
    let Ground { height, cover, t: ground_t, water, sunlit, lowest, .. } = &mut state.ground;
    let (heights, cover, sunlit, lowest) = (height.data(), cover.data(), sunlit.data(), &lowest[..]);
    let band = parallel::BAND_ROWS * n;
    let mut items: Vec<GroundBand> = ground_t
        .data_mut()
        .chunks_mut(band)
        .zip(water.data_mut().chunks_mut(band))
        .map(|(tg, wg)| (tg, wg, Vec::with_capacity(air.len())))
        .collect();
    for (t, h) in air {
        for (item, rows) in items.iter_mut().zip(t.chunks_mut(band).zip(h.chunks_mut(band))) {
            item.2.push(rows);
        }
    }
    let columns = &columns[..];
    // Grams moved from ground to air per m² × area, per band in cell order.
    let moved: Vec<Vec<f64>> = parallel::par_map(items, |b, (tg_rows, water_rows, mut air_rows)| {
        let mut moved = Vec::new();
        for (r, (tg_cell, ground_water)) in tg_rows.iter_mut().zip(water_rows.iter_mut()).enumerate() {
            let k = b * band + r;
            let li = lowest[k];
            if li == u8::MAX {
                continue;
            }
            let layer = &columns[li as usize];
            let (t_rows, h_rows) = &mut air_rows[li as usize];
            let cover = cover[k];
            let props = cover_props(cover);
            let cap = heat_capacity_per_m2(cover, params);
            let (i, j) = (k % n, k / n);
            // Surface normal from central differences on the torus.
            let (east, west) = (heights[j * n + ((i + 1) & mask)], heights[j * n + ((i + n - 1) & mask)]);
            let (north, south) = (heights[((j + 1) & mask) * n + i], heights[((j + n - 1) & mask) * n + i]);
            let cos_inc = if east == west && north == south {
                // No slope (the sea, a plain): the normal is vertical, cos θ the sun's height
                // as the general formula gives it, bit for bit (≤ 0, no sunlight, either way
                // when the sun is on the horizon).
                sun.direction[2]
            } else {
                let hx = (east - west) as f64 / (2.0 * dx);
                let hy = (north - south) as f64 / (2.0 * dx);
                let norm = (hx * hx + hy * hy + 1.0).sqrt();
                (-hx * sun.direction[0] - hy * sun.direction[1] + sun.direction[2]) / norm
            };
            let lit = sunlit[k] as f64;
            let tg = *tg_cell as f64;
            let ta = t_rows[r] as f64;
            let sigma = layer.sigma[k] as f64;
            let air_cap = air_density(layer.pi, ta) * CP_AIR * sigma * layer.thickness;
            // Cloud shading: the column's condensed water above the ground.
            let lwp: f64 = columns.iter().map(|l| l.w[k] * l.sigma[k] as f64 * l.thickness).sum();
            let absorbed = lit
                * cloud_transmission(lwp)
                * absorbed_flux_through(
                    params.solar_constant,
                    props.albedo as f64,
                    cos_inc,
                    cos_zenith,
                    sun_air_mass,
                );
            let back = props.emissivity as f64 * grey_body(params.sky_emissivity, ta);
            let (tg_heat, ta_new) = ground_heat_step(
                tg,
                ta,
                absorbed + back,
                props.emissivity as f64,
                params.sensible_heat_coefficient,
                cap,
                air_cap,
                dt,
            );
            // Water exchange (4.12): toward saturation at the ground temperature.
            let vol = sigma * layer.thickness;
            let hum = h_rows[r];
            let target = saturation_humidity(tg_heat, layer.pi);
            // g/m² this step (+ = evaporation), at most what relaxes the air to saturation.
            let relax = if sigma == 1.0 {
                layer.open
            } else {
                1.0 - (-params.ground_evaporation_velocity * dt / vol).exp()
            };
            let (warmer, colder) =
                (saturation_humidity(tg_heat + 0.5, layer.pi), saturation_humidity(tg_heat - 0.5, layer.pi));
            let slope = (warmer - colder).max(0.0);
            // Latent heat taken from (evaporation) or given to (dew) the ground, eq. (4.12),
            // with the flux at the end temperature: g(T₁) = g(T) + relax·vol·H'·(T₁ − T).
            let implicit = 1.0 + relax * vol * slope * L_V_PER_G / cap;
            let mut grams = relax * (target - hum) * vol / implicit;
            let linear_end = tg_heat - grams * L_V_PER_G / cap;
            // Evaporating, the linearised end lies in [T_heat − 0.5, T_heat] (cooler): if the
            // floor of the saturation humidity there is above the air's humidity, the flux
            // keeps its sign at the end and the test below is false without evaluating it
            // (bit for bit the same decision). Likewise when the flux is zero.
            let kept = if target > hum {
                linear_end >= tg_heat - 0.5
                    && linear_end <= tg_heat
                    && saturation_floor(colder.min(target)) > hum
            } else {
                target == hum
            };
            if !kept && (saturation_humidity(linear_end, layer.pi) - hum) * (target - hum) < 0.0 {
                // The linearisation overshot the temperature where the flux vanishes (a
                // long step over a thin soil: dew heated it hundreds of kelvin, or
                // evaporation cooled it below absolute zero, the next step). Solve the
                // implicit balance T = T_heat − relax·vol·(H_sat(T) − H)·L/c exactly instead,
                // by bisection between the two ends (it is monotone in T).
                let balance = |t: f64| {
                    t - tg_heat + relax * vol * (saturation_humidity(t, layer.pi) - hum) * L_V_PER_G / cap
                };
                let (mut lo, mut hi) =
                    if linear_end < tg_heat { (linear_end, tg_heat) } else { (tg_heat, linear_end) };
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if balance(mid) > 0.0 { hi = mid } else { lo = mid }
                }
                grams = (tg_heat - 0.5 * (lo + hi)) * cap / L_V_PER_G;
            }
            let grams = grams.clamp(-hum * vol, *ground_water);
            let tg_new = tg_heat - grams * L_V_PER_G / cap;
            t_rows[r] = ta_new as f32;
            h_rows[r] = (hum + grams / vol).max(0.0);
            *tg_cell = tg_new as f32;
            *ground_water -= grams;
            moved.push(grams * dx * dx);
        }
        moved
    });
    moved.into_iter().flatten().fold(0.0, |sum, g| sum + g)
}

/// A layer's temperature and humidity (rows of one band, or the whole grid).
type AirRows<'a> = (&'a mut [f32], &'a mut [f64]);

/// One band of the ground exchange: the ground's temperature and water, every layer's air.
type GroundBand<'a> = (&'a mut [f32], &'a mut [f64], Vec<AirRows<'a>>);

/// What the ground exchange reads of one layer.
struct Column<'a> {
    w: &'a [f64],
    sigma: &'a [f32],
    thickness: f64,
    pi: f64,
    /// `1 − exp(−v_e Δt / h)`: the evaporation relaxation of a cell with σ = 1.
    open: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::sun::sun_position;

    #[test]
    fn free_fraction_is_the_slab_share_above_the_ground() {
        // Slab 100–300 m.
        assert_eq!(free_fraction(0.0, 100.0, 200.0), 1.0);
        assert_eq!(free_fraction(100.0, 100.0, 200.0), 1.0);
        assert_eq!(free_fraction(150.0, 100.0, 200.0), 0.75);
        assert_eq!(free_fraction(200.0, 100.0, 200.0), 0.5);
        assert_eq!(free_fraction(300.0, 100.0, 200.0), 0.0);
        assert_eq!(free_fraction(900.0, 100.0, 200.0), 0.0);
    }

    #[test]
    fn grey_body_is_t4_and_absorption_follows_cosines() {
        // 288 K black body: 390 W/m² (T⁸ would be 1.5e11).
        assert!((grey_body(1.0, 288.0) - 390.08).abs() < 0.1);
        assert!((grey_body(0.9, 300.0) / grey_body(0.9, 150.0) - 16.0).abs() < 1e-9);
        let noon = absorbed_flux(1000.0, 0.2, 1.0, 1.0);
        assert!((noon - 800.0).abs() < 1e-9);
        assert!(absorbed_flux(1000.0, 0.2, 0.5, 0.5) < 0.26 * noon);
        assert_eq!(absorbed_flux(1000.0, 0.2, 0.5, -0.1), 0.0);
    }

    #[test]
    fn clouds_shade_the_ground() {
        assert_eq!(cloud_transmission(0.0), 1.0);
        // A 1 km stratocumulus with 0.2 g/m³ (LWP 200 g/m², τ 30) lets ≈ 23 % through.
        let t = cloud_transmission(200.0);
        assert!((t - 1.0 / (1.0 + 0.75 * 30.0 * 0.15)).abs() < 1e-12 && t < 0.25 && t > 0.2);
        assert!(cloud_transmission(1000.0) < cloud_transmission(100.0));
    }

    #[test]
    fn a_cloud_column_heats_its_ground_less_at_noon() {
        let sc = crate::model::scenario::WeatherScenario::builtin("convection").unwrap();
        let mut st = sc.build(Some(16)).unwrap();
        st.layers[1].w.data_mut()[5] = 0.5;
        let t0 = st.ground.t.data().to_vec();
        let sun = sun_position(172.0, 12.0, 43.0);
        ground_exchange(&mut st, &AtmosphereParams::default(), &sun, 600.0);
        let (under, clear) = (st.ground.t.data()[5] - t0[5], st.ground.t.data()[6] - t0[6]);
        assert!(clear > 0.5 && under < 0.3 * clear, "cloudy {under} K vs clear {clear} K");
    }

    #[test]
    fn a_ridge_shadows_the_valley_behind_it_at_low_sun() {
        let n = 32;
        let mut h = vec![0.0f32; n * n];
        for j in 0..n {
            h[j * n + 16] = 500.0; // north–south ridge at i = 16
        }
        // Evening sun in the west: cells just east of the ridge are in its shadow.
        let sun = sun_position(81.0, 17.5, 45.0);
        assert!(sun.direction[0] < 0.0 && sun.elevation > 0.0);
        let mut lit = vec![0.0; n * n];
        sunlit_map(&h, n, 1000.0, &sun, &mut lit);
        assert_eq!(lit[5 * n + 17], 0.0);
        assert_eq!(lit[5 * n + 18], 0.0);
        assert_eq!(lit[5 * n + 14], 1.0, "west of the ridge faces the sun");
        assert_eq!(lit[5 * n + 16], 1.0, "the ridge top is lit");
    }

    #[test]
    fn foundation_terrain_is_sampled_at_cell_centres() {
        let t = volcano_core::StratovolcanoParams { resolution: 129, cell: 100.0, ..Default::default() }
            .generate()
            .unwrap();
        let g = GridSpec::new(64, 400.0).unwrap();
        let (h, c) = sample_terrain(&t, g);
        let centre = 32 * 64 + 32; // cell centre at (200, 200) m, on the cone
        assert!((h[centre] - t.height_at(200.0, 200.0)).abs() < 1e-3);
        assert!(h[centre] > 1500.0, "summit region {}", h[centre]);
        assert_eq!(c.len(), 64 * 64);
        assert!(h.iter().all(|x| x.is_finite() && *x >= t.sea_level()));
    }

    /// The ground model alone, air held: 1 × 1 h and 60 × 1 min agree within 1 K on 1 cm of
    /// soil (a 10-minute time constant) by day and by night, and a coupled air column
    /// follows the ground without heat being created.
    #[test]
    fn ground_heat_step_is_step_independent_and_does_not_overshoot() {
        let cap = 800.0 * 1600.0 * 0.01;
        for gain in [1000.0, 250.0, 0.0] {
            let run = |steps: usize, dt: f64| {
                (0..steps).fold(290.0, |t, _| {
                    ground_heat_step(t, 285.0, gain, 0.91, 15.0, cap, f64::INFINITY, dt).0
                })
            };
            let (one, sixty, exact) = (run(1, 3600.0), run(60, 60.0), run(36_000, 0.1));
            assert!(
                (one - sixty).abs() < 1.0 && (sixty - exact).abs() < 0.2,
                "gain {gain}: {one} {sixty} {exact}"
            );
            assert!(one.is_finite() && one > 150.0);
        }
        // A clear night without sky radiation, 10 m of air: the radiating ground cools and
        // the air it touches follows it down, staying the warmer of the two.
        let (tg, ta) = ground_heat_step(300.0, 280.0, 0.0, 0.91, 15.0, cap, 12_000.0, 3600.0);
        assert!(tg < 280.0 && ta < 280.0 && ta > tg && tg > 200.0, "{tg} {ta}");
        // No radiation: energy is conserved between ground and air.
        let (tg3, ta3) = ground_heat_step(300.0, 280.0, 0.0, 0.0, 15.0, cap, 12_000.0, 600.0);
        assert!(((tg3 - 300.0) * cap + (ta3 - 280.0) * 12_000.0).abs() < 1e-6);
    }

    #[test]
    fn land_heat_capacity_is_far_below_the_sea() {
        let p = AtmosphereParams::default();
        let land = heat_capacity_per_m2(LandCover::Ground, &p);
        let sea = heat_capacity_per_m2(LandCover::Water, &p);
        assert!((land - 800.0 * 1600.0 * 0.3).abs() < 1e-6);
        assert!(sea > 40.0 * land);
    }
}
