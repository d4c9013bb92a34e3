//! The training loss against the step (`imade train`), with its running mean.

use super::font::FAMILY;
use super::panel::{ESTIMATE, SECONDARY, draw_legend, legend_mark};
use plotters::prelude::*;
use std::path::Path;

/// Steps in the running mean.
const WINDOW: usize = 50;

/// Writes the loss curve (1000 x 600 px) to `path`.
pub fn plot(losses: &[f64], path: &Path) -> anyhow::Result<()> {
    super::font::register()?;
    let finite: Vec<(f64, f64)> = losses
        .iter()
        .enumerate()
        .filter(|(_, l)| l.is_finite() && **l >= 0.0)
        .map(|(step, &l)| (step as f64, l))
        .collect();
    let top = finite.iter().map(|p| p.1).fold(0.0f64, f64::max);
    let top = if top > 0.0 { 1.05 * top } else { 1.0 };
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Training loss (L2 of the warped prior against the true mask)",
            (FAMILY, 22),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..losses.len().max(1) as f64, 0.0..top)?;
    chart
        .configure_mesh()
        .x_desc("step")
        .y_desc("loss")
        .label_style((FAMILY, 14))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            finite.iter().copied(),
            SECONDARY.stroke_width(1),
        ))?
        .label("step")
        .legend(legend_mark(SECONDARY));
    let running: Vec<(f64, f64)> = finite
        .windows(WINDOW.min(finite.len()).max(1))
        .map(|w| {
            let mean = w.iter().map(|p| p.1).sum::<f64>() / w.len() as f64;
            (w[w.len() - 1].0, mean)
        })
        .collect();
    chart
        .draw_series(LineSeries::new(running, ESTIMATE.stroke_width(2)))?
        .label(format!("mean of {WINDOW} steps"))
        .legend(legend_mark(ESTIMATE));
    draw_legend(&mut chart)?;
    root.present()?;
    Ok(())
}
