//! Development timing of the kernels at 512² (not a benchmark; see benches/).
use std::time::Instant;

use volcano_atmosphere::model::advection::{Staggering, advect_conservative, advect_field, apertures};
use volcano_atmosphere::model::multigrid::Poisson;
use volcano_atmosphere::model::params::AdvectionScheme;

fn main() {
    let n = 512;
    let f: Vec<f32> = (0..n * n).map(|k| (k % 97) as f32).collect();
    let u: Vec<f32> = (0..n * n).map(|k| 5.0 + (k % 13) as f32 * 0.1).collect();
    let v: Vec<f32> = (0..n * n).map(|k| -3.0 + (k % 7) as f32 * 0.1).collect();
    let mut out = vec![0.0f32; n * n];
    let mut scratch = vec![0.0f32; 3 * n * n];
    for scheme in [AdvectionScheme::SemiLagrangian, AdvectionScheme::MacCormack] {
        let t = Instant::now();
        for _ in 0..10 {
            advect_field(&f, &mut out, &mut scratch, &u, &v, n, 0.3, Staggering::FaceX, scheme);
        }
        println!("advect_field {scheme:?}: {:.2} ms", t.elapsed().as_secs_f64() * 100.0);
    }
    let sigma = vec![1.0f32; n * n];
    let mut ax = vec![0.0; n * n];
    let mut ay = vec![0.0; n * n];
    apertures(&sigma, n, &mut ax, &mut ay);
    let mut q: Vec<f64> = (0..n * n).map(|k| (k % 11) as f64).collect();
    let mut src = vec![0.0; 3 * n * n];
    let t = Instant::now();
    for _ in 0..10 {
        advect_conservative(&mut [&mut q[..]], &mut src, &u, &v, &ax, &ay, &sigma, n, 0.1);
    }
    println!("flux (1 field, 1 substep): {:.2} ms", t.elapsed().as_secs_f64() * 100.0);
    let mut mg = Poisson::new(n, 100.0).unwrap();
    let mut rhs: Vec<f64> = (0..n * n).map(|k| ((k * 7919) % 101) as f64 - 50.0).collect();
    let mean = rhs.iter().sum::<f64>() / rhs.len() as f64;
    rhs.iter_mut().for_each(|r| *r -= mean);
    let mut phi = vec![0.0; n * n];
    let t = Instant::now();
    for _ in 0..10 {
        mg.v_cycle(&mut phi, &rhs);
    }
    println!("V-cycle: {:.2} ms", t.elapsed().as_secs_f64() * 100.0);
    let t = Instant::now();
    for _ in 0..10 {
        std::hint::black_box(mg.residual_rms(&phi, &rhs));
    }
    println!("residual: {:.2} ms", t.elapsed().as_secs_f64() * 100.0);
}
