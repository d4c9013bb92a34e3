//! The source paper's published accuracy figures (the paper is cited in `README.md`), the yard
//! stick of `imade eval`. Pose figures are "about" values of its abstract and Sec. 5.5, normalized
//! to 1 km like ours; the IoU figures are the medians it quotes in Sec. 5.4.1 (Fig. 19).

use serde::Serialize;

/// Whether the range to the target was known (from a range sensor) or measured from the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RangeCase {
    /// Tz from a range sensor (the paper's Fig. 16, Fig. 23).
    Known,
    /// Tz from the image (the paper's Fig. 15, Fig. 22).
    Unknown,
}

impl RangeCase {
    /// Name used in tables.
    pub fn label(self) -> &'static str {
        match self {
            RangeCase::Known => "known range",
            RangeCase::Unknown => "unknown range",
        }
    }
}

/// A pose parameter whose error is reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Parameter {
    /// Tx, m/km.
    Tx,
    /// Ty, m/km.
    Ty,
    /// Tz, m/km.
    Tz,
    /// Pitch of the chosen candidate, deg/km.
    Pitch,
    /// Yaw of the chosen candidate, deg/km.
    Yaw,
    /// Yaw of the better of the two candidates, deg/km.
    YawBest,
}

impl Parameter {
    /// Every parameter, in table order.
    pub const ALL: [Parameter; 6] = [
        Parameter::Tx,
        Parameter::Ty,
        Parameter::Tz,
        Parameter::Pitch,
        Parameter::Yaw,
        Parameter::YawBest,
    ];

    /// Name used in tables and plots.
    pub fn label(self) -> &'static str {
        match self {
            Parameter::Tx => "Tx",
            Parameter::Ty => "Ty",
            Parameter::Tz => "Tz",
            Parameter::Pitch => "pitch",
            Parameter::Yaw => "yaw (chosen)",
            Parameter::YawBest => "yaw (best of two)",
        }
    }

    /// Unit of the 1-km-normalized error.
    pub fn unit(self) -> &'static str {
        match self {
            Parameter::Tx | Parameter::Ty | Parameter::Tz => "m/km",
            _ => "deg/km",
        }
    }
}

/// The paper's 1-km-normalized accuracy of a parameter in a range case, where it published one:
/// unknown range: Tz about 50 m, in-plane location about 0.15 m, pitch about 6 deg, yaw ambiguous
/// (not given); known range: in-plane about 0.15 m (Sec. 5.5.2: all methods under 0.2 m), pitch
/// about 3 deg, yaw about 20 deg (Tz is the given range).
pub fn pose_accuracy(case: RangeCase, parameter: Parameter) -> Option<f64> {
    match (case, parameter) {
        (_, Parameter::Tx | Parameter::Ty) => Some(0.15),
        (RangeCase::Unknown, Parameter::Tz) => Some(50.0),
        (RangeCase::Unknown, Parameter::Pitch) => Some(6.0),
        (RangeCase::Known, Parameter::Pitch) => Some(3.0),
        (RangeCase::Known, Parameter::Yaw) => Some(20.0),
        _ => None,
    }
}

/// A published IoU figure of a segmentation method.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PaperIou {
    /// The paper's method.
    pub method: &'static str,
    /// Its median IoU against the ground-truth masks.
    pub median: f64,
}

/// Mask R-CNN, the paper's blind segmentation: median IoU 0.64 (Sec. 5.4.1).
pub const IOU_MASK_RCNN: PaperIou = PaperIou {
    method: "Mask R-CNN",
    median: 0.64,
};

/// The shape prior rendered at the estimated pose: median "about 0.6" (Sec. 5.4.1, Fig. 19).
pub const IOU_SHAPE_PRIOR: PaperIou = PaperIou {
    method: "shape prior",
    median: 0.6,
};
