//! Bad input is rejected with a named error; fuzzed valid input never panics or produces NaN.

use proptest::prelude::*;
use volcano_plume::model::run::run_single_slice;
use volcano_plume::{PlumeParams, Preset, WindProfile};

#[test]
fn bad_parameters_are_named_errors() {
    let base = Preset::Thesis.params();
    let cases: Vec<(&str, PlumeParams)> = vec![
        ("v0", PlumeParams { v0: f64::NAN, ..base.clone() }),
        ("r0", PlumeParams { r0: 0.0, ..base.clone() }),
        ("r0", PlumeParams { r0: -5.0, ..base.clone() }),
        ("rho0", PlumeParams { rho0: -1.0, ..base.clone() }),
        ("dt", PlumeParams { dt: 5.0, ..base.clone() }),
        ("dt", PlumeParams { dt: 0.0, ..base.clone() }),
        ("t0", PlumeParams { t0: f64::INFINITY, ..base.clone() }),
        (
            "wind max",
            PlumeParams {
                wind: WindProfile::Linear { max: -3.0, top: 12e3, direction_deg: 0.0 },
                ..base.clone()
            },
        ),
    ];
    for (name, p) in cases {
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains(name), "expected an error naming {name}, got {e}");
        assert!(run_single_slice(&p, 10.0, 0.1).is_err());
    }
    let e = PlumeParams::from_ron("(v0: 150.0, vent_radius: 3.0)").unwrap_err().to_string();
    assert!(e.contains("vent_radius"), "{e}");
    let p = PlumeParams::from_ron("(v0: 180.0, contraction: false)").unwrap();
    assert_eq!((p.v0, p.contraction, p.r0), (180.0, false, 100.0));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    #[test]
    fn fuzzed_parameters_never_nan(
        v0 in 0.1f64..1000.0,
        r0 in 0.1f64..5000.0,
        rho0 in 1e-3f64..3000.0,
        t0 in 200.0f64..2000.0,
        wind in 0.0f64..200.0,
        dt in 1e-4f64..0.1,
        contraction in any::<bool>(),
        vent in -1000.0f64..9000.0,
        sigma_col in 0.0f64..1e-2,
        tau in 0.0f64..100.0,
        ks in 0.0f64..1.0,
        kw in 0.0f64..5.0,
        drag in 0.0f64..10.0,
        lambda in 0.0f64..1e5,
    ) {
        let p = PlumeParams {
            v0, r0, rho0, t0, dt, contraction, vent_altitude: vent, sigma_col, tau, ks, kw,
            drag_coefficient: drag, wind_coefficient: lambda,
            wind: WindProfile::Linear { max: wind, top: 12_000.0, direction_deg: 30.0 },
            ..Preset::Thesis.params()
        };
        let (s, traj) = run_single_slice(&p, 120.0, 1.0).unwrap();
        prop_assert!(s.apex_m.is_finite() && s.max_downwind_m.is_finite());
        for t in traj {
            prop_assert!([t.x, t.y, t.z, t.vx, t.vy, t.vz, t.r, t.rho, t.temperature].iter().all(|v| v.is_finite()));
            prop_assert!(t.rho > 0.0 && t.r > 0.0 && t.temperature > 0.0);
        }
    }
}
