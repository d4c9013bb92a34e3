//! `imade train tetris` from a fixed seed, briefly: the loss falls, the weights it writes
//! validate in the core and warp perturbed priors closer to the true masks on chips of clips it
//! did not train on, and the same seed gives the same weights byte for byte.

use imade_core::shape_guided::TetrisWeights;
use imade_host::train::tetris::{TetrisArgs, run};

fn args(out: std::path::PathBuf) -> TetrisArgs {
    TetrisArgs {
        out,
        seed: 11,
        steps: 150,
        batch: 16,
        clips: 7,
        frames_per_clip: 4,
        validation_clips: 7,
        learning_rate: 2e-3,
    }
}

#[test]
fn a_brief_training_lowers_the_loss_and_is_repeatable() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let first = dir.path().join("first.weights");
    let report = run(&args(first.clone())).expect("training runs");
    let (start, end) = (report.mean_loss(true, 20), report.mean_loss(false, 20));
    println!(
        "{} chips, {} steps: loss {start:.4} -> {end:.4}; validation IoU {:.3} -> {:.3} over {} \
         samples; {:.1} s",
        report.chips,
        report.losses.len(),
        report.prior_iou,
        report.warped_iou,
        report.validated,
        report.seconds
    );
    assert_eq!(report.losses.len(), 150);
    assert!(
        end < 0.8 * start,
        "the loss fell only from {start} to {end}"
    );
    assert!(
        report.validated >= 10,
        "{} validation samples",
        report.validated
    );
    assert!(
        report.warped_iou > report.prior_iou,
        "warped {:.3} vs prior {:.3}",
        report.warped_iou,
        report.prior_iou
    );
    let bytes = std::fs::read(&first).expect("the weights were written");
    let weights = TetrisWeights::new_checked(&bytes).expect("the written weights validate");
    assert_eq!(weights.seed(), 11);
    for beside in ["first.weights.loss.csv", "first.weights.loss.png"] {
        assert!(
            dir.path().join(beside).is_file(),
            "{beside} was not written"
        );
    }
    let csv = std::fs::read_to_string(dir.path().join("first.weights.loss.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 151, "a header and one line a step");
    // The same seed again: the same weights.
    let second = dir.path().join("second.weights");
    run(&args(second.clone())).expect("training runs again");
    assert!(
        bytes == std::fs::read(&second).expect("written"),
        "the same seed gave other weights"
    );
}

#[test]
fn an_unwritable_output_is_refused_before_training() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let missing = run(&args(dir.path().join("missing").join("x.weights")));
    let error = format!("{:#}", missing.expect_err("no folder to write to"));
    assert!(error.contains("its folder must exist"), "{error}");
    assert!(
        run(&args(dir.path().to_path_buf())).is_err(),
        "a folder as the output"
    );
}
