//! `volcano plume-plots`: the validation figures of thesis Fig 3.5 as PNG (plotters).
//! A: slice density vs altitude with the air; B: altitude vs vertical speed for several v0;
//! C: trajectories (downwind distance vs altitude) for winds of 15/45/105 m/s at 12 km.
//! For the physical column also `height_vs_mer.png`: top height against mass eruption rate
//! (10⁴–10⁹ kg/s) beside Mastin et al. (2009).

use std::path::Path;
use std::process::ExitCode;

use plotters::prelude::*;
use volcano::plume::model::params::Dynamics;
use volcano::plume::model::run::{TrajectorySample, run_single_slice};
use volcano::plume::{PlumeParams, WindProfile};

type Plot = Result<(), Box<dyn std::error::Error>>;

const COLORS: [RGBColor; 4] =
    [RGBColor(200, 60, 30), RGBColor(30, 110, 200), RGBColor(40, 150, 60), RGBColor(120, 60, 160)];

fn trajectory(p: &PlumeParams) -> Result<Vec<TrajectorySample>, Box<dyn std::error::Error>> {
    Ok(run_single_slice(p, 3_600.0, 0.1)?.1)
}

/// Writes `fig3_5a.png`, `fig3_5b.png`, `fig3_5c.png` into `out` for parameters `base`.
pub fn plume_plots(base: &PlumeParams, out: &Path) -> ExitCode {
    if let Err(e) = base.validate() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    // Text needs a font; plotters' ab_glyph backend takes one by bytes (egui's Ubuntu Light,
    // already in the dependency tree, so no system font is needed).
    if plotters::style::register_font("sans-serif", FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
        .is_err()
    {
        eprintln!("error: cannot load the plot font");
        return ExitCode::FAILURE;
    }
    let run = || -> Plot {
        std::fs::create_dir_all(out)?;
        density(base, &out.join("fig3_5a.png"))?;
        speeds(base, &out.join("fig3_5b.png"))?;
        winds(base, &out.join("fig3_5c.png"))?;
        if base.dynamics == Dynamics::Column {
            height_vs_mer(base, &out.join("height_vs_mer.png"))?;
        }
        Ok(())
    };
    match run() {
        Ok(()) => {
            let extra = if base.dynamics == Dynamics::Column { ", height_vs_mer.png" } else { "" };
            println!("wrote fig3_5a.png, fig3_5b.png, fig3_5c.png{extra} to {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn density(base: &PlumeParams, path: &Path) -> Plot {
    let t = trajectory(base)?;
    let top = t.iter().map(|s| s.z).fold(1_000.0, f64::max) * 1.1;
    let root = BitMapBackend::new(path, (800, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("A: slice density vs altitude (v0 = {} m/s)", base.v0), ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d((0.01f64..300.0).log_scale(), 0.0..top / 1_000.0)?;
    chart.configure_mesh().x_desc("density (kg/m³, log)").y_desc("altitude above vent (km)").draw()?;
    chart
        .draw_series(LineSeries::new(t.iter().map(|s| (s.rho, s.z / 1_000.0)), COLORS[0].stroke_width(2)))?
        .label("slice")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], COLORS[0]));
    chart
        .draw_series(LineSeries::new(
            t.iter().map(|s| (s.rho_air, s.z / 1_000.0)),
            COLORS[1].stroke_width(2),
        ))?
        .label("air")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], COLORS[1]));
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    root.present()?;
    Ok(())
}

fn speeds(base: &PlumeParams, path: &Path) -> Plot {
    let v0s = [150.0, 175.0, 200.0, 250.0];
    let runs: Vec<_> =
        v0s.iter().map(|&v0| trajectory(&PlumeParams { v0, ..base.clone() })).collect::<Result<_, _>>()?;
    let top = runs.iter().flatten().map(|s| s.z).fold(1_000.0, f64::max) * 1.05;
    let vmax = runs.iter().flatten().map(|s| s.vz).fold(1.0, f64::max) * 1.05;
    let vmin = runs.iter().flatten().map(|s| s.vz).fold(0.0, f64::min) * 1.05;
    let root = BitMapBackend::new(path, (800, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("B: altitude vs vertical speed", ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(vmin..vmax, 0.0..top / 1_000.0)?;
    chart.configure_mesh().x_desc("vertical speed (m/s)").y_desc("altitude above vent (km)").draw()?;
    for (i, (v0, t)) in v0s.iter().zip(&runs).enumerate() {
        let c = COLORS[i % COLORS.len()];
        chart
            .draw_series(LineSeries::new(t.iter().map(|s| (s.vz, s.z / 1_000.0)), c.stroke_width(2)))?
            .label(format!("v0 = {v0} m/s"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    root.present()?;
    Ok(())
}

fn winds(base: &PlumeParams, path: &Path) -> Plot {
    let winds = [0.0, 15.0, 45.0, 105.0];
    let runs: Vec<_> = winds
        .iter()
        .map(|&w| {
            let wind = WindProfile::Linear { max: w, top: 12_000.0, direction_deg: 0.0 };
            trajectory(&PlumeParams { wind, ..base.clone() })
        })
        .collect::<Result<_, _>>()?;
    let top = runs.iter().flatten().map(|s| s.z).fold(1_000.0, f64::max) * 1.05;
    let right = runs.iter().flatten().map(|s| s.x).fold(1_000.0, f64::max) * 1.05;
    let root = BitMapBackend::new(path, (800, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("C: trajectories in wind (v0 = {} m/s)", base.v0), ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(-0.5..right / 1_000.0, 0.0..top / 1_000.0)?;
    chart.configure_mesh().x_desc("downwind distance (km)").y_desc("altitude above vent (km)").draw()?;
    for (i, (w, t)) in winds.iter().zip(&runs).enumerate() {
        let c = COLORS[i % COLORS.len()];
        chart
            .draw_series(LineSeries::new(
                t.iter().map(|s| (s.x / 1_000.0, s.z / 1_000.0)),
                c.stroke_width(2),
            ))?
            .label(format!("wind {w} m/s at 12 km"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    root.present()?;
    Ok(())
}

/// Mastin et al. (2009): top height above the vent (km) for a mass eruption rate (kg/s),
/// `H = 2.00 V^0.241` with V the dense-rock volume rate at 2,500 kg/m³.
pub fn mastin_km(mer: f64) -> f64 {
    2.0 * (mer / 2_500.0).powf(0.241)
}

fn height_vs_mer(base: &PlumeParams, path: &Path) -> Plot {
    // 26 rates, 5 per decade, each with the vent sized by the preset's rule.
    let mers: Vec<f64> = (0..=25).map(|k| 10f64.powf(4.0 + 0.2 * k as f64)).collect();
    let mut tops = Vec::new();
    for &mer in &mers {
        let p = base.with_mer(mer, None)?;
        let s = run_single_slice(&p, 7_200.0, 0.0)?.0;
        tops.push((mer, s.apex_m / 1_000.0, s.regime == "plume"));
    }
    let root = BitMapBackend::new(path, (800, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Top height vs mass eruption rate (no wind)", ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d((1e4f64..1e9).log_scale(), (1.0f64..80.0).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("mass eruption rate (kg/s, log)")
        .y_desc("top above the vent (km, log)")
        .draw()?;
    let mastin = |f: f64| mers.iter().map(move |&m| (m, f * mastin_km(m)));
    chart
        .draw_series(LineSeries::new(mastin(1.0), BLACK.stroke_width(2)))?
        .label("Mastin et al. (2009)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    let grey = RGBColor(150, 150, 150);
    chart
        .draw_series(LineSeries::new(mastin(1.3), grey.stroke_width(1)))?
        .label("Mastin ±30 %")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], grey));
    chart.draw_series(LineSeries::new(mastin(0.7), grey.stroke_width(1)))?;
    chart
        .draw_series(LineSeries::new(
            tops.iter().filter(|t| t.2).map(|t| (t.0, t.1)),
            COLORS[0].stroke_width(2),
        ))?
        .label(format!("physical column (n = {}, T0 = {} K)", base.gas_fraction, base.t0))
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], COLORS[0]));
    chart.draw_series(tops.iter().map(|t| {
        let style = if t.2 { COLORS[0].filled() } else { COLORS[1].filled() };
        Circle::new((t.0, t.1.max(1.0)), 4, style)
    }))?;
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    root.present()?;
    Ok(())
}
