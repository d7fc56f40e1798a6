//! Development probe: prints time series and x-profiles of a scenario (not a test).
//! `cargo run -p volcano_atmosphere --example probe -- NAME STEPS GRID EVERY`
use volcano_atmosphere::model::scenario::WeatherScenario;
use volcano_atmosphere::model::step::{Workspace, step};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("orographic", |s| s.as_str());
    let steps: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(100);
    let grid: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(64);
    let every: u32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(10);
    let sc = WeatherScenario::builtin(name).unwrap();
    let mut st = sc.build(Some(grid)).unwrap();
    let mut w = Workspace::new(&st).unwrap();
    let n = st.grid.n;
    for s in 0..steps {
        let r = step(&mut st, &sc.params, &mut w, sc.dt).unwrap();
        if s % every == 0 || s + 1 == steps {
            println!(
                "step {s} hour {:.2} maxD {:.3} div {:.2e} red {:.1} subs {} cycles {} ms {:?}",
                st.local_hour(),
                r.max_vertical_speed,
                r.max_divergence_error,
                r.residual_reduction,
                r.flux_substeps,
                r.v_cycles,
                r.phase_ms
            );
            // x-profile (mean over y) of layer 0/1: T, ground T, u, D, C, U, W.
            let mut line = String::new();
            for i in (0..n).step_by((n / 16).max(1)) {
                let mean = |f: &dyn Fn(usize) -> f64| {
                    (3 * n / 8..5 * n / 8).map(|j| f(j * n + i)).sum::<f64>() / (n / 4) as f64
                };
                let l0 = &st.layers[0];
                let l1 = &st.layers[1];
                line += &format!(
                    "\n  i{i:3} h{:6.0} Tg{:6.1} T0{:6.1} T1{:6.1} u0{:6.2} D0{:6.2} C0{:6.2} U0{:6.2} D1{:6.2} W0{:5.2} W1{:5.2} H0{:5.2} W2{:5.2} W3{:5.2} D2{:5.2}",
                    mean(&|k| st.ground.height.data()[k] as f64),
                    mean(&|k| st.ground.t.data()[k] as f64),
                    mean(&|k| l0.t.data()[k] as f64),
                    mean(&|k| l1.t.data()[k] as f64),
                    mean(&|k| l0.u.data()[k] as f64),
                    mean(&|k| l0.d.data()[k] as f64),
                    mean(&|k| l0.c.data()[k] as f64),
                    mean(&|k| l0.up.data()[k] as f64),
                    mean(&|k| l1.d.data()[k] as f64),
                    mean(&|k| l0.w.data()[k]),
                    mean(&|k| l1.w.data()[k]),
                    mean(&|k| l0.h.data()[k]),
                    mean(&|k| st.layers[2].w.data()[k]),
                    mean(&|k| st.layers[st.layers.len() - 1].w.data()[k]),
                    mean(&|k| st.layers[2].d.data()[k] as f64),
                );
            }
            println!("{line}");
            for (li, l) in st.layers.iter().enumerate() {
                let frac = |range: std::ops::Range<usize>| {
                    let mut c = 0;
                    let mut t = 0;
                    for j in 0..n {
                        for i in range.clone() {
                            t += 1;
                            if l.w.data()[j * n + i] > 0.05 && l.sigma.data()[j * n + i] > 0.0 {
                                c += 1;
                            }
                        }
                    }
                    c as f64 / t as f64
                };
                println!("  layer {li}: cloudy frac windward {:.2} lee {:.2}", frac(22..30), frac(35..43));
            }
        }
    }
}
