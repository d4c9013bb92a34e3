//! The angle of attack over the frames and the classic damping plot (its component up against
//! its component right), estimated (orange) against true (blue), where the results state the
//! world frame (`aoa_deg`, `aoa_up_deg`, `aoa_right_deg`) and the clip gives the truth
//! (`gt_aoa_*`).

use super::font::FAMILY;
use super::panel::{ESTIMATE, Mark, Series, TRUTH, draw_legend, draw_panel, legend_mark, span};
use crate::clip::{Clip, ResultRow, TrueAngleOfAttack};
use plotters::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// An angle of attack as (total, up, right), deg.
type Angles = (f64, f64, f64);

/// Writes the figure for one results file to `path` (1500 x 900 px); false (nothing written)
/// where no row gives an angle of attack.
pub fn plot(clip: &Clip, rows: &[ResultRow], title: &str, path: &Path) -> anyhow::Result<bool> {
    let estimated: HashMap<u64, Angles> = rows
        .iter()
        .filter(|r| r.is_ok())
        .filter_map(|r| Some((r.frame?, (r.aoa_deg?, r.aoa_up_deg?, r.aoa_right_deg?))))
        .collect();
    if estimated.is_empty() {
        return Ok(false);
    }
    let frames: Vec<(u64, Option<TrueAngleOfAttack>)> = clip
        .frames
        .iter()
        .filter_map(|f| f.as_ref().ok())
        .map(|r| (r.frame, r.truth_aoa))
        .collect();
    let series_of = |pick: fn(&Angles) -> f64, truth: fn(&TrueAngleOfAttack) -> f64| {
        vec![
            Series {
                label: "truth",
                mark: Mark::Line,
                color: TRUTH,
                points: frames
                    .iter()
                    .filter_map(|(f, t)| Some((*f as f64, truth(t.as_ref()?))))
                    .collect(),
                sigmas: Vec::new(),
            },
            Series {
                label: "estimate",
                mark: Mark::Dots,
                color: ESTIMATE,
                points: frames
                    .iter()
                    .filter_map(|(f, _)| Some((*f as f64, pick(estimated.get(f)?))))
                    .collect(),
                sigmas: Vec::new(),
            },
        ]
    };
    let root = BitMapBackend::new(path, (1500, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, (FAMILY, 26))?;
    let areas = root.split_evenly((2, 2));
    let panels = [
        ("total angle of attack", series_of(|a| a.0, |t| t.total_deg)),
        (
            "component up (nose above the velocity)",
            series_of(|a| a.1, |t| t.up_deg),
        ),
        (
            "component right (nose right of the velocity)",
            series_of(|a| a.2, |t| t.right_deg),
        ),
    ];
    for (area, (name, series)) in areas.iter().zip(panels) {
        draw_panel(area, name, "deg", &series)?;
    }
    if let Some(area) = areas.get(3) {
        let truth: Vec<(f64, f64)> = frames
            .iter()
            .filter_map(|(_, t)| t.map(|t| (t.right_deg, t.up_deg)))
            .collect();
        let estimate: Vec<(f64, f64)> = frames
            .iter()
            .filter_map(|(f, _)| estimated.get(f).map(|a| (a.2, a.1)))
            .collect();
        damping(area, &truth, &estimate)?;
    }
    root.present()?;
    Ok(true)
}

/// The damping plot: the component up against the component right, the truth as a line in
/// time order, the estimates as dots, on equal scales.
fn damping(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    truth: &[(f64, f64)],
    estimate: &[(f64, f64)],
) -> anyhow::Result<()> {
    let all = || truth.iter().chain(estimate);
    let (x, y) = (span(all().map(|p| p.0)), span(all().map(|p| p.1)));
    // Equal scales: both axes span the larger range, centred on their own middles.
    let half = 0.5 * (x.end - x.start).max(y.end - y.start);
    let centre = |r: &std::ops::Range<f64>| 0.5 * (r.start + r.end);
    let (cx, cy) = (centre(&x), centre(&y));
    let mut chart = ChartBuilder::on(area)
        .caption("damping plot: up against right", (FAMILY, 22))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(cx - half..cx + half, cy - half..cy + half)?;
    chart
        .configure_mesh()
        .x_desc("right, deg")
        .y_desc("up, deg")
        .label_style((FAMILY, 14))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            truth.iter().copied(),
            TRUTH.stroke_width(2),
        ))?
        .label("truth")
        .legend(legend_mark(TRUTH));
    chart
        .draw_series(
            estimate
                .iter()
                .map(|&p| Circle::new(p, 3, ESTIMATE.filled())),
        )?
        .label("estimate")
        .legend(legend_mark(ESTIMATE));
    draw_legend(&mut chart)
}
