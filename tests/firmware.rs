//! The firmware on an emulated Cortex-M4F (QEMU mps2-an386) gives the host's results, bit for
//! bit, with the bundled reference model and with a model built from another projectile's mesh.
//! A clip is packed by the host library and run through `firmware-sim/run` (which installs and
//! builds what is missing, see docs/firmware.md; with a model file it builds the firmware with
//! that file in flash), then compared with two independent host runs:
//!
//! - `imade run` (its library) on the clip folder, with the same model and silhouette table:
//!   the results CSVs must be byte-identical (same status and the same printed pose in every
//!   row);
//! - the host's pipeline replaying the same packed bytes: every frame's whole result, floats at
//!   full precision (shortest round-trip `Debug` form), must be identical, i.e. tolerance zero.
//!
//! It also checks that `report.json` holds the five figures, and, in the firmware's default
//! configuration (without the grey-level fit), that the memory budgets hold.

use anyhow::{Context, anyhow, ensure};
use imade_core::Pipeline;
use imade_host::pack::pack_clip;
use imade_host::run::{PolarityArg, RangeArg, RunArgs, run};
use imade_pack::{TableUse, read_header, read_record, replay};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn firmware_results_equal_the_hosts() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware-small-known-range");
    check_firmware(
        &root().join("fixtures/small-known-range"),
        RangeArg::Auto,
        "bundled",
        &dir,
    )
}

/// With the grey-level fit (`firmware-sim/run --grey-fit`, `imade run`'s default), on the
/// first three frames of the clip without its range (the fit is some 1 G instructions a frame
/// there on the M4F): the fit gives the host's results bit for bit.
#[test]
fn firmware_runs_the_grey_level_fit_as_the_host() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware-grey-fit");
    if dir.exists() {
        std::fs::remove_dir_all(&dir)?;
    }
    let clip = first_frames(
        &root().join("fixtures/small-unknown-range"),
        3,
        &dir.join("clip"),
    )?;
    let case = Case {
        range: RangeArg::Ignore,
        lut: "bundled",
        grey_fit: true,
    };
    let (_, report) = check(&clip, &case, &dir.join("run"))?;
    eprintln!(
        "grey-level fit on the firmware: median {} instructions a frame, stack peak {} B",
        report["instructions_per_frame_median"], report["stack_peak_bytes"]
    );
    Ok(())
}

/// A copy of `clip` in `dir` with only its first `n` frame rows.
fn first_frames(clip: &Path, n: usize, dir: &Path) -> anyhow::Result<PathBuf> {
    imade_tests::copy_clip(clip, dir);
    let frames = std::fs::read_to_string(clip.join("frames.csv"))?;
    let kept: Vec<&str> = frames.lines().take(n + 1).collect();
    std::fs::write(dir.join("frames.csv"), kept.join("\n") + "\n")?;
    Ok(dir.to_path_buf())
}

/// Without the range sensor, with the mount's pointing: the flight filter gives the range on
/// the firmware as on the host.
#[test]
fn firmware_flies_the_flight_filter_as_the_host() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware-small-unknown-range");
    check_firmware(
        &root().join("fixtures/small-unknown-range"),
        RangeArg::Ignore,
        "bundled",
        &dir,
    )
}

/// A projectile other than the reference, its model built from its mesh (`imade model mesh`,
/// then `imade model build --mesh`), runs on the firmware from flash as on the host.
#[test]
fn firmware_runs_a_model_built_from_a_mesh() -> anyhow::Result<()> {
    let id = "sixfin-1000x70";
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware-sixfin");
    if dir.exists() {
        std::fs::remove_dir_all(&dir)?;
    }
    std::fs::create_dir_all(&dir)?;
    let model = imade_tests::shape_model(&dir, id);
    let lut = model.to_str().context("a UTF-8 path")?;
    check_firmware(
        &root().join(format!("fixtures/small-{id}")),
        RangeArg::Auto,
        lut,
        &dir.join("run"),
    )
}

/// How a clip is run: its range used as `range` says, the model choice `lut` (`bundled` or a
/// model file), with the grey-level fit or not.
struct Case<'a> {
    range: RangeArg,
    lut: &'a str,
    grey_fit: bool,
}

/// Runs the 20-frame `clip` in the firmware's default configuration (without the grey-level
/// fit), on the firmware and on the host, in `dir`, compares them, and checks the memory
/// budgets.
fn check_firmware(clip: &Path, range: RangeArg, lut: &str, dir: &Path) -> anyhow::Result<()> {
    let case = Case {
        range,
        lut,
        grey_fit: false,
    };
    let (rows, report) = check(clip, &case, dir)?;
    assert_eq!(rows, 20, "20 frame rows");
    // The memory budgets hold (the instruction budget is an open issue): a pipeline moved on
    // the stack once cost 80 KB and went over unnoticed.
    let ram = report["static_ram_bytes"].as_u64().unwrap_or(u64::MAX);
    let stack = report["stack_peak_bytes"].as_u64().unwrap_or(u64::MAX);
    assert!(
        ram + stack <= 192 * 1024,
        "static RAM {ram} B + stack peak {stack} B over 192 KiB"
    );
    let flash = report["flash_bytes"].as_u64().unwrap_or(u64::MAX);
    assert!(flash <= 1024 * 1024, "flash {flash} B over 1 MiB");
    Ok(())
}

/// Runs `clip` as `case` says on the firmware and on the host, in `dir`, compares them (results
/// and outcomes, at least half the rows with a pose), checks that `report.json` has its
/// figures, and returns the number of frame rows and the report.
fn check(clip: &Path, case: &Case, dir: &Path) -> anyhow::Result<(usize, serde_json::Value)> {
    let clip = clip.to_path_buf();
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    let host_dir = dir.join("host");
    let lut = case.lut;
    run(&RunArgs {
        lut: lut.into(),
        no_grey_fit: !case.grey_fit,
        polarity: PolarityArg::default(),
        ..imade_tests::run_args(&clip, case.range, &host_dir)
    })?;
    let host_csv = host_dir.join("results.csv");
    let packed = dir.join("clip.pack");
    pack_clip(&clip, &packed, case.range, lut, case.grey_fit)?;

    let out = dir.join("firmware");
    let status = Command::new(root().join("firmware-sim/run"))
        .arg(&packed)
        .arg("--lut")
        .arg(lut)
        .arg("--out")
        .arg(&out)
        .status()
        .context("starting firmware-sim/run")?;
    ensure!(status.success(), "firmware-sim/run failed: {status}");

    let host = std::fs::read_to_string(&host_csv)?;
    let firmware = std::fs::read_to_string(out.join("results.csv"))?;
    assert_same_lines(&host, &firmware, "results.csv");
    let rows = host.lines().count().saturating_sub(1);
    let poses = host.lines().filter(|l| l.contains(",ok,")).count();
    assert!(
        2 * poses >= rows && poses > 0,
        "the comparison should cover poses, not only failures: {poses} ok rows of {rows}"
    );

    let expected = host_outcomes(&std::fs::read(&packed)?, lut)?.join("\n");
    let outcomes = std::fs::read_to_string(out.join("outcomes.txt"))?;
    assert_same_lines(&expected, &outcomes, "outcomes.txt");

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json"))?)?;
    for key in [
        "flash_bytes",
        "static_ram_bytes",
        "stack_peak_bytes",
        "instructions_per_frame_median",
        "instructions_per_frame_max",
    ] {
        let value = report[key].as_u64().unwrap_or(0);
        assert!(value > 0, "report.json: {key} is {}", report[key]);
    }
    Ok((rows, report))
}

/// Every frame's outcome in `Debug` form, from the host's pipeline replaying the packed clip
/// with the model choice `lut`.
fn host_outcomes(mut packed: &[u8], lut: &str) -> anyhow::Result<Vec<String>> {
    let header = read_header(&mut packed).map_err(|e| anyhow!("{e:?}"))?;
    ensure!(
        header.table == TableUse::Bundled,
        "the clip should use its model file's table"
    );
    let file = (lut != "bundled").then(|| Path::new(lut));
    let model = imade_host::model::for_clip(&header.projectile, file)?;
    let table = model.table().context("no table in the model file")?;
    let mut pipeline: Box<Pipeline> =
        Box::new(Pipeline::new(header.config(), header.camera, model).with_table(table));
    if let Some(station) = header.world {
        pipeline.set_station(station);
    }
    let mut chip = vec![0u16; imade_core::capacity::MAX_CHIP_PIXELS];
    (0..header.records)
        .map(|_| {
            let record = read_record(&mut packed, &mut chip).map_err(|e| anyhow!("{e:?}"))?;
            let outcome = replay(&record, &chip, |frame| pipeline.process(frame));
            Ok(format!("{outcome:?}"))
        })
        .collect()
}

/// Asserts line by line that `got` equals `expected`, naming the first differing line.
fn assert_same_lines(expected: &str, got: &str, what: &str) {
    for (i, (e, g)) in expected.lines().zip(got.lines()).enumerate() {
        assert_eq!(g, e, "{what}: line {} differs (firmware, host)", i + 1);
    }
    assert_eq!(
        got.lines().count(),
        expected.lines().count(),
        "{what}: line counts differ"
    );
}
