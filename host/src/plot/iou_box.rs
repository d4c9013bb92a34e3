//! IoU box plots of each segmentation stage against the ground-truth masks, one box per run,
//! like the paper's Fig. 19; the paper's median for the stage's counterpart in red.

use super::boxes::{RUNS, category_chart, draw_box, draw_paper_mark, tukey};
use crate::eval::Evaluation;
use crate::stages::STAGES;
use plotters::prelude::*;
use std::path::Path;

/// Writes the figure (one category per stage that any run has) to `path`; false when no run
/// has stage masks (nothing is written then).
pub fn plot(runs: &[(String, &Evaluation)], path: &Path) -> anyhow::Result<bool> {
    let stages: Vec<_> = STAGES
        .iter()
        .filter(|s| {
            runs.iter()
                .any(|(_, e)| e.segmentation.iter().any(|g| g.folder == s.folder))
        })
        .collect();
    if stages.is_empty() {
        return Ok(false);
    }
    let labels: Vec<String> = stages.iter().map(|s| s.name.to_owned()).collect();
    let root = BitMapBackend::new(path, (400 + 250 * labels.len() as u32, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let title = "IoU against the ground-truth masks (red: paper's median)";
    let mut chart = category_chart(&root, title, &labels, 0.0..1.0, "IoU")?;
    let width = 0.7 / runs.len().max(1) as f64;
    for (i, stage) in stages.iter().enumerate() {
        for (j, ((label, evaluation), color)) in runs.iter().zip(RUNS.iter().cycle()).enumerate() {
            let x = i as f64 - 0.35 + width * (j as f64 + 0.5);
            let Some(scores) = evaluation
                .segmentation
                .iter()
                .find(|g| g.folder == stage.folder)
            else {
                continue;
            };
            let values: Vec<f64> = scores.ious.iter().map(|f| f.iou).collect();
            if let Some(t) = tukey(&values) {
                draw_box(&mut chart, x, width * 0.8, &t, *color, 1.0)?;
            }
            if i == 0 {
                let color = *color;
                chart
                    .draw_series([Rectangle::new([(x, 0.0), (x, 0.0)], color)])?
                    .label(label.as_str())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled())
                    });
            }
        }
        if let Some(paper) = stage.paper {
            draw_paper_mark(&mut chart, i as f64, 0.8, paper.median)?;
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .label_font((super::font::FAMILY, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(true)
}
