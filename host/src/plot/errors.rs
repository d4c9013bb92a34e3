//! 1-km-normalized pose errors per run, one panel per parameter, like the paper's Fig. 22
//! (unknown range) and Fig. 23 (known range); the paper's figure for each run's case in red.

use super::boxes::{RUNS, category_chart, draw_box, draw_paper_mark, tukey};
use crate::eval::Evaluation;
use crate::eval::paper::{Parameter, pose_accuracy};
use plotters::prelude::*;
use std::path::Path;

/// Writes the figure (1500 x 900 px) to `path`.
pub fn plot(runs: &[(String, &Evaluation)], path: &Path) -> anyhow::Result<()> {
    let labels: Vec<String> = runs.iter().map(|(l, _)| l.clone()).collect();
    let root = BitMapBackend::new(path, (1500, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        "Pose errors normalized to 1 km (red: the paper's accuracy)",
        (super::font::FAMILY, 26),
    )?;
    for (area, parameter) in root.split_evenly((2, 3)).iter().zip(Parameter::ALL) {
        let samples: Vec<Vec<f64>> = runs
            .iter()
            .map(|(_, e)| e.pose.frames.iter().map(|f| f.get(parameter)).collect())
            .collect();
        let boxes: Vec<_> = samples.iter().map(|s| tukey(s)).collect();
        let papers: Vec<Option<f64>> = runs
            .iter()
            .map(|(_, e)| pose_accuracy(e.pose.case, parameter))
            .collect();
        let top = boxes
            .iter()
            .flatten()
            .map(|t| t.high)
            .chain(papers.iter().flatten().copied())
            .fold(0.0, f64::max);
        let top = if top > 0.0 { top * 1.15 } else { 1.0 };
        let title = format!("{} ({})", parameter.label(), parameter.unit());
        let mut chart = category_chart(area, &title, &labels, 0.0..top, parameter.unit())?;
        for (i, (t, color)) in boxes.iter().zip(RUNS.iter().cycle()).enumerate() {
            if let Some(t) = t {
                draw_box(&mut chart, i as f64, 0.5, t, *color, top)?;
            }
        }
        for (i, paper) in papers.iter().enumerate() {
            if let Some(y) = paper {
                draw_paper_mark(&mut chart, i as f64, 0.7, *y)?;
            }
        }
    }
    root.present()?;
    Ok(())
}
