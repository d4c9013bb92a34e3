//! Properties of every frame result, over random chips: any size up to 300 px a side, 8 or 16
//! bits, a sky with a gradient, noise, blobs of either polarity, and the projectile rendered by
//! the independent ray caster at a random pose, partly outside the chip or not; three frames
//! per case, so the temporal state is carried. For every result:
//!
//! - a capacity status names its capacity, and no other status does;
//! - the mask lies inside the chip: it has the chip's size and no bit outside it;
//! - an ok result is finite, in front of the camera, with pitch in [-90, 90] and yaw in
//!   [-180, 180] deg for both candidates.

use imade_core::{
    BodyPolarity, ChipView, Config, DetectConfig, FrameInput, FrameResult, Pipeline, Status,
};
use imade_tests::render::{ChipStyle, Rng, TruePose, chip_u8, project};
use imade_tests::{TELESCOPE, core_camera};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// One random chip's description.
#[derive(Debug, Clone)]
struct Scene {
    width: usize,
    height: usize,
    wide: bool,
    sky: f64,
    body: f64,
    gradient: (f64, f64),
    noise: f64,
    projectile: Option<Projectile>,
    blobs: Vec<Blob>,
    seed: u64,
    range_known: bool,
}

/// The projectile in the first frame.
#[derive(Debug, Clone)]
struct Projectile {
    /// Slant range, m.
    range: f64,
    /// Pitch, yaw, roll, deg.
    attitude: (f64, f64, f64),
    /// Offset of the body origin from the chip centre, px.
    offset: (i64, i64),
}

/// An ellipse of constant level added to the chip.
#[derive(Debug, Clone)]
struct Blob {
    /// Centre, px.
    centre: (f64, f64),
    /// Radii along x and y, px.
    radii: (f64, f64),
    /// Grey levels added (either sign).
    level: f64,
}

fn scene() -> impl Strategy<Value = Scene> {
    let projectile = (
        800.0..3000.0f64,
        (-60.0..60.0f64, -180.0..180.0f64, 0.0..90.0f64),
        (-60i64..60, -60i64..60),
    )
        .prop_map(|(range, attitude, offset)| Projectile {
            range,
            attitude,
            offset,
        });
    let blob = (
        (0.0..300.0f64, 0.0..300.0f64),
        (0.5..20.0f64, 0.5..20.0f64),
        -150.0..150.0f64,
    )
        .prop_map(|(centre, radii, level)| Blob {
            centre,
            radii,
            level,
        });
    (
        (1usize..=300, 1usize..=300, any::<bool>()),
        (0.0..255.0f64, 0.0..255.0f64),
        ((-0.3..0.3f64, -0.3..0.3f64), 0.0..20.0f64),
        proptest::option::weighted(0.8, projectile),
        proptest::collection::vec(blob, 0..5),
        (any::<u64>(), any::<bool>()),
    )
        .prop_map(
            |(
                (width, height, wide),
                (sky, body),
                (gradient, noise),
                projectile,
                blobs,
                (seed, range_known),
            )| {
                Scene {
                    width,
                    height,
                    wide,
                    sky,
                    body,
                    gradient,
                    noise,
                    projectile,
                    blobs,
                    seed,
                    range_known,
                }
            },
        )
}

impl Scene {
    /// The pose of the projectile in frame `k` (it moves 5 px and turns 1 deg a frame).
    fn pose(&self, k: usize) -> Option<TruePose> {
        let Projectile {
            range,
            attitude: (pitch, yaw, roll),
            ..
        } = *self.projectile.as_ref()?;
        Some(TruePose {
            t: [
                0.05 * k as f64 * range / 1000.0,
                0.0,
                range + 10.0 * k as f64,
            ],
            pitch_deg: pitch + k as f64,
            yaw_deg: yaw,
            roll_deg: roll,
        })
    }

    /// The chip of frame `k`: 8-bit samples (scaled to 16 bits when `wide`), and its origin.
    fn render(&self, k: usize) -> (Vec<u16>, (i64, i64)) {
        let style = ChipStyle {
            sky: self.sky,
            body: self.body,
            gradient: self.gradient,
            psf_sigma: 0.8,
            noise: self.noise,
        };
        let mut rng = Rng(self.seed.wrapping_add(k as u64));
        let (pixels, origin) = match self.pose(k) {
            Some(pose) => {
                let (u, v) = project(&TELESCOPE, &pose, [0.0; 3]);
                let (dx, dy) = self.projectile.as_ref().map_or((0, 0), |p| p.offset);
                let origin = (
                    u.round() as i64 - self.width as i64 / 2 + dx,
                    v.round() as i64 - self.height as i64 / 2 + dy,
                );
                let size = (self.width, self.height);
                (
                    chip_u8(&TELESCOPE, &pose, origin, size, &style, &mut rng).0,
                    origin,
                )
            }
            None => {
                let sky = (0..self.width * self.height).map(|i| {
                    let (x, y) = ((i % self.width) as f64, (i / self.width) as f64);
                    let v = style.sky + style.gradient.0 * x + style.gradient.1 * y;
                    (v + style.noise * rng.gaussian()).round().clamp(0.0, 255.0) as u8
                });
                (sky.collect(), (900, 900))
            }
        };
        let scale = if self.wide { 257.0 } else { 1.0 };
        let full = if self.wide { 65535.0 } else { 255.0 };
        let samples = pixels
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let (x, y) = ((i % self.width) as f64, (i / self.width) as f64);
                let blobs: f64 = self
                    .blobs
                    .iter()
                    .filter(|b| {
                        ((x - b.centre.0) / b.radii.0).powi(2)
                            + ((y - b.centre.1) / b.radii.1).powi(2)
                            <= 1.0
                    })
                    .map(|b| b.level)
                    .sum();
                ((f64::from(v) + blobs) * scale).round().clamp(0.0, full) as u16
            })
            .collect();
        (samples, origin)
    }
}

fn check(pipeline: &Pipeline, chip: &ChipView, r: &FrameResult) -> Result<(), TestCaseError> {
    prop_assert_eq!(r.check(), Ok(()), "{:?}", r);
    let mask = pipeline.mask();
    if r.status != Status::BadInput {
        prop_assert_eq!((mask.width(), mask.height()), (chip.width(), chip.height()));
    }
    let inside = (0..mask.height())
        .map(|y| (0..mask.width()).filter(|&x| mask.get(x, y)).count())
        .sum::<usize>();
    prop_assert_eq!(mask.count(), inside, "every set bit is a chip pixel");
    Ok(())
}

proptest! {
    #![proptest_config(imade_tests::proptest_config(96))]

    #[test]
    fn every_result_keeps_the_invariants(scene in scene(), polarity in 0usize..3) {
        let config = Config {
            detect: DetectConfig {
                polarity: [Some(BodyPolarity::Dark), Some(BodyPolarity::Bright), None][polarity],
                ..DetectConfig::DEFAULT
            },
            ..Config::DEFAULT
        };
        let mut pipeline: Box<Pipeline> = Box::new(Pipeline::new(config, core_camera(&TELESCOPE), imade_tests::reference_model()));
        for k in 0..3 {
            let (samples, origin) = scene.render(k);
            let (w, h) = (scene.width, scene.height);
            let bytes: Vec<u8>;
            let chip = if scene.wide {
                ChipView::gray16(&samples, w, h, w, origin.0 as i32, origin.1 as i32)
            } else {
                bytes = samples.iter().map(|&v| v as u8).collect();
                ChipView::gray8(&bytes, w, h, w, origin.0 as i32, origin.1 as i32)
            }
            .unwrap();
            let range = scene.pose(k).filter(|_| scene.range_known).map(|p| {
                (p.t.iter().map(|c| c * c).sum::<f64>()).sqrt() as f32
            });
            let result = pipeline.process(&FrameInput {
                chip,
                time_s: k as f64 / 30.0,
                range_m: range,
                mount: None,
            });
            check(&pipeline, &chip, &result)?;
        }
    }
}
