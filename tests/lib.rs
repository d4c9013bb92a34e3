//! Shared helpers of the cross-crate integration tests (the tests are the `[[test]]` targets).
//!
//! [`render`] is an exact ray-casting renderer of `ref-1378x80`, written from `docs/projectile.md`
//! and `docs/geometry.md` in f64 without any code of the core, so that the core's estimates are
//! checked against an independent truth.

pub mod render;

use imade_core::lut::table::Table;
use imade_core::{Camera, ProjectileModel};
use proptest::test_runner::{Config as ProptestConfig, RngSeed};
use render::Intrinsics;
use std::path::{Path, PathBuf};

/// The telescope of the tests' rendered chips (and of the fixtures): fx = fy = 100000 px, principal
/// point at the centre of a 2048 x 2048 frame.
pub const TELESCOPE: Intrinsics = Intrinsics {
    fx: 100000.0,
    fy: 100000.0,
    cx: 1023.5,
    cy: 1023.5,
};

/// The settings of the workspace's property tests: `cases` cases drawn from a fixed seed, so that
/// every run (CI's among them) checks the same cases and a failure is a change, not a draw.
/// `PROPTEST_RNG_SEED=<n>` draws other cases.
pub fn proptest_config(cases: u32) -> ProptestConfig {
    let config = ProptestConfig::with_cases(cases);
    if std::env::var_os("PROPTEST_RNG_SEED").is_some() {
        return config;
    }
    ProptestConfig {
        rng_seed: RngSeed::Fixed(PROPTEST_SEED),
        ..config
    }
}

/// The property tests' fixed seed ([`proptest_config`]).
const PROPTEST_SEED: u64 = 20261202;

/// The core's camera for the renderer's intrinsics.
pub fn core_camera(intrinsics: &Intrinsics) -> Camera {
    Camera {
        fx: intrinsics.fx as f32,
        fy: intrinsics.fy as f32,
        cx: intrinsics.cx as f32,
        cy: intrinsics.cy as f32,
    }
}

/// The bundled model file of the reference projectile `ref-1378x80`, validated.
pub fn reference_model() -> ProjectileModel<'static> {
    static BYTES: &[u8] = include_bytes!("../fixtures/models/ref-1378x80.model");
    ProjectileModel::parse(BYTES).expect("the bundled reference model is valid")
}

/// The silhouette table the reference projectile's model file carries.
pub fn bundled_table() -> Table<'static> {
    reference_model()
        .table()
        .expect("the reference model carries its table")
}

/// TETRIS's bundled weights (`fixtures/tetris/tetris.weights`), validated.
pub fn bundled_tetris() -> imade_core::shape_guided::TetrisWeights<'static> {
    imade_host::tetris_weights::load(&imade_host::tetris_weights::bundled_path())
        .expect("the bundled TETRIS weights validate")
}

/// `imade run`'s arguments for `clip` alone into `out` with the range use `range`, the rest as
/// the command line's defaults give them (the bundled model, no masks, no shape-guided loop,
/// the motion model, causal, the grey-level fit on); a test changes what it varies.
pub fn run_args(
    clip: &Path,
    range: imade_host::run::RangeArg,
    out: &Path,
) -> imade_host::run::RunArgs {
    imade_host::run::RunArgs {
        clips: vec![clip.to_path_buf()],
        out: out.to_path_buf(),
        range,
        save_masks: false,
        lut: "bundled".to_owned(),
        refine: imade_host::run::RefineChoice(None),
        tetris: None,
        range_smoothing: imade_host::run::SmoothingArg::default(),
        smooth: false,
        no_grey_fit: false,
        polarity: imade_host::run::PolarityArg::default(),
    }
}

/// Runs `clip` through `imade run` (its library) into `out`, with the model choice `lut`
/// (`bundled` or a model file), the range use `range` and, with `save_masks`, the stage masks,
/// and evaluates the results against the clip's truth (`imade eval`).
pub fn run_and_evaluate(
    clip: &Path,
    lut: &str,
    range: imade_host::run::RangeArg,
    save_masks: bool,
    out: &Path,
) -> imade_host::eval::Evaluation {
    evaluate_run(imade_host::run::RunArgs {
        save_masks,
        lut: lut.to_owned(),
        ..run_args(clip, range, out)
    })
}

/// Runs `imade run` (its library) with `args` of one clip and evaluates its results against the
/// clip's truth (`imade eval`).
pub fn evaluate_run(args: imade_host::run::RunArgs) -> imade_host::eval::Evaluation {
    imade_host::run::run(&args).expect("the run succeeds");
    imade_host::eval::evaluate(&args.clips[0], &args.out.join("results.csv"), &args.lut)
        .expect("the evaluation")
}

/// `imade model build --mesh MESH --diameter D --id ID` with the default table grid, into
/// `dir`; the model file's path.
pub fn model_from_mesh(mesh: &Path, id: &str, diameter_m: f64, dir: &Path) -> PathBuf {
    let out = dir.join(format!("{id}.model"));
    imade_host::model::command::build_command(&imade_host::model::command::BuildArgs {
        model: None,
        mesh: Some(mesh.to_path_buf()),
        mesh_scale: 1.0,
        diameter: Some(diameter_m),
        id: Some(id.into()),
        table: None,
        no_table: false,
        tilts: 91,
        rolls: None,
        stations: 96,
        out: out.clone(),
    })
    .unwrap_or_else(|e| panic!("{id}: {e:#}"));
    out
}

/// The model file of the simulator's shape `id`, built in `dir` from its bundled mesh
/// (`fixtures/meshes/ID.obj`, what `imade model mesh --shape ID` writes) as a user would:
/// `imade model build --mesh` with its diameter.
pub fn shape_model(dir: &Path, id: &str) -> PathBuf {
    let mesh = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/meshes")
        .join(format!("{id}.obj"));
    let diameter_m = imade_host::sim::shapes::description(id)
        .expect("a built-in shape")
        .diameter_m;
    model_from_mesh(&mesh, id, diameter_m, dir)
}

/// A result's errors against the truth, normalized to 1 km (`docs/geometry.md`): Tx, Ty,
/// Tz in m/km; pitch, the chosen yaw and the better of the two yaw candidates in deg/km.
pub fn pose_errors(
    result: &imade_core::FrameResult,
    truth: &imade_host::clip::GroundTruth,
) -> [f64; 6] {
    let km = truth.tz_m / 1000.0;
    let p = result.pose;
    let angle = |a: f32, b: f64| imade_core::pose::wrap_deg(a - b as f32).abs() as f64 / km;
    let yaw = angle(p.yaw_deg, truth.yaw_deg);
    [
        (f64::from(p.tx_m) - truth.tx_m).abs() / km,
        (f64::from(p.ty_m) - truth.ty_m).abs() / km,
        (f64::from(p.tz_m) - truth.tz_m).abs() / km,
        angle(p.pitch_deg, truth.pitch_deg),
        yaw,
        yaw.min(angle(result.yaw_alt_deg, truth.yaw_deg)),
    ]
}

/// Copies the clip folder `from` (clip.json, frames.csv, chips/, masks/) to `to`, replacing
/// what was there.
pub fn copy_clip(from: &Path, to: &Path) {
    let _ = std::fs::remove_dir_all(to);
    for sub in ["chips", "masks"] {
        std::fs::create_dir_all(to.join(sub)).unwrap();
        for entry in std::fs::read_dir(from.join(sub)).unwrap() {
            let entry = entry.unwrap();
            std::fs::copy(entry.path(), to.join(sub).join(entry.file_name())).unwrap();
        }
    }
    for file in ["clip.json", "frames.csv"] {
        std::fs::copy(from.join(file), to.join(file)).unwrap();
    }
}
