//! Shared helpers of the cross-crate integration tests (the tests are the `[[test]]` targets).
//!
//! [`render`] is an exact ray-casting renderer of `ref-1378x80`, written from `docs/projectile.md`
//! and `docs/geometry.md` in f64 without any code of the core, so that the core's estimates are
//! checked against an independent truth.

pub mod render;

use imade_core::lut::table::Table;
use imade_core::{Camera, ProjectileModel};
use render::Intrinsics;

/// The telescope of the tests' rendered chips (and of the fixtures): fx = fy = 100000 px, principal
/// point at the centre of a 2048 x 2048 frame.
pub const TELESCOPE: Intrinsics = Intrinsics {
    fx: 100000.0,
    fy: 100000.0,
    cx: 1023.5,
    cy: 1023.5,
};

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
