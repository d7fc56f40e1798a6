//! `volcano plume-plots`: the validation figures of thesis Fig 3.5 as PNG (plotters).
//! A: slice density vs altitude with the air; B: altitude vs vertical speed for several v0;
//! C: trajectories (downwind distance vs altitude) for winds of 15/45/105 m/s at 12 km.

use std::path::Path;
use std::process::ExitCode;

use plotters::prelude::*;
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
        Ok(())
    };
    match run() {
        Ok(()) => {
            println!("wrote fig3_5a.png, fig3_5b.png, fig3_5c.png to {}", out.display());
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
