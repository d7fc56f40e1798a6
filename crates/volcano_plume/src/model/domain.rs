//! The plume domain's step (docs/ARCHITECTURE.md §2.1): everything one volcano's column does
//! in one plume step, on plain data, called by `PlumePlugin`, the tests and the benches alike.
//!
//! [`step`] runs, in this order:
//!
//! 1. **Emission** (§3.4.1): a slice at the vent every `PlumeParams::emission_interval`
//!    (`r₀/(2v₀)` for the thesis' slice), at most [`MAX_EMISSIONS_PER_STEP`] per step; what is
//!    due beyond that is carried to the next steps as a backlog, never dropped. Each new slice
//!    gets its ring of s1 spheres (§3.5.1) from its own random stream ([`ring`]).
//! 2. **Live-slice cap** (bookkeeping, not physics; the rule is `crate::caps`'): beyond
//!    [`StepCaps::max_live_slices`], secondary columns (lightest first), then the oldest
//!    slices are retired and their ash released.
//! 3. **Slices**, in the state's order, unless the eruption is frozen: eqs 3.3–3.9
//!    ([`Slice::step`](crate::model::slice::Slice::step)) in the coupled air or the
//!    parameters' own, the ash σ_col sheds (eq 3.9) kept in [`LiveSlice::ash_pending`], the
//!    ring's spin `Ω = v / r_s` with the mean sphere size `r_s = r/2` (§3.5.1),
//!    neutral-buoyancy events. A slice whose state is no longer
//!    finite is removed and its ash booked as lost.
//! 4. **Finishing**: a slice at its apex gives its ring's spheres to the umbrella (§3.5.2),
//!    sharing its solid mass among them; a collapsed slice (§3.6) is handed to the pyroclastic
//!    flows with its ash.
//! 5. **Umbrella** (§3.5.2): every sphere, those just detached included, spreads
//!    ([`UmbrellaSphere::step`]), drifts with the wind at its altitude, lets its ash fall out
//!    with the time constant `umbrella_fallout_s` (beyond the thesis, docs/ARCHITECTURE.md
//!    §1.4) and expires after `umbrella_lifetime`, releasing the ash it still holds.
//! 6. **Umbrella cap** (bookkeeping): beyond [`StepCaps::max_umbrella_spheres`], the oldest
//!    spheres expire early.
//!
//! **Order and positions.** The state's lists keep their order: what is removed leaves the
//! others in place, what is new is appended. Sums over slices and spheres (the ash books) are
//! taken in that order, so a caller that gathers them in a stable order gets the same bits
//! every run. The report numbers slices by their position after emission (the slices the
//! state held at the start of the step, then the emitted ones), ring spheres by their position
//! in [`PlumeState::rings`] after emission, and umbrella spheres by their position before the
//! umbrella phase (those at the start of the step, then the ones detached in it), so a caller
//! keeping a parallel list of its own (the plugin: entities) can follow every change
//! ([`PlumeReport::slice_fates`], [`PlumeReport::sphere_fates`]).
//!
//! A caller that keeps the rings itself (the plugin: on the s1 entities) passes a
//! [`RingSource`]; the step then asks it, once, for the rings of the slices that leave the
//! column instead of holding every ring.
//!
//! Slices are identified by their emission index ([`LiveSlice::index`], unique within a
//! volcano: the vent's slices and the secondary columns share one counter), ring and umbrella
//! spheres by their id `(slice index << 8) | k`.

mod inputs;
mod report;
mod state;

use std::collections::HashMap;

pub use inputs::{Emitter, PlumeAir, PlumeInputs, RingSource, StepCaps};
pub use report::{
    Emitted, Finished, NeutralEvent, Outcome, PlumeReport, RemovedSlice, RemovedSphere, SliceFate, SphereFate,
};
pub use state::{
    AshBooks, CloudSphere, Emission, LiveSlice, MAX_EMISSIONS_PER_STEP, PlumeState, RingSphere, ring,
};

use super::params::Dynamics;
use super::slice::{Phase, SliceEnv};
use super::umbrella::{Spread, UmbrellaSphere, buoyancy_frequency, gravity_current_coefficient};

/// Advances one volcano's plume by one step of `inputs.dt` seconds (see the module docs).
pub fn step(state: &mut PlumeState, inputs: &PlumeInputs) -> PlumeReport {
    let mut report = PlumeReport::default();
    let held = state.slices.len();
    emit(state, inputs, &mut report);
    let n = state.slices.len();
    let mut gone = vec![None; n];
    cap_slices(state, inputs.caps.max_live_slices, &mut gone, &mut report);
    let finishing = if inputs.frozen {
        Vec::new()
    } else {
        report.stepped = true;
        step_slices(state, inputs, &mut gone, &mut report)
    };
    if let Some(RingSource(source)) = inputs.rings {
        // The rings of the held slices that leave the column, in one request.
        let leaving =
            report.retired.iter().chain(&report.non_finite).map(|r| r.at).chain(finishing.iter().copied());
        let want: Vec<u64> = leaving.filter(|&k| k < held).map(|k| state.slices[k].index).collect();
        if !want.is_empty() {
            state.rings.extend(source(&want));
        }
    }
    for k in finishing {
        finish(state, inputs, k, &mut gone, &mut report);
    }
    ring_positions(&state.rings, &mut report.retired);
    ring_positions(&state.rings, &mut report.non_finite);
    let mut gone_spheres = vec![None; state.umbrella.len()];
    let umbrella_dt = inputs.umbrella_dt;
    if umbrella_dt.is_finite() && umbrella_dt > 0.0 {
        step_umbrella(state, inputs, umbrella_dt, &mut gone_spheres, &mut report);
        cap_umbrella(state, inputs.caps.max_umbrella_spheres, &mut gone_spheres, &mut report);
    }
    compact(state, gone, gone_spheres, &mut report);
    report
}

fn emit(state: &mut PlumeState, inputs: &PlumeInputs, report: &mut PlumeReport) {
    let Some(emitter) = inputs.emitter else { return };
    if !inputs.active || inputs.frozen {
        return;
    }
    let p = inputs.params;
    let e = &mut state.emission;
    e.since_last += inputs.dt;
    let interval = p.emission_interval();
    // At most a few per step so a huge edit cannot flood the world; what is due beyond that
    // is carried to the next steps.
    let mut budget = MAX_EMISSIONS_PER_STEP;
    while e.since_last >= interval && budget > 0 {
        e.since_last -= interval;
        budget -= 1;
        let index = e.emitted;
        e.emitted += 1;
        let slice = LiveSlice::at_vent(p, index, emitter.vent);
        state.ash.emitted_kg += slice.state.solid_mass;
        let ring = ring(inputs.spheres, emitter.rng, index);
        let first_ring = state.rings.len();
        state.rings.extend_from_slice(&ring);
        report.emitted.push(Emitted { at: state.slices.len(), slice: slice.clone(), ring, first_ring });
        state.slices.push(slice);
    }
    let backlog = (e.since_last / interval).floor() as u64;
    report.backlog_began = backlog > 0 && e.backlog == 0;
    e.backlog = backlog;
    e.capped_steps += u64::from(backlog > 0);
}

/// The live-slice cap: secondary columns first (lightest first), then the column from its
/// oldest slice (lowest index).
fn cap_slices(state: &mut PlumeState, max: usize, gone: &mut [Option<SliceFate>], report: &mut PlumeReport) {
    let n = state.slices.len();
    if n <= max {
        return;
    }
    let s = &state.slices;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        let (a, b) = (&s[a], &s[b]);
        (!a.secondary)
            .cmp(&!b.secondary)
            .then_with(|| match a.secondary {
                true => a.state.mass.total_cmp(&b.state.mass),
                false => std::cmp::Ordering::Equal,
            })
            .then(a.index.cmp(&b.index))
    });
    for &k in &order[..n - max] {
        let slice = &state.slices[k];
        let ash = slice.state.solid_mass.max(0.0) + slice.ash_pending.max(0.0);
        if ash > 0.0 {
            state.ash.released_kg += ash;
            state.ash.capped_kg += ash;
        }
        gone[k] = Some(SliceFate::Retired(report.retired.len()));
        report.retired.push(RemovedSlice { at: k, slice: slice.clone(), ash_kg: ash, ring: Vec::new() });
    }
}

/// Steps every live slice; returns the positions of those that reached their apex or
/// collapsed, in order.
fn step_slices(
    state: &mut PlumeState,
    inputs: &PlumeInputs,
    gone: &mut [Option<SliceFate>],
    report: &mut PlumeReport,
) -> Vec<usize> {
    let (p, dt) = (inputs.params, inputs.dt);
    let own_air = p.air();
    let mut finishing = Vec::new();
    for (k, slice) in state.slices.iter_mut().enumerate() {
        if gone[k].is_some() {
            continue;
        }
        let vent_altitude = slice.vent.y as f64;
        let out = match inputs.air {
            // Coupled: the layers' air and wind around the column (§4.3.3).
            PlumeAir::Coupled(a) => {
                let wind = |z: f64| a.wind_at(vent_altitude + z);
                slice.state.step(p, &SliceEnv { air: a, vent_altitude, wind: &wind }, dt)
            }
            PlumeAir::Own => {
                let wind = |z: f64| p.wind.at(z);
                slice.state.step(p, &SliceEnv { air: &own_air, vent_altitude, wind: &wind }, dt)
            }
        };
        slice.ash_pending += out.sedimented;
        // Spin of the ring spheres: Ω = v / r_s about the ring tangent (mean size r_s = r/2).
        slice.ring_phase += slice.state.velocity.length() / (0.5 * slice.state.r).max(1e-9) * dt;
        if out.reached_neutral {
            report.neutral.push(NeutralEvent {
                at: k,
                altitude: slice.state.neutral_altitude.unwrap_or(0.0),
                speed: slice.state.neutral_speed.unwrap_or(0.0),
            });
        }
        if !slice.state.is_finite() {
            let lost = slice.ash_pending + slice.state.solid_mass.max(0.0);
            state.ash.lost_kg += lost;
            gone[k] = Some(SliceFate::NonFinite(report.non_finite.len()));
            report.non_finite.push(RemovedSlice {
                at: k,
                slice: slice.clone(),
                ash_kg: lost,
                ring: Vec::new(),
            });
            continue;
        }
        if matches!(slice.state.phase, Phase::Collapsed | Phase::Umbrella) {
            finishing.push(k);
        }
    }
    finishing
}

/// A slice at its apex gives its ring to the umbrella with its ash; a collapsed one goes to the
/// flows with its ash.
fn finish(
    state: &mut PlumeState,
    inputs: &PlumeInputs,
    k: usize,
    gone: &mut [Option<SliceFate>],
    report: &mut PlumeReport,
) {
    let slice = state.slices[k].clone();
    let s = &slice.state;
    let ring: Vec<usize> = (0..state.rings.len()).filter(|&i| state.rings[i].slice == slice.index).collect();
    let solid = s.solid_mass.max(0.0);
    let ash = solid + slice.ash_pending;
    let outcome = if s.phase == Phase::Collapsed { Outcome::Collapsed } else { Outcome::Umbrella };
    match outcome {
        Outcome::Collapsed => state.ash.to_flows_kg += ash,
        Outcome::Umbrella if ring.is_empty() => state.ash.lost_kg += ash,
        Outcome::Umbrella => {}
    }
    let first = state.umbrella.len();
    let mut buoyancy_floored = false;
    if outcome == Outcome::Umbrella {
        let (spread, floored) = umbrella_spread(&slice, inputs);
        buoyancy_floored = floored;
        let share = 1.0 / ring.len().max(1) as f64;
        for (m, &i) in ring.iter().enumerate() {
            let r = state.rings[i];
            // Spread radially around the column axis from where the sphere sits on the
            // (possibly tilted) vortex ring (§3.5.2; the law's clamp d ≥ r moves it at v until
            // d = r).
            state.umbrella.push(CloudSphere {
                id: r.id,
                sphere: UmbrellaSphere::detach(s, r.sphere.local_offset(s.r), spread),
                radius: r.sphere.radius(s.r),
                density: s.density,
                age: 0.0,
                vent: slice.vent,
                ash: solid * share,
                // What the slice shed and the coupling has not taken yet rides on the first.
                ash_pending: if m == 0 { slice.ash_pending } else { 0.0 },
            });
        }
    }
    gone[k] = Some(SliceFate::Finished(report.finished.len()));
    let spheres = first..state.umbrella.len();
    report.finished.push(Finished {
        removed: RemovedSlice { at: k, slice, ash_kg: ash, ring },
        outcome,
        spheres,
        buoyancy_floored,
    });
}

/// How a slice's umbrella spheres spread: the thesis' `v r / d` (§3.5.2), or for a column slice
/// a gravity current (Woods & Kienle 1994) fed by the column's volume rate at the top (the
/// slice's volume over the emission interval) in the air's buoyancy frequency at the neutral
/// level. The bool: that frequency was raised to its floor.
pub fn umbrella_spread(slice: &LiveSlice, inputs: &PlumeInputs) -> (Spread, bool) {
    let p = inputs.params;
    if p.dynamics != Dynamics::Column {
        return (Spread::Thesis, false);
    }
    let s = &slice.state;
    let z = slice.vent.y as f64 + s.neutral_altitude.unwrap_or(s.apex);
    let (n, floored) = match inputs.air {
        PlumeAir::Coupled(a) => buoyancy_frequency(a, z),
        PlumeAir::Own => buoyancy_frequency(&p.air(), z),
    };
    let q = s.volume() / p.emission_interval();
    (Spread::GravityCurrent { c: gravity_current_coefficient(p.umbrella_lambda, n, q) }, floored)
}

/// Fills in the ring positions of removed slices (one pass over the rings).
fn ring_positions(rings: &[RingSphere], removed: &mut [RemovedSlice]) {
    if removed.is_empty() {
        return;
    }
    let mut of: HashMap<u64, Vec<usize>> = HashMap::new();
    for (e, r) in removed.iter().enumerate() {
        of.entry(r.slice.index).or_default().push(e);
    }
    for (i, r) in rings.iter().enumerate() {
        if let Some(entries) = of.get(&r.slice) {
            for &e in entries {
                removed[e].ring.push(i);
            }
        }
    }
}

fn step_umbrella(
    state: &mut PlumeState,
    inputs: &PlumeInputs,
    dt: f64,
    gone: &mut [Option<SphereFate>],
    report: &mut PlumeReport,
) {
    let p = inputs.params;
    for (k, u) in state.umbrella.iter_mut().enumerate() {
        u.sphere.step(dt);
        // The spreading cloud drifts with the wind at its altitude (the column axis moves).
        let altitude = u.sphere.altitude();
        let wind = match inputs.air {
            PlumeAir::Coupled(a) => a.wind_at(u.vent.y as f64 + altitude),
            PlumeAir::Own => p.wind.at(altitude),
        };
        u.sphere.axis += wind * dt;
        u.age += dt;
        // Ash fallout from the spreading cloud, exact for any step: a share 1 − exp(−Δt/τ).
        let fallout = u.ash * (1.0 - (-dt / inputs.umbrella_fallout_s).exp());
        u.ash -= fallout;
        u.ash_pending += fallout;
        if !u.is_finite() {
            // The guard (`volcano_core::fault`): what it still held is booked as lost.
            let mass = volcano_core::fault::bookable(u.ash) + volcano_core::fault::bookable(u.ash_pending);
            state.ash.lost_kg += mass;
            gone[k] = Some(SphereFate::NonFinite(report.umbrella_non_finite.len()));
            report.umbrella_non_finite.push(RemovedSphere { at: k, sphere: u.clone(), ash_kg: mass });
        } else if u.age > inputs.umbrella_lifetime {
            let mass = u.ash + u.ash_pending;
            if mass > 0.0 {
                state.ash.released_kg += mass;
            }
            gone[k] = Some(SphereFate::Expired(report.expired.len()));
            report.expired.push(RemovedSphere { at: k, sphere: u.clone(), ash_kg: mass });
        }
    }
}

/// The umbrella cap: the oldest (largest age, then lowest id) expire early.
fn cap_umbrella(
    state: &mut PlumeState,
    max: usize,
    gone: &mut [Option<SphereFate>],
    report: &mut PlumeReport,
) {
    let mut list: Vec<usize> = (0..state.umbrella.len()).filter(|&k| gone[k].is_none()).collect();
    if list.len() <= max {
        return;
    }
    let u = &state.umbrella;
    let older = |a: &usize, b: &usize| u[*b].age.total_cmp(&u[*a].age).then(u[*a].id.cmp(&u[*b].id));
    // Only the excess is ordered: at the cap a few spheres arrive per step among tens of
    // thousands (a full sort of them every step would be most of a soak's tick).
    let excess = list.len() - max;
    list.select_nth_unstable_by(excess - 1, older);
    list[..excess].sort_by(older);
    for &k in &list[..excess] {
        let sphere = &state.umbrella[k];
        let ash = sphere.ash.max(0.0) + sphere.ash_pending.max(0.0);
        if ash > 0.0 {
            state.ash.released_kg += ash;
            state.ash.capped_kg += ash;
        }
        gone[k] = Some(SphereFate::Retired(report.umbrella_retired.len()));
        report.umbrella_retired.push(RemovedSphere { at: k, sphere: sphere.clone(), ash_kg: ash });
    }
}

/// Drops what left and numbers what stays.
fn compact(
    state: &mut PlumeState,
    gone: Vec<Option<SliceFate>>,
    gone_spheres: Vec<Option<SphereFate>>,
    report: &mut PlumeReport,
) {
    let mut ring_gone = vec![false; state.rings.len()];
    let removed =
        report.retired.iter().chain(&report.non_finite).chain(report.finished.iter().map(|f| &f.removed));
    for i in removed.flat_map(|r| &r.ring) {
        ring_gone[*i] = true;
    }
    if ring_gone.contains(&true) {
        let mut i = 0;
        state.rings.retain(|_| {
            i += 1;
            !ring_gone[i - 1]
        });
    }
    let mut kept = 0;
    report.slice_fates = gone
        .into_iter()
        .map(|g| {
            g.unwrap_or_else(|| {
                kept += 1;
                SliceFate::Kept(kept - 1)
            })
        })
        .collect();
    let mut k = 0;
    let fates = &report.slice_fates;
    state.slices.retain(|_| {
        k += 1;
        matches!(fates[k - 1], SliceFate::Kept(_))
    });
    let mut kept = 0;
    report.sphere_fates = gone_spheres
        .into_iter()
        .map(|g| {
            g.unwrap_or_else(|| {
                kept += 1;
                SphereFate::Kept(kept - 1)
            })
        })
        .collect();
    let mut k = 0;
    let fates = &report.sphere_fates;
    state.umbrella.retain(|_| {
        k += 1;
        matches!(fates[k - 1], SphereFate::Kept(_))
    });
}

#[cfg(test)]
mod tests;
