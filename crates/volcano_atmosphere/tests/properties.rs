//! Property tests: budgets and bounds hold for arbitrary inputs.

use approx::assert_relative_eq;
use proptest::prelude::*;
use volcano_atmosphere::model::advection::{advect_conservative, apertures};
use volcano_atmosphere::model::thermo::{phase_change, saturation_humidity};

proptest! {
    #[test]
    fn phase_change_conserves_water_and_never_goes_negative(
        t in 200.0f64..320.0, h in 0.0f64..40.0, w in 0.0f64..10.0,
        pi in 20_000.0f64..105_000.0, gamma in 0.0f64..1.0, dt in 0.1f64..600.0,
    ) {
        let pc = phase_change(t, h, w, pi, gamma, dt);
        prop_assert!(pc.h >= 0.0 && pc.w >= 0.0 && pc.t.is_finite());
        assert_relative_eq!(pc.h + pc.w, h + w, max_relative = 1e-12);
        // Moves toward saturation, never past it.
        let sat = saturation_humidity(t, pi);
        if h < sat { prop_assert!(pc.h >= h && pc.h <= sat + 1e-9) } else { prop_assert!(pc.h <= h && pc.h >= sat - 1e-9) }
    }

    #[test]
    fn flux_advection_conserves_for_any_wind_and_terrain(
        seed in 0u64..1000, speed in 0.0f32..40.0, dt_dx in 0.01f64..1.0,
    ) {
        let n = 16;
        let r = |k: usize, m: u64| ((((k as u64 + 1) * 2_654_435_761) ^ (seed * 97 + m)) % 1000) as f32 / 1000.0;
        let sigma: Vec<f32> = (0..n * n).map(|k| if r(k, 1) < 0.2 { 0.0 } else { r(k, 2).max(0.1) }).collect();
        let u: Vec<f32> = (0..n * n).map(|k| speed * (2.0 * r(k, 3) - 1.0)).collect();
        let v: Vec<f32> = (0..n * n).map(|k| speed * (2.0 * r(k, 4) - 1.0)).collect();
        let mut q: Vec<f64> = (0..n * n).map(|k| if sigma[k] > 0.0 { 10.0 * r(k, 5) as f64 } else { 0.0 }).collect();
        let (mut ax, mut ay) = (vec![0.0; n * n], vec![0.0; n * n]);
        apertures(&sigma, n, &mut ax, &mut ay);
        let total = |q: &[f64]| q.iter().zip(&sigma).map(|(a, &s)| a * s as f64).sum::<f64>();
        let before = total(&q);
        let mut scratch = vec![0.0; 2 * n * n];
        advect_conservative(&mut [&mut q[..]], &mut scratch, &u, &v, &ax, &ay, &sigma, n, dt_dx);
        prop_assert!(q.iter().all(|&x| x >= 0.0));
        prop_assert!((total(&q) - before).abs() <= 1e-12 * before.max(1.0));
        prop_assert!((0..n * n).all(|k| sigma[k] > 0.0 || q[k] == 0.0));
    }
}
