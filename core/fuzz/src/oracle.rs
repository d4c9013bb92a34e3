//! The invariants of a frame result, checked after every frame: the result's own contract
//! (`FrameResult::check`, which `tests/core_properties.rs` holds too), and masks of the chip's
//! size.

use imade_core::{ChipView, FrameResult, Pipeline, Status};

/// Panics (a fuzzing finding) when `result`, just returned by `pipeline` for `chip`, breaks an
/// invariant.
pub fn check<const R: usize, const L: usize>(
    pipeline: &Pipeline<R, L>,
    chip: &ChipView,
    result: &FrameResult,
) {
    if let Err(fault) = result.check() {
        panic!("{fault:?}: {result:?}");
    }
    if result.status != Status::Ok {
        return;
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
