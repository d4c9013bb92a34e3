//! `imade demo` end to end on the bundled small known-range clip: both runs, the report against
//! the paper, the evaluation files and every figure.

use std::process::Command;

const CLIP: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/small-known-range");

#[test]
fn demo_runs_scores_and_plots_both_range_cases() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .args(["demo", CLIP, "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    // The table has both cases beside the paper's figures and the IoU of the saved masks.
    assert!(stdout.contains("known range median") && stdout.contains("unknown range median"));
    assert!(stdout.contains("| Tz | m/km |") && stdout.contains("50.00"));
    assert!(
        stdout.contains("| known range | blind segmentation | 20 |"),
        "{stdout}"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(stdout.starts_with(&report));
    for run in ["known-range", "unknown-range"] {
        let results = std::fs::read_to_string(out.join(run).join("results.csv")).unwrap();
        assert_eq!(results.lines().count(), 21);
        let eval: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(run).join("eval.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(eval["pose"]["frames_with_truth"], 20);
    }
    // Known range: every frame with a pose used the sensor's range; unknown: none did.
    let known = std::fs::read_to_string(out.join("known-range/results.csv")).unwrap();
    let unknown = std::fs::read_to_string(out.join("unknown-range/results.csv")).unwrap();
    let range_used = |text: &str| {
        text.lines()
            .skip(1)
            .filter(|l| l.split(',').nth(1) == Some("ok"))
            .map(|l| l.split(',').nth(9) == Some("true"))
            .collect::<Vec<_>>()
    };
    assert!(range_used(&known).iter().all(|&u| u) && !range_used(&known).is_empty());
    assert!(range_used(&unknown).iter().all(|&u| !u));
    for (name, size) in [
        ("pose-known-range.png", (1500, 900)),
        ("pose-unknown-range.png", (1500, 900)),
        ("errors.png", (1500, 900)),
        ("overlays-known-range.png", (1280, 640)),
    ] {
        let image = image::open(out.join("plots").join(name)).unwrap();
        assert_eq!((image.width(), image.height()), size, "{name}");
        // Drawn on: far from a blank page.
        let rgb = image.to_rgb8();
        let inked = rgb.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(inked > rgb.len() / 3 / 50, "{name} is nearly blank");
    }
    assert!(out.join("plots/iou.png").is_file());
}
