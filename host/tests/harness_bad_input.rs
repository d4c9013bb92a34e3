//! `imade run` on clips with one defect each: the defect is reported with its file and line or
//! frame, the other frames are still processed, the exit code is the documented one, and nothing
//! panics. Each test copies the bundled `small-known-range` clip and breaks one thing.

use imade_host::summary::RunSummary;
use std::path::{Path, PathBuf};
use std::process::Command;

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/small-known-range");

/// A copy of the fixture clip in a temporary folder, and an output folder beside it.
struct Scratch {
    _dir: tempfile::TempDir,
    clip: PathBuf,
    out: PathBuf,
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

fn scratch() -> Scratch {
    let dir = tempfile::tempdir().unwrap();
    let clip = dir.path().join("clip");
    copy_dir(Path::new(FIXTURE), &clip);
    let out = dir.path().join("out");
    Scratch {
        _dir: dir,
        clip,
        out,
    }
}

/// The data lines of `frames.csv` (the header is line 1, so data line i is file line i + 2).
fn frames_lines(clip: &Path) -> Vec<String> {
    std::fs::read_to_string(clip.join("frames.csv"))
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect()
}

/// Replaces field `column` of file line `line` (1-based) of `frames.csv`.
fn set_field(clip: &Path, line: usize, column: usize, value: &str) {
    let mut lines = frames_lines(clip);
    let mut fields: Vec<String> = lines[line - 1].split(',').map(str::to_owned).collect();
    fields[column] = value.to_owned();
    lines[line - 1] = fields.join(",");
    std::fs::write(clip.join("frames.csv"), lines.join("\n") + "\n").unwrap();
}

/// The index of the `frames.csv` column named `name`.
fn column_of(clip: &Path, name: &str) -> usize {
    frames_lines(clip)[0]
        .split(',')
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

/// The frame number on file line `line` of the pristine fixture.
fn frame_on_line(line: usize) -> String {
    frames_lines(Path::new(FIXTURE))[line - 1]
        .split(',')
        .next()
        .unwrap()
        .to_owned()
}

struct Outcome {
    code: i32,
    stderr: String,
    statuses: Vec<(String, String)>,
}

fn run_imade(s: &Scratch) -> Outcome {
    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .arg("run")
        .arg(&s.clip)
        .arg("--out")
        .arg(&s.out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    let statuses = std::fs::read_to_string(s.out.join("results.csv"))
        .map(|text| {
            text.lines()
                .skip(1)
                .map(|l| {
                    let mut f = l.split(',');
                    let frame = f.next().unwrap_or_default().to_owned();
                    (frame, f.next().unwrap_or_default().to_owned())
                })
                .collect()
        })
        .unwrap_or_default();
    Outcome {
        code: output.status.code().unwrap(),
        stderr,
        statuses,
    }
}

/// Checks a run with exactly one unusable frame: exit code 3, one row per frame, the bad frame's
/// status, every other frame processed, and the message in stderr and summary.json.
fn assert_one_bad_frame(s: &Scratch, o: &Outcome, frame: &str, status: &str, needles: &[&str]) {
    assert_eq!(o.code, 3, "{}", o.stderr);
    assert_eq!(o.statuses.len(), frames_lines(&s.clip).len() - 1);
    let bad: Vec<_> = o.statuses.iter().filter(|(_, st)| st == status).collect();
    assert_eq!(bad.len(), 1, "{:?}", o.statuses);
    assert_eq!(bad[0].0, frame);
    // Every other frame went through the pipeline (whatever it made of it).
    let unusable = o
        .statuses
        .iter()
        .filter(|(_, st)| st == "bad_row" || st == "bad_chip");
    assert_eq!(unusable.count(), 1, "{:?}", o.statuses);
    let ok = o.statuses.iter().filter(|(_, st)| st == "ok").count();
    assert!(2 * ok > o.statuses.len(), "{:?}", o.statuses);
    for needle in needles {
        assert!(o.stderr.contains(needle), "{needle:?} not in {}", o.stderr);
    }
    let summary: RunSummary =
        serde_json::from_str(&std::fs::read_to_string(s.out.join("summary.json")).unwrap())
            .unwrap();
    let problems = &summary.clips[0].problems;
    assert_eq!(problems.len(), 1);
    assert!(needles.iter().all(|n| problems[0].message.contains(n)));
}

#[test]
fn a_missing_chip_is_that_frames_bad_chip() {
    let s = scratch();
    std::fs::remove_file(s.clip.join("chips/000046.png")).unwrap();
    let o = run_imade(&s);
    assert_one_bad_frame(
        &s,
        &o,
        "46",
        "bad_chip",
        &["chips/000046.png", "frame 46", "line 4"],
    );
}

#[test]
fn a_corrupt_chip_is_that_frames_bad_chip() {
    let s = scratch();
    let path = s.clip.join("chips/000046.png");
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let o = run_imade(&s);
    assert_one_bad_frame(&s, &o, "46", "bad_chip", &["chips/000046.png", "frame 46"]);
}

#[test]
fn a_chip_of_the_wrong_size_is_that_frames_bad_chip() {
    let s = scratch();
    image::GrayImage::new(200, 256)
        .save(s.clip.join("chips/000046.png"))
        .unwrap();
    let o = run_imade(&s);
    assert_one_bad_frame(&s, &o, "46", "bad_chip", &["chips/000046.png", "200x256"]);
}

#[test]
fn a_malformed_row_is_that_rows_bad_row() {
    let s = scratch();
    let frame = frame_on_line(5);
    set_field(&s.clip, 5, 3, "eleven");
    let o = run_imade(&s);
    assert_one_bad_frame(&s, &o, &frame, "bad_row", &["frames.csv line 5", "chip_x0"]);
}

#[test]
fn a_frame_number_that_does_not_increase_is_a_bad_row() {
    let s = scratch();
    let previous = frame_on_line(5);
    set_field(&s.clip, 6, 0, &previous);
    let o = run_imade(&s);
    assert_one_bad_frame(
        &s,
        &o,
        &previous,
        "bad_row",
        &["frames.csv line 6", "does not increase"],
    );
    // The rows keep the file's order: the repeated number is the sixth line's row.
    assert_eq!(o.statuses[4], (previous, "bad_row".to_owned()));
}

#[test]
fn a_nan_range_is_a_bad_row() {
    let s = scratch();
    let frame = frame_on_line(7);
    set_field(&s.clip, 7, 5, "NaN");
    let o = run_imade(&s);
    assert_one_bad_frame(&s, &o, &frame, "bad_row", &["frames.csv line 7", "range_m"]);
}

#[test]
fn a_negative_range_is_a_bad_row() {
    let s = scratch();
    let frame = frame_on_line(8);
    set_field(&s.clip, 8, 5, "-1100.5");
    let o = run_imade(&s);
    assert_one_bad_frame(&s, &o, &frame, "bad_row", &["frames.csv line 8", "range_m"]);
}

#[test]
fn a_mount_elevation_beyond_the_vertical_is_a_bad_row() {
    let s = scratch();
    let frame = frame_on_line(4);
    set_field(&s.clip, 4, column_of(&s.clip, "mount_el_deg"), "91.5");
    let o = run_imade(&s);
    assert_one_bad_frame(
        &s,
        &o,
        &frame,
        "bad_row",
        &["frames.csv line 4", "mount_el_deg must be within [-90, 90]"],
    );
}

/// Rewrites one key of `clip.json`.
fn set_meta(clip: &Path, key: &str, value: &str) {
    let path = clip.join("clip.json");
    let mut meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    meta[key] = serde_json::Value::String(value.to_owned());
    std::fs::write(&path, meta.to_string()).unwrap();
}

/// Runs a broken clip together with an intact one: the broken one is named, the intact one is
/// still processed, exit code 4.
fn assert_clip_rejected(s: &Scratch, needles: &[&str]) {
    let good = s.out.parent().unwrap().join("good");
    copy_dir(Path::new(FIXTURE), &good);
    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .arg("run")
        .arg(&s.clip)
        .arg(&good)
        .arg("--out")
        .arg(&s.out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(output.status.code(), Some(4), "{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
    }
    assert!(!s.out.join("clip/results.csv").exists());
    let results = std::fs::read_to_string(s.out.join("good/results.csv")).unwrap();
    assert_eq!(results.lines().count(), frames_lines(&good).len());
    let summary: RunSummary =
        serde_json::from_str(&std::fs::read_to_string(s.out.join("summary.json")).unwrap())
            .unwrap();
    assert!(summary.clips[0].error.is_some() && summary.clips[1].error.is_none());
}

#[test]
fn an_unknown_projectile_rejects_the_clip_and_the_others_run() {
    let s = scratch();
    set_meta(&s.clip, "projectile", "no-such-shell");
    assert_clip_rejected(&s, &["clip.json", "no-such-shell"]);
}

#[test]
fn a_clip_json_of_another_format_version_rejects_the_clip() {
    let s = scratch();
    set_meta(&s.clip, "format", "imade-clip/2");
    assert_clip_rejected(&s, &["clip.json", "imade-clip/2"]);
}

#[test]
fn an_intact_clip_exits_zero_quietly_with_masks_when_asked() {
    let s = scratch();
    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .args(["run", "--save-masks"])
        .arg(&s.clip)
        .arg("--out")
        .arg(&s.out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    // Piped: no progress bar, one line per clip.
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    let results = std::fs::read_to_string(s.out.join("results.csv")).unwrap();
    let ok: Vec<&str> = results
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(1) == Some("ok"))
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert!(!ok.is_empty());
    // Every frame with a pose has its mask, 8-bit, only 0 and 255, chip-sized.
    for frame in ok {
        let path = s
            .out
            .join(format!("masks/{:06}.png", frame.parse::<u64>().unwrap()));
        let mask = image::open(&path).unwrap();
        assert_eq!(mask.color(), image::ColorType::L8);
        assert_eq!((mask.width(), mask.height()), (256, 256));
        assert!(
            mask.to_luma8()
                .pixels()
                .all(|p| p.0[0] == 0 || p.0[0] == 255)
        );
    }
}

/// The results rows of `out/results.csv` by frame number (the whole line).
fn result_lines(out: &Path) -> Vec<(String, String)> {
    std::fs::read_to_string(out.join("results.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| (l.split(',').next().unwrap().to_owned(), l.to_owned()))
        .collect()
}

/// Every file and folder under `dir`, relative to it, sorted.
fn tree(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, dir: &Path, into: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            into.push(path.strip_prefix(root).unwrap().to_path_buf());
            if path.is_dir() && !path.is_symlink() {
                walk(root, &path, into);
            }
        }
    }
    let mut paths = Vec::new();
    walk(dir, dir, &mut paths);
    paths.sort();
    paths
}

#[cfg(unix)]
#[test]
fn paths_outside_the_clip_folder_are_refused_and_the_other_frames_run() {
    let s = scratch();
    let scratch_dir = s.clip.parent().unwrap().to_path_buf();
    // Valid PNGs outside the clip folder: a chip of the right size and a mask, so that only the
    // containment check can refuse them.
    let outside_chip = scratch_dir.join("outside.png");
    std::fs::copy(s.clip.join("chips/000054.png"), &outside_chip).unwrap();
    std::fs::copy(
        s.clip.join("masks/000078.png"),
        scratch_dir.join("outside-mask.png"),
    )
    .unwrap();
    let frames: Vec<String> = (3..=8).map(frame_on_line).collect();
    set_field(&s.clip, 3, 2, "../../../../etc/passwd");
    set_field(&s.clip, 4, 2, "/etc/hostname");
    // The chip path is the usual one, but the file is a symbolic link out of the folder.
    std::fs::remove_file(s.clip.join("chips/000054.png")).unwrap();
    std::os::unix::fs::symlink(&outside_chip, s.clip.join("chips/000054.png")).unwrap();
    set_field(&s.clip, 6, 2, "chips/../../outside.png");
    set_field(&s.clip, 7, 2, outside_chip.to_str().unwrap());
    // `imade run` does not read the ground-truth masks; `imade eval` refuses this one.
    set_field(
        &s.clip,
        8,
        column_of(&s.clip, "gt_mask"),
        "../outside-mask.png",
    );
    let clip_before = tree(&s.clip);

    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .args(["run", "--save-masks"])
        .arg(&s.clip)
        .arg("--out")
        .arg(&s.out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(output.status.code(), Some(3), "{stderr}");

    let bad = &frames[..5];
    let rows = result_lines(&s.out);
    assert_eq!(rows.len(), frames_lines(&s.clip).len() - 1);
    for (frame, line) in &rows {
        let status = line.split(',').nth(1).unwrap();
        if bad.contains(frame) {
            assert_eq!(status, "bad_chip", "{line}");
        } else {
            assert_ne!(status, "bad_chip", "{line}");
            assert_ne!(status, "bad_row", "{line}");
        }
    }
    // Each refusal is reported, names its frame and says why, and nothing was decoded.
    let summary: RunSummary =
        serde_json::from_str(&std::fs::read_to_string(s.out.join("summary.json")).unwrap())
            .unwrap();
    let problems = &summary.clips[0].problems;
    assert_eq!(problems.len(), bad.len(), "{problems:?}");
    for (problem, frame) in problems.iter().zip(bad) {
        assert_eq!(problem.frame.map(|f| f.to_string()).as_ref(), Some(frame));
        assert!(
            problem.message.contains("outside the clip folder"),
            "{}",
            problem.message
        );
        assert!(!problem.message.contains("decoding"), "{}", problem.message);
        assert!(stderr.contains(&problem.message), "{stderr}");
    }
    assert!(problems[0].message.contains("../../../../etc/passwd"));
    assert!(problems[1].message.contains("/etc/hostname"));
    assert!(problems[2].message.contains("outside.png"));

    // The intact frames are as in a run where the refused frames' chips are merely missing (the
    // pipeline keeps state between frames, so that is the run to compare with): the same status,
    // mostly ok, and the same poses, the frame with the escaping mask included.
    let baseline = scratch();
    for line in 3..=7 {
        set_field(&baseline.clip, line, 2, "chips/missing.png");
    }
    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .arg("run")
        .arg(&baseline.clip)
        .arg("--out")
        .arg(&baseline.out)
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(3));
    assert_eq!(rows, result_lines(&baseline.out));
    let ok = rows.iter().filter(|(_, l)| l.contains(",ok,")).count();
    assert!(ok > (rows.len() - bad.len()) / 2, "{rows:?}");
    assert!(
        rows.iter()
            .any(|(f, l)| *f == frames[5] && l.contains(",ok,"))
    );

    // Nothing was written outside --out: the clip folder and the scratch folder are unchanged.
    assert_eq!(tree(&s.clip), clip_before);
    let mut top: Vec<_> = std::fs::read_dir(&scratch_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    top.sort();
    assert_eq!(top, ["clip", "out", "outside-mask.png", "outside.png"]);

    // `imade eval` reads the ground-truth masks: the escaping one is refused, named.
    let output = Command::new(env!("CARGO_BIN_EXE_imade"))
        .arg("eval")
        .arg(&s.clip)
        .arg("--results")
        .arg(s.out.join("results.csv"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    for needle in [
        "outside the clip folder",
        "../outside-mask.png",
        &format!("frame {}", frames[5]),
    ] {
        assert!(stderr.contains(needle), "{needle:?} not in {stderr}");
    }
    assert!(!s.out.join("eval.json").exists());
}
