//! The multigrid's AVX2 row loops give the same bits as its scalar loops: every built-in
//! scenario run 40 steps at 64² with and without them ends in the same state, bit for bit
//! (and the same V-cycles); one at 256², where the sweeps run in parallel bands, 8 steps.
//! On a CPU without AVX2 both runs take the scalar loops.

use volcano_atmosphere::WeatherScenario;
use volcano_atmosphere::model::fields::AtmosphereState;
use volcano_atmosphere::model::multigrid::use_simd;
use volcano_atmosphere::model::scenario::BUILTIN;
use volcano_atmosphere::model::step::{Workspace, step};

/// Every field of every layer and the ground, as bits.
fn bits(state: &AtmosphereState) -> Vec<u64> {
    let mut out = Vec::new();
    for l in &state.layers {
        for g in [&l.t, &l.u, &l.v, &l.c, &l.up, &l.d, &l.sigma] {
            out.extend(g.data().iter().map(|x| x.to_bits() as u64));
        }
        for g in [&l.h, &l.w, &l.ash, &l.p] {
            out.extend(g.data().iter().map(|x| x.to_bits()));
        }
    }
    out.extend(state.ground.t.data().iter().map(|x| x.to_bits() as u64));
    out.extend(state.ground.water.data().iter().map(|x| x.to_bits()));
    out
}

/// The state's bits and the V-cycles after `steps` steps of scenario `name` on an `n²` grid.
fn run(name: &str, n: usize, steps: usize, simd: bool) -> (Vec<u64>, u32) {
    use_simd(simd);
    let sc = WeatherScenario::builtin(name).unwrap();
    let mut state = sc.build(Some(n)).unwrap();
    let mut work = Workspace::new(&state).unwrap();
    let mut cycles = 0;
    for _ in 0..steps {
        cycles += step(&mut state, &sc.params, &mut work, sc.dt).unwrap().v_cycles;
    }
    use_simd(true);
    (bits(&state), cycles)
}

// One test: the switch is process-wide.
#[test]
fn avx2_loops_give_the_scalar_loops_bits() {
    for (name, _) in BUILTIN {
        let (a, b) = (run(name, 64, 40, true), run(name, 64, 40, false));
        assert_eq!(a.1, b.1, "{name}: V-cycles");
        assert!(a.0 == b.0, "{name}: the states differ");
    }
    let (a, b) = (run("mixed", 256, 8, true), run("mixed", 256, 8, false));
    assert!(a.1 == b.1 && a.0 == b.0, "mixed at 256²: the states differ");
}
