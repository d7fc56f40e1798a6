//! Convergence in the time step: the same 40 simulated minutes cut into steps of
//! 120 s down to 3.75 s must approach one answer, as a consistent scheme does — a rate applied
//! per step instead of per second (a damping factor, a relaxation, a transfer share) would make
//! the answer depend on the number of steps and the differences would not shrink. What the
//! shipped scenarios show is written in docs/physics/atmosphere.md §5.4 ("Time step").

use volcano_atmosphere::model::fields::AtmosphereState;
use volcano_atmosphere::model::scenario::WeatherScenario;
use volcano_atmosphere::model::step::{Workspace, step};

const STEPS_S: [f64; 6] = [120.0, 60.0, 30.0, 15.0, 7.5, 3.75];

fn run(s: &WeatherScenario, st: &AtmosphereState, dt: f64, seconds: f64) -> AtmosphereState {
    let mut st = st.clone();
    let mut work = Workspace::new(&st).unwrap();
    for _ in 0..(seconds / dt).round() as usize {
        step(&mut st, &s.params, &mut work, dt).unwrap();
    }
    st
}

/// Root-mean-square difference of temperature (K) and horizontal wind (m/s) over all layers.
fn rms(a: &AtmosphereState, b: &AtmosphereState) -> (f64, f64) {
    let (mut t, mut w, mut n) = (0.0, 0.0, 0.0);
    for (la, lb) in a.layers.iter().zip(&b.layers) {
        for (x, y) in la.t.data().iter().zip(lb.t.data()) {
            t += ((x - y) as f64).powi(2);
            n += 1.0;
        }
        for (x, y) in la.u.data().iter().zip(lb.u.data()).chain(la.v.data().iter().zip(lb.v.data())) {
            w += ((x - y) as f64).powi(2) / 2.0;
        }
    }
    ((t / n).sqrt(), (w / n).sqrt())
}

/// 40 simulated minutes from `st` at each step of `steps`; the RMS difference (T, wind) of each
/// step's result to its half step's, printed.
fn half_step_differences(s: &WeatherScenario, st: &AtmosphereState, steps: &[f64]) -> Vec<(f64, f64)> {
    let runs: Vec<_> = steps.iter().map(|&dt| run(s, st, dt, 2400.0)).collect();
    let halves: Vec<(f64, f64)> = runs.windows(2).map(|w| rms(&w[0], &w[1])).collect();
    for (dt, (t, w)) in steps.iter().zip(&halves) {
        eprintln!("dt {dt:>6} s vs dt/2: T {t:.3e} K, wind {w:.3e} m/s");
    }
    halves
}

/// Each halving of the step (from `steps[from]` on) brings the wind at least 1.4× closer to
/// its half step's (first order gives 2×).
fn assert_wind_converges(halves: &[(f64, f64)], steps: &[f64], from: usize) {
    for k in from..halves.len() - 1 {
        let (a, b) = (halves[k].1, halves[k + 1].1);
        assert!(a > 1.4 * b, "wind: dt {} vs half {a:.3e}, dt {} vs half {b:.3e}", steps[k], steps[k + 1]);
    }
}

/// The `mixed` scenario (land and sea, hills, moist air, wind; 32² cells of 1.6 km), 40 minutes
/// from the same start at each step. The difference between a step and its half shrinks with
/// each halving (measured: wind 0.060, 0.020, 0.0072, 0.0032, 0.0015 m/s from 120 s down to
/// 7.5 s, temperature 0.029 → 0.0027 K; applying the terrain damping per step instead gives
/// 0.082 → 0.009 m/s and 0.032 → 0.009 K).
#[test]
fn halving_the_step_converges_on_one_answer() {
    let s = WeatherScenario::builtin("mixed").unwrap();
    let st = s.build(Some(32)).unwrap();
    let halves = half_step_differences(&s, &st, &STEPS_S);
    assert_wind_converges(&halves, &STEPS_S, 1);
    // Both fields: 16× smaller steps, ≥ 3× closer answers.
    let (first, last) = (halves[0], halves[halves.len() - 1]);
    assert!(first.0 > 3.0 * last.0, "temperature: {:.3e} → {:.3e} K", first.0, last.0);
    assert!(first.1 > 3.0 * last.1, "wind: {:.3e} → {:.3e} m/s", first.1, last.1);
}

/// The dry `orographic` scenario (a 1,100 m ridge across a 10 m/s wind, 32² cells of 1.6 km):
/// where the terrain narrows a face the wind is damped (eq. 4.8), and that damping must be a
/// rate per second, not a factor per step — applied once per step, halving the step doubled
/// the damping and the wind's half-step difference stalled at 0.29, 0.24, 0.20, 0.18 m/s
/// (60 s down to 7.5 s); as a rate it halves with each halving: 0.078, 0.036, 0.017, 0.008.
#[test]
fn halving_the_step_converges_over_a_ridge() {
    let s = WeatherScenario::builtin("orographic").unwrap();
    let mut st = s.build(Some(32)).unwrap();
    for l in st.layers.iter_mut() {
        l.h.data_mut().fill(0.0);
        l.w.data_mut().fill(0.0);
    }
    st.ground.water.data_mut().fill(0.0);
    let halves = half_step_differences(&s, &st, &STEPS_S[1..]);
    assert_wind_converges(&halves, &STEPS_S[1..], 0);
}
