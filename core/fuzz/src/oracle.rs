//! The invariants of a frame result, checked after every frame (the same properties as
//! `tests/core_properties.rs`): a capacity status names its capacity; a pose is finite, in front
//! of the camera, with its angles in range; the masks are the chip's size.

use imade_core::{ChipView, FrameResult, Pipeline, Status};

/// Panics (a fuzzing finding) when `result`, just returned by `pipeline` for `chip`, breaks an
/// invariant.
pub fn check<const R: usize, const L: usize>(
    pipeline: &Pipeline<R, L>,
    chip: &ChipView,
    result: &FrameResult,
) {
    assert_eq!(
        result.status == Status::Capacity,
        result.capacity.is_some(),
        "{result:?}"
    );
    if result.status != Status::Ok {
        return;
    }
    let p = &result.pose;
    let mut values = vec![
        p.tx_m,
        p.ty_m,
        p.tz_m,
        p.pitch_deg,
        p.yaw_deg,
        result.pitch_alt_deg,
        result.yaw_alt_deg,
        result.image_range_m,
    ];
    values.extend(result.roll_deg);
    let s = result.silhouette.expect("an ok result has its silhouette");
    values.extend([
        s.axis.centre.0,
        s.axis.centre.1,
        s.axis.dir.0,
        s.axis.dir.1,
        s.nose_t,
        s.tail_t,
        s.diameter_px,
        s.contrast,
        s.sigma_px,
        s.nose_evidence,
    ]);
    if let Some(m) = result.matched {
        values.extend([
            m.tilt_deg,
            m.roll_deg,
            m.roll_confidence,
            m.px_per_d,
            m.origin_t,
        ]);
    }
    assert!(values.iter().all(|v| v.is_finite()), "{result:?}");
    assert!(p.tz_m > 0.0, "{result:?}");
    for (pitch, yaw) in [
        (p.pitch_deg, p.yaw_deg),
        (result.pitch_alt_deg, result.yaw_alt_deg),
    ] {
        assert!((-90.0..=90.0).contains(&pitch), "{result:?}");
        assert!((-180.0..=180.0).contains(&yaw), "{result:?}");
    }
    let (w, h) = (chip.width(), chip.height());
    let mask = pipeline.mask();
    assert_eq!((mask.width(), mask.height()), (w, h));
    assert!(mask.count() <= w * h);
    let prior = pipeline.prior();
    if prior.count() > 0 {
        assert_eq!((prior.width(), prior.height()), (w, h));
        assert!(prior.count() <= w * h);
    }
}
