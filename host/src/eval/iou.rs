//! Segmentation IoU of each stage (crate::stages) against the clip's ground-truth masks, from the
//! stage masks saved beside a results file (`imade run --save-masks`).

use super::paper::PaperIou;
use super::stats::{BoxStats, box_stats};
use crate::clip::{Clip, load_mask};
use crate::stages::{MaskStage, STAGES, mask_file_name};
use anyhow::{Context, bail};
use serde::Serialize;
use std::path::Path;

/// One frame's IoU.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameIou {
    /// Frame number.
    pub frame: u64,
    /// Intersection over union with the ground-truth mask (0 where the stage gave no mask).
    pub iou: f64,
}

/// The IoU statistics of one stage.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageIou {
    /// The stage's name.
    pub stage: &'static str,
    /// Its mask folder beside the results.
    pub folder: &'static str,
    /// Frames with a ground-truth mask.
    pub frames: usize,
    /// Of those, frames without a mask of this stage (scored 0).
    pub missing: usize,
    /// Box statistics of the IoU over all frames with a ground-truth mask.
    pub stats: Option<BoxStats>,
    /// The paper's counterpart.
    pub paper: Option<PaperIou>,
    /// Per-frame IoU.
    pub ious: Vec<FrameIou>,
}

/// Intersection over union of two equally sized masks (1 when both are empty).
pub fn iou(a: &[bool], b: &[bool]) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (&x, &y) in a.iter().zip(b) {
        both += usize::from(x && y);
        either += usize::from(x || y);
    }
    if either == 0 {
        1.0
    } else {
        both as f64 / either as f64
    }
}

/// True when `dir` holds at least one PNG.
fn has_masks(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .filter_map(Result::ok)
            .any(|e| e.path().extension().is_some_and(|x| x == "png"))
    })
}

/// Scores every stage that has masks in `results_dir`; stages without any are left out.
pub fn evaluate(clip: &Clip, results_dir: &Path) -> anyhow::Result<Vec<StageIou>> {
    let truth: Vec<(u64, &str)> = clip
        .frames
        .iter()
        .filter_map(|f| f.as_ref().ok())
        .filter_map(|row| Some((row.frame, row.gt_mask.as_deref()?)))
        .collect();
    STAGES
        .iter()
        .filter(|stage| has_masks(&results_dir.join(stage.folder)))
        .map(|stage| evaluate_stage(clip, stage, &truth, results_dir))
        .collect()
}

fn evaluate_stage(
    clip: &Clip,
    stage: &MaskStage,
    truth: &[(u64, &str)],
    results_dir: &Path,
) -> anyhow::Result<StageIou> {
    let dir = results_dir.join(stage.folder);
    let mut ious = Vec::with_capacity(truth.len());
    let mut missing = 0;
    for &(frame, gt_path) in truth {
        let path = dir.join(mask_file_name(frame));
        let value = if path.is_file() {
            let gt_path = clip
                .resolve(gt_path)
                .with_context(|| format!("ground-truth mask of frame {frame}"))?;
            let (gw, gh, gt) = load_mask(&gt_path)?;
            let (w, h, mask) = load_mask(&path)?;
            if (w, h) != (gw, gh) {
                bail!(
                    "{} is {w}x{h} but the ground truth {} is {gw}x{gh}",
                    path.display(),
                    gt_path.display()
                );
            }
            iou(&mask, &gt)
        } else {
            missing += 1;
            0.0
        };
        ious.push(FrameIou { frame, iou: value });
    }
    Ok(StageIou {
        stage: stage.name,
        folder: stage.folder,
        frames: truth.len(),
        missing,
        stats: box_stats(&ious.iter().map(|f| f.iou).collect::<Vec<_>>()),
        paper: stage.paper,
        ious,
    })
}

#[cfg(test)]
mod tests {
    use super::iou;

    #[test]
    fn iou_counts_overlap_over_union() {
        let a = [true, true, false, false];
        let b = [false, true, true, false];
        assert!((iou(&a, &b) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(iou(&a, &a), 1.0);
        assert_eq!(iou(&[false; 4], &a), 0.0);
    }
}
