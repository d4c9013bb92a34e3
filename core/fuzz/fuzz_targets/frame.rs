//! The core's frame entry point, `Pipeline::process`, over up to four frames of one clip (so the
//! temporal state is exercised), on synthesized chips of any size, stride and bit depth, with
//! any intrinsics, ranges, times and configuration, with and without the bundled lookup table,
//! with the default capacities and with tiny ones. Every result is checked by the oracle.
#![no_main]

use arbitrary::Arbitrary;
use imade_core::extremes::cross_profile::ClutterWidth;
use imade_core::extremes::follow::FollowConfig;
use imade_core::extremes::orientation::FadeBridge;
use imade_core::flight_filter::FlightFilterConfig;
use imade_core::grey_fit::GreyFitConfig;
use imade_core::lut::table::Table;
use imade_core::mask::ChipMask;
use imade_core::segment::bar::BarConfig;
use imade_core::segment::corridor::CorridorConfig;
use imade_core::segment::terrain::TerrainConfig;
use imade_core::world::{Mount, WorldConfig};
use imade_core::{
    BodyPolarity, Camera, Config, DetectConfig, FrameInput, GuidedLoopConfig, GuidedMethod,
    MatchConfig, Pipeline, RangeFilterConfig, RangeSmoothing, RangeUse, SilhouetteConfig,
    SizeTolerance, TemporalConfig, TrackConfig, UncertaintyConfig,
};
use imade_core_fuzz::{oracle, reference, synth};
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

/// Frames per input.
const MAX_FRAMES: usize = 4;

#[derive(Arbitrary, Debug)]
struct Input {
    camera: CameraSpec,
    config: ConfigSpec,
    /// Capacities of 64 runs and 16 labels instead of the defaults.
    small: bool,
    /// Refine against the bundled table (one value in four: the table match dominates the time
    /// of a frame, and the `lut_table` target fuzzes it on its own).
    table: u8,
    frames: Vec<FrameSpec>,
}

#[derive(Arbitrary, Debug)]
enum CameraSpec {
    /// The fixtures' camera.
    Nominal,
    /// Focal length and principal point from small numbers.
    Scaled { focal: u16, cx: i16, cy: i16 },
    /// Any floats, NaN and infinities included.
    Raw { fx: f32, fy: f32, cx: f32, cy: f32 },
}

#[derive(Arbitrary, Debug)]
enum ConfigSpec {
    /// The defaults with a polarity and range use.
    Nominal { polarity: u8, ignore_range: bool },
    /// Every field from the input.
    Raw {
        detect_sigma: f32,
        detect_retries: u8,
        min_area_px: u32,
        polarity: u8,
        mask_level: f32,
        mask_min_sigma: f32,
        tz_smoothing_r: f32,
        tz_smoothing_interval_s: f32,
        window_frames: u8,
        min_trend_frames: u8,
        trend_sigma: f32,
        max_gap_s: f32,
        mask_margin_sigmas: f32,
        mask_margin_px: f32,
        faint_mask_sigma: f32,
        /// The sky exclusion's minimum width, scale, margin and re-detection thresholds.
        sky_exclusion: [f32; 5],
        /// The body size tolerance (min width, max width, max length, margin), the faint box
        /// in diameters and its threshold, the width, polarity and track weights.
        body: [f32; 12],
        /// The track's gate (px, length fraction, axis deg) and its longest age, s.
        track: [f32; 4],
        ignore_range: bool,
        /// The shape-guided method, modulo 3 (0: none).
        guided: u8,
        shape_prior: bool,
        section_bin_px: f32,
        cylinder_margin: f32,
        min_cylinder_px: f32,
        end_weight: f32,
        clutter_diameter_tolerance: f32,
        /// Every scalar tunable of the silhouette stage, in its field order.
        silhouette: [f32; 15],
        /// The fade bridge's tunables, in their field order (None: not looked for).
        fade_bridge: Option<[f32; 4]>,
        /// The follow's tunables, in their field order (None: not followed).
        follow: Option<[f32; 5]>,
        /// The clutter width's stretches and tunables, in their field order (None: not read).
        clutter_width: Option<(u8, [f32; 2])>,
        /// Every tunable of the uncertainties, in their field order.
        uncertainty: [f32; 13],
        /// The grey-level fit: whether it runs, then its tunables (pixels, roll starts,
        /// iterations, the rest in field order).
        grey_fit: (bool, u16, u8, u8, u8, [f32; 14]),
        /// Every tunable of the bar search, in its field order (None: no bar search).
        bar: Option<[f32; 18]>,
        /// Every tunable of the sky corridor, in its field order (None: the tiles' sky).
        corridor: Option<[f32; 6]>,
        /// Every tunable of the world stage, in its field order.
        world: [f64; 8],
        /// The terrain's tunables: its float ones and its px ones, each in field order (None:
        /// not looked for).
        terrain: Option<([f32; 6], [u16; 3])>,
        max_predicted_scatter: f32,
        /// The flight filter's float tunables in field order, its iterations, misses, frames
        /// to be established and whether it runs.
        flight: ([f32; 15], u8, u8, u8, bool),
    },
}

#[derive(Arbitrary, Debug)]
struct FrameSpec {
    /// Forget the temporal state first (a new clip).
    reset: bool,
    chip: synth::ChipSpec,
    origin: (i32, i32),
    time: TimeSpec,
    range: Option<RangeSpec>,
    /// The mount's pointing, deg (refused ones are no pointing, as the clip reader makes them).
    mount: Option<(f64, f64)>,
}

#[derive(Arbitrary, Debug)]
enum TimeSpec {
    /// Milliseconds after the previous frame.
    Step(u16),
    /// Any time, NaN included.
    Raw(f64),
}

#[derive(Arbitrary, Debug)]
enum RangeSpec {
    Metres(u16),
    Raw(f32),
}

fn polarity(p: u8) -> Option<BodyPolarity> {
    [Some(BodyPolarity::Dark), Some(BodyPolarity::Bright), None][usize::from(p % 3)]
}

fn range_use(ignore: bool) -> RangeUse {
    if ignore {
        RangeUse::Ignore
    } else {
        RangeUse::Auto
    }
}

fn camera(spec: &CameraSpec) -> Camera {
    match *spec {
        CameraSpec::Nominal => Camera {
            fx: 100000.0,
            fy: 100000.0,
            cx: 1023.5,
            cy: 1023.5,
        },
        CameraSpec::Scaled { focal, cx, cy } => Camera {
            fx: f32::from(focal) * 4.0,
            fy: f32::from(focal) * 4.0,
            cx: f32::from(cx),
            cy: f32::from(cy),
        },
        CameraSpec::Raw { fx, fy, cx, cy } => Camera { fx, fy, cx, cy },
    }
}

fn config(spec: &ConfigSpec) -> Config {
    match *spec {
        ConfigSpec::Nominal {
            polarity: p,
            ignore_range,
        } => Config {
            detect: DetectConfig {
                polarity: polarity(p),
                ..DetectConfig::DEFAULT
            },
            range_use: range_use(ignore_range),
            ..Config::DEFAULT
        },
        ConfigSpec::Raw {
            detect_sigma,
            detect_retries,
            min_area_px,
            polarity: p,
            mask_level,
            mask_min_sigma,
            tz_smoothing_r,
            tz_smoothing_interval_s,
            window_frames,
            min_trend_frames,
            trend_sigma,
            max_gap_s,
            mask_margin_sigmas,
            mask_margin_px,
            faint_mask_sigma,
            sky_exclusion: x,
            body: b,
            track: t,
            ignore_range,
            guided,
            shape_prior,
            section_bin_px,
            cylinder_margin,
            min_cylinder_px,
            end_weight,
            clutter_diameter_tolerance,
            silhouette: s,
            fade_bridge,
            follow,
            clutter_width,
            uncertainty: u,
            grey_fit: g,
            bar,
            corridor,
            world: w,
            terrain,
            max_predicted_scatter,
            flight: (f, iterations, misses, established, flight_enabled),
        } => Config {
            range_use: range_use(ignore_range),
            detect: DetectConfig {
                threshold_sigma: detect_sigma,
                retries: detect_retries % 4,
                min_area_px,
                polarity: polarity(p),
                mask_level,
                mask_min_sigma,
                mask_margin_sigmas,
                mask_margin_px,
                faint_mask_sigma,
                sky_exclusion_min_width_px: x[0],
                sky_exclusion_scale: x[1],
                sky_exclusion_px: x[2],
                redetect_sigma: x[3],
                redetect_contrast: x[4],
                body_size: SizeTolerance {
                    min_width: b[0],
                    max_width: b[1],
                    max_length: b[2],
                    margin_px: b[3],
                },
                faint_box_diameters: b[4],
                faint_threshold_sigma: b[5],
                width_weight: b[6],
                polarity_weight: b[7],
                track_weight: b[8],
                unknown_range_diameters_px: [b[9], b[10], b[11]],
                bar: bar.map(|a| BarConfig {
                    block_diameters: a[0],
                    length_fraction: a[1],
                    min_length_diameters: a[2],
                    flank_diameters: a[3],
                    threshold_sigma: a[4],
                    end_fraction: a[5],
                    end_ceiling: a[6],
                    max_gap_diameters: a[7],
                    strong_sigma: a[8],
                    overhang_lengths: a[9],
                    min_bar_diameters: a[10],
                    plume_min_sigma: a[11],
                    plume_weight: a[12],
                    max_width_penalty: a[13],
                    fragment_fraction: a[14],
                    piece_fraction: a[15],
                    plume_length_fraction: a[16],
                    plume_max_contrast_ratio: a[17],
                }),
                corridor: corridor.map(|a| CorridorConfig {
                    margin_px: a[0],
                    axis_slope: a[1],
                    flank_diameters: a[2],
                    bin_diameters: a[3],
                    length_scale: a[4],
                    max_disagreement: a[5],
                }),
                terrain: terrain.map(|(f, px)| TerrainConfig {
                    min_contrast_sigma: f[0],
                    min_width_fraction: f[1],
                    gap_px: px[0],
                    margin_px: px[1],
                    edge_fraction: f[2],
                    edge_px: px[2],
                    min_sharp_fraction: f[3],
                    min_low_fraction: f[4],
                    min_dark_contrast_sigma: f[5],
                }),
            },
            silhouette: SilhouetteConfig {
                half_length_sds: s[0],
                section_reach_sds: s[1],
                section_reach_px: s[2],
                nose_ramp: (s[3], s[4]),
                end_level: s[5],
                max_gap: s[6],
                plateau_window: (s[7], s[8]),
                min_nose_evidence: s[9],
                min_plume_area: s[10],
                plume_dominance: s[11],
                fade_bridge: fade_bridge.map(|a| FadeBridge {
                    onset_diameters: a[0],
                    min_plume_area: a[1],
                    min_fill_diameters: a[2],
                    max_contrast_sigmas: a[3],
                }),
                follow: follow.map(|a| FollowConfig {
                    stretch_diameters: a[0],
                    diameter_tolerance: a[1],
                    max_offset_diameters: a[2],
                    min_contrast_fraction: a[3],
                    min_sigma: a[4],
                }),
                remeasure_length: s[12],
                diameter_tolerance: s[13],
                narrow_band_max_contrast_sigmas: s[14],
                clutter_width: clutter_width.map(|(stretches, a)| ClutterWidth {
                    stretches: usize::from(stretches),
                    quantile: a[0],
                    min_fraction_of_median: a[1],
                }),
            },
            table_match: MatchConfig {
                section_bin_px,
                cylinder_margin,
                min_cylinder_px,
                end_weight,
                clutter_diameter_tolerance,
                shape_prior,
                guided: GuidedLoopConfig {
                    method: [
                        None,
                        Some(GuidedMethod::SisCut),
                        Some(GuidedMethod::GvfAsm),
                        Some(GuidedMethod::Tetris),
                    ][usize::from(guided % 4)],
                    ..GuidedLoopConfig::DEFAULT
                },
            },
            world: WorldConfig {
                max_span_s: w[0],
                max_gap_s: w[1],
                side_margin_deg: w[2],
                side_max_range_sd_fraction: w[3] as f32,
                side_min_sigmas: w[4] as f32,
                side_clear_velocity_deg: w[5],
                min_flight_across: w[6],
                max_aoa_deg: w[7],
            },
            uncertainty: UncertaintyConfig {
                end_gain: u[0],
                min_end_sd_px: u[1],
                min_end_sd_diameters: u[2],
                residual_gain: u[3],
                fit_gain: u[4],
                fit_min_end_sd_px: u[5],
                fit_min_end_sd_diameters: u[6],
                fit_min_roll_sd_deg: u[7],
                max_roll_sd_deg: u[8],
                min_roll_tilt_deg: u[9],
                fit_min_roll_sd_as_body_deg: u[10],
                fit_faces_gain: u[11],
                cluttered_range_fraction: u[12],
            },
            grey_fit: GreyFitConfig {
                enabled: g.0,
                max_pixels: usize::from(g.1),
                roll_starts: u32::from(g.2 % 16),
                probe_iterations: u32::from(g.3 % 8),
                max_iterations: u32::from(g.4 % 32),
                columns_per_sigma: g.5[0],
                margin_sigmas: g.5[1],
                margin_px: g.5[2],
                huber_sigmas: g.5[3],
                max_scale_change: g.5[4],
                max_shift_px: g.5[5],
                orientation_margin: g.5[6],
                wide_body_sigmas: g.5[7],
                narrow_body_px: g.5[8],
                sharp_body_sigmas: g.5[9],
                plume_margin_sigmas: g.5[10],
                sky_bin_diameters: g.5[11],
                flight_tilt_sd_deg: g.5[12],
                fin_faces_min_contrast_sigmas: g.5[13],
            },
            track: TrackConfig {
                gate_px: t[0],
                gate_length: t[1],
                gate_axis_deg: t[2],
                max_age_s: t[3],
            },
            temporal: TemporalConfig {
                range_smoothing: if tz_smoothing_r > 0.5 {
                    RangeSmoothing::Eq5
                } else {
                    RangeSmoothing::MotionModel
                },
                range_filter: RangeFilterConfig::DEFAULT,
                flight: FlightFilterConfig {
                    enabled: flight_enabled,
                    gravity_m_s2: f[0],
                    acceleration_psd: f[1],
                    along_jerk_psd: f[2],
                    sight_sd_px: f[3],
                    min_range_fraction: f[4],
                    range_bias_sd: f[5],
                    range_bias_psd: f[6],
                    initial_velocity_sd_m_s: f[7],
                    initial_along_sd_m_s2: f[8],
                    huber_sigmas: f[9],
                    sight_gate_sigmas: f[10],
                    max_misses: u32::from(misses),
                    hold_fraction: f[11],
                    size_fraction: f[12],
                    established_frames: u32::from(established),
                    young_gate_sigmas: f[13],
                    max_step_s: f[14],
                    iterations: u32::from(iterations),
                },
                tz_smoothing_r,
                tz_smoothing_interval_s,
                window_frames: usize::from(window_frames),
                min_trend_frames: usize::from(min_trend_frames),
                trend_sigma,
                max_gap_s,
                max_predicted_scatter,
            },
        },
    }
}

fn table() -> Table<'static> {
    static TABLE: OnceLock<Table<'static>> = OnceLock::new();
    *TABLE.get_or_init(|| {
        reference()
            .table()
            .expect("the bundled model carries its table")
    })
}

fn with_table<const R: usize, const L: usize>(
    pipeline: Pipeline<R, L>,
    table: Option<Table<'static>>,
) -> Pipeline<R, L> {
    match table {
        Some(t) => {
            let mut p = pipeline.with_table(t);
            p.set_tetris(imade_core_fuzz::tetris());
            p
        }
        None => pipeline,
    }
}

fn run<const R: usize, const L: usize>(mut pipeline: Box<Pipeline<R, L>>, input: &Input) {
    let mut scratch = Box::new(ChipMask::new());
    let mut time_s = 0.0f64;
    for frame in input.frames.iter().take(MAX_FRAMES) {
        let chip = synth::synthesize(&frame.chip, &mut scratch);
        let Ok(view) = chip.view(frame.origin) else {
            continue;
        };
        if frame.reset {
            pipeline.reset();
        }
        time_s = match frame.time {
            TimeSpec::Step(ms) => time_s + f64::from(ms) / 1000.0,
            TimeSpec::Raw(t) => t,
        };
        let range_m = frame.range.as_ref().map(|r| match *r {
            RangeSpec::Metres(m) => f32::from(m),
            RangeSpec::Raw(r) => r,
        });
        let mount = frame
            .mount
            .and_then(|(az, el)| Mount::new_checked(az, el).ok());
        let result = pipeline.process(&FrameInput {
            chip: view,
            time_s,
            range_m,
            mount,
        });
        oracle::check(&pipeline, &view, &result);
    }
}

fuzz_target!(|input: Input| {
    let (camera, config) = (camera(&input.camera), config(&input.config));
    let table = input.table.is_multiple_of(4).then(table);
    if input.small {
        let p = Pipeline::<64, 16>::new(config, camera, reference());
        run(Box::new(with_table(p, table)), &input);
    } else {
        let p: Pipeline = Pipeline::new(config, camera, reference());
        run(Box::new(with_table(p, table)), &input);
    }
});
