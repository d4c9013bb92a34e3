//! The segmentation stages whose masks `imade run --save-masks` writes and `imade eval` scores.
//!
//! Each stage is one entry of [`STAGES`]: its name, the folder beside the results file where its
//! masks go (`<folder>/NNNNNN.png`, 8-bit, 0 or 255), how to read it from the pipeline after a
//! frame, and the source paper's counterpart. A new stage is one more entry here; run, eval
//! and plot pick it up.

use crate::eval::paper::{self, PaperIou};
use imade_core::{ChipMask, Pipeline};

/// One segmentation stage.
#[derive(Debug, Clone, Copy)]
pub struct MaskStage {
    /// Human-readable name (tables and plots).
    pub name: &'static str,
    /// Folder beside the results file that holds this stage's masks.
    pub folder: &'static str,
    /// The stage's mask of the last processed frame.
    pub mask: fn(&Pipeline) -> &ChipMask,
    /// The source paper's closest counterpart, where it published one.
    pub paper: Option<PaperIou>,
}

/// Folder of the blind segmentation's masks.
pub const MASKS_FOLDER: &str = "masks";
/// Folder of the shape priors.
pub const PRIORS_FOLDER: &str = "priors";
/// Folder of the shape-guided segmentations (`imade run --refine sis-cut|gvf-asm`).
pub const REFINED_FOLDER: &str = "refined";

/// Every stage, in pipeline order.
pub const STAGES: &[MaskStage] = &[
    MaskStage {
        name: "blind segmentation",
        folder: MASKS_FOLDER,
        mask: Pipeline::mask,
        paper: Some(paper::IOU_MASK_RCNN),
    },
    MaskStage {
        name: "shape prior",
        folder: PRIORS_FOLDER,
        mask: Pipeline::prior,
        paper: Some(paper::IOU_SHAPE_PRIOR),
    },
    MaskStage {
        name: "shape-guided segmentation",
        folder: REFINED_FOLDER,
        mask: Pipeline::guided_mask,
        // Fig. 19 gives no median for SIS-Cut or GVF-ASM, only that both fall below the prior.
        paper: None,
    },
];

/// The file name of frame `frame`'s mask inside a stage folder.
pub fn mask_file_name(frame: u64) -> String {
    format!("{frame:06}.png")
}
