//! `imade fuse`: one flight recorded at two or more stations, combined frame by frame.
//!
//! Each clip is run as `imade run` runs it (`OUT/<station id>/results.csv`). The first clip is
//! the reference: the fused results have one row per row of its `frames.csv`, in its camera
//! frame. At each reference frame's time, every other station's sight is interpolated between
//! its two frames around that time (no further apart than `--max-gap`), and the sights go
//! through [`imade_core::stations::fuse`]: the nose where the stations' axis planes meet (the
//! yaw side is no longer a choice), the body origin where their lines of sight meet (no range
//! sensor needed). The angle of attack follows from the velocity of the fused positions, before
//! and after each frame. A frame the stations cannot fuse (only the reference saw it, or the
//! geometry is degenerate) keeps the reference station's own row; the `stations` column names
//! the stations each row stands on.

use crate::clip::{Clip, FrameRow, ResultRow, read_results, write_atomically};
use crate::run::{Job, PolarityArg, RangeArg, RefineChoice, SmoothingArg, run_jobs};
use crate::smooth::centred_velocity;
use anyhow::{Context, bail, ensure};
use imade_core::pose::{Pose, attitude_of};
use imade_core::results::{HEADER, WORLD_HEADER, write_row, write_world_columns};
use imade_core::stations::{
    FusedSight, FusionConfig, FusionError, SightSd, StationSight, fuse, mirror,
};
use imade_core::world::{AngleOfAttack, Position, Station, WorldConfig, WorldPose, WorldState};
use imade_core::{FrameResult, Status};
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Arguments of `imade fuse`.
#[derive(Debug, clap::Args)]
pub struct FuseArgs {
    /// Clip folders of one flight, one per station, each with the mount's pointing and its
    /// `station` in clip.json; the first is the reference whose frames and camera frame the
    /// fused results keep.
    #[arg(required = true)]
    pub clips: Vec<PathBuf>,
    /// Output folder: `<station id>/results.csv` for each station, `fused.csv` and
    /// `fusion.json`.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// How range measurements are used in each station's run (as `imade run --range`).
    #[arg(long, value_enum, default_value = "auto")]
    pub range: RangeArg,
    /// The projectile's model for every station's run (as `imade run --lut`).
    #[arg(long, default_value = "bundled")]
    pub lut: String,
    /// Longest time between a station's two frames around a reference frame for its sight to
    /// be interpolated there, s.
    #[arg(long, default_value_t = 0.5)]
    pub max_gap: f64,
}

/// One sigma of a station's line of sight to the body origin, in pixels of its focal length.
const SIGHT_SD_PX: f64 = 0.5;
/// One sigma of each end of the body's axis across it in the image, px: the axis plane's
/// sigma is sqrt 2 of it over the silhouette's length (the grey-level fit's axis, from the
/// whole body, is off by 0.01-0.1 deg at 65-130 px on the two-stations preset).
const AXIS_END_SD_PX: f64 = 0.1;
/// Floor of a station's attitude sigmas, deg.
const MIN_SD_DEG: f64 = 0.01;
/// Frames this close in time are taken as one, s.
const SAME_TIME_S: f64 = 1e-6;
/// The fused results' own column, after the world frame's.
const STATIONS_HEADER: &str = ",stations";

/// One station: its clip, id, and per frame row the sight of its ok frames.
struct StationRun {
    id: String,
    station: Station,
    frames: Vec<StationFrame>,
}

/// One row of a station's clip and results.
struct StationFrame {
    time_s: f64,
    sight: Option<StationSight>,
}

/// Runs `imade fuse`.
pub fn run(args: &FuseArgs) -> anyhow::Result<()> {
    ensure!(
        args.clips.len() >= 2,
        "imade fuse needs the clips of two or more stations (one station's results are \
         `imade run`'s)"
    );
    ensure!(
        args.max_gap.is_finite() && args.max_gap > 0.0,
        "--max-gap must be a positive number of seconds"
    );
    let clips: Vec<Clip> = args
        .clips
        .iter()
        .map(|dir| Clip::open(dir))
        .collect::<anyhow::Result<_>>()?;
    check_clips(&clips)?;
    let ids: Vec<String> = clips.iter().map(station_id).collect();
    let jobs: Vec<Job> = clips
        .iter()
        .zip(&ids)
        .map(|(clip, id)| Job {
            clip: clip.dir.clone(),
            out_dir: args.out.join(id),
            range: args.range,
            save_masks: false,
            lut: args.lut.clone(),
            refine: RefineChoice(None),
            tetris: None,
            range_smoothing: SmoothingArg::MotionModel,
            smooth: false,
            grey_fit: true,
            polarity: PolarityArg::default(),
        })
        .collect();
    let summary = run_jobs(&jobs);
    crate::run::outcome(&summary)?;
    let runs: Vec<StationRun> = clips
        .iter()
        .zip(&ids)
        .map(|(clip, id)| station_run(clip, id, &args.lut, &args.out.join(id).join("results.csv")))
        .collect::<anyhow::Result<_>>()?;
    check_clocks(&runs)?;
    let reference_results = args.out.join(&ids[0]).join("results.csv");
    let fused = fuse_frames(&runs, args.max_gap);
    let text = fused_csv(&clips[0], &runs, &fused, &reference_results)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.out.join("fused.csv");
    write_atomically(&path, text.as_bytes())?;
    let report = FusionReport::of(&ids, &fused);
    write_atomically(
        &args.out.join("fusion.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    eprintln!("{report}-> {}", path.display());
    Ok(())
}

/// Every clip must give the mount's pointing and a station of its own, and fly one projectile.
fn check_clips(clips: &[Clip]) -> anyhow::Result<()> {
    let first = &clips[0];
    for clip in clips {
        let json = clip.dir.join("clip.json");
        ensure!(
            clip.meta.station.is_some(),
            "{}: no `station`: imade fuse needs each station's place in the range's frame",
            json.display()
        );
        ensure!(
            clip.has_mount,
            "{}: no mount_az_deg / mount_el_deg columns: imade fuse needs the mount's pointing",
            clip.dir.join("frames.csv").display()
        );
        ensure!(
            clip.meta.projectile == first.meta.projectile,
            "{}: projectile {:?}, but {} flies {:?}: the clips are not of one flight",
            json.display(),
            clip.meta.projectile,
            first.dir.join("clip.json").display(),
            first.meta.projectile
        );
    }
    for (i, clip) in clips.iter().enumerate() {
        if let Some(other) = clips[..i]
            .iter()
            .find(|other| station_id(other) == station_id(clip))
        {
            bail!(
                "{} and {} are both station {:?}: give each station's clip once",
                other.dir.display(),
                clip.dir.display(),
                station_id(clip)
            );
        }
    }
    Ok(())
}

fn station_id(clip: &Clip) -> String {
    clip.meta
        .station
        .as_ref()
        .map_or_else(String::new, |s| s.id.clone())
}

/// A station's frames with their sights, from its clip and the results its run wrote.
fn station_run(clip: &Clip, id: &str, lut: &str, results: &Path) -> anyhow::Result<StationRun> {
    let rows = read_results(results)?;
    ensure!(
        rows.len() == clip.frames.len(),
        "{}: {} rows for {} frames",
        results.display(),
        rows.len(),
        clip.frames.len()
    );
    let station = clip.station();
    let optics = Optics {
        fx: clip.meta.camera.fx,
        length_m: f64::from(clip.model(lut)?.length_m),
    };
    let frames = clip
        .frames
        .iter()
        .zip(&rows)
        .filter_map(|(frame, row)| {
            let frame = frame.as_ref().ok()?;
            Some(StationFrame {
                time_s: frame.time_s,
                sight: row
                    .is_ok()
                    .then(|| sight_of(frame, row, &station, &optics))
                    .flatten(),
            })
        })
        .collect();
    Ok(StationRun {
        id: id.into(),
        station,
        frames,
    })
}

/// What sizes a station's sight sigmas: its focal length, px, and the body's length, m.
struct Optics {
    fx: f64,
    length_m: f64,
}

/// The sight of an ok frame with the mount's pointing: the axis plane's sigma from the
/// silhouette's length in the image ([`AXIS_END_SD_PX`]), the tilt's from the station's yaw
/// sigma (times cos pitch: the nose's move), the line of sight's [`SIGHT_SD_PX`].
fn sight_of(
    frame: &FrameRow,
    row: &ResultRow,
    station: &Station,
    optics: &Optics,
) -> Option<StationSight> {
    let (pitch_deg, yaw_deg) = (row.pitch_deg?, row.yaw_deg?);
    let origin_c = [row.tx_m?, row.ty_m?, row.tz_m?];
    let min_sd = MIN_SD_DEG.to_radians();
    let exact = StationSight::from_camera(
        station,
        frame.mount.as_ref()?,
        origin_c,
        pitch_deg,
        yaw_deg,
        SightSd {
            plane: min_sd,
            tilt: min_sd,
            sight: SIGHT_SD_PX / optics.fx,
        },
    )?;
    // The axis's length across the line of sight, px.
    let across = exact.candidates[0].cross(&exact.sight).norm();
    let length_px = optics.length_m * optics.fx * across / exact.range_m;
    let cos_pitch = pitch_deg.to_radians().cos();
    Some(StationSight {
        plane_sd_rad: (std::f64::consts::SQRT_2 * AXIS_END_SD_PX / length_px).max(min_sd),
        tilt_sd_rad: (row.yaw_sd_deg.unwrap_or(0.0).to_radians() * cos_pitch).max(min_sd),
        ..exact
    })
}

/// Each other station's clock must overlap the reference's.
fn check_clocks(runs: &[StationRun]) -> anyhow::Result<()> {
    let span = |run: &StationRun| {
        let times = run.frames.iter().map(|f| f.time_s);
        (
            times.clone().fold(f64::INFINITY, f64::min),
            times.fold(f64::NEG_INFINITY, f64::max),
        )
    };
    let (start, end) = span(&runs[0]);
    for run in &runs[1..] {
        let (s, e) = span(run);
        ensure!(
            s <= end && e >= start,
            "station {}'s frames ({s:.3} to {e:.3} s) and station {}'s ({start:.3} to {end:.3} \
             s) do not overlap in time: are the clips of one flight, on one clock?",
            run.id,
            runs[0].id
        );
    }
    Ok(())
}

/// What became of one reference frame.
enum Fused {
    /// The stations' sights combined, and the ids of the stations that contributed.
    Fused(Box<FusedSight>, Vec<usize>),
    /// The reference station's own result stands: why.
    Single(&'static str),
}

/// Fuses every reference frame with the other stations' sights at its time.
fn fuse_frames(runs: &[StationRun], max_gap_s: f64) -> Vec<Fused> {
    runs[0]
        .frames
        .iter()
        .map(|frame| {
            let Some(reference) = frame.sight else {
                return Fused::Single("no pose at the reference station");
            };
            let mut sights = vec![reference];
            let mut contributed = vec![0];
            for (i, run) in runs.iter().enumerate().skip(1) {
                if let Some(sight) = sight_at(run, frame.time_s, max_gap_s) {
                    sights.push(sight);
                    contributed.push(i);
                }
            }
            match fuse(&sights, &FusionConfig::DEFAULT) {
                Ok(fused) => Fused::Fused(Box::new(fused), contributed),
                Err(error) => Fused::Single(reason(error)),
            }
        })
        .collect()
}

fn reason(error: FusionError) -> &'static str {
    match error {
        FusionError::TooFewStations => "no other station saw the body then",
        FusionError::SameLine => "the stations look along the same line",
        FusionError::SamePlane => "the body's axis lies in the plane of the stations",
        FusionError::BadSight => "a station's sight is not usable",
    }
}

/// A station's sight at `time_s`: its frame then, or interpolated between its ok frames just
/// before and after, no further apart than `max_gap_s`.
fn sight_at(run: &StationRun, time_s: f64, max_gap_s: f64) -> Option<StationSight> {
    let after = run
        .frames
        .iter()
        .position(|f| f.time_s >= time_s - SAME_TIME_S)?;
    let later = &run.frames[after];
    if (later.time_s - time_s).abs() <= SAME_TIME_S {
        return later.sight;
    }
    let earlier = &run.frames[after.checked_sub(1)?];
    let gap = later.time_s - earlier.time_s;
    if gap > max_gap_s {
        return None;
    }
    earlier
        .sight?
        .between(&later.sight?, (time_s - earlier.time_s) / gap)
}

/// The fused results file: the reference's header with the `stations` column, and one row per
/// reference row.
fn fused_csv(
    reference: &Clip,
    runs: &[StationRun],
    fused: &[Fused],
    reference_results: &Path,
) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(reference_results)
        .with_context(|| format!("reading {}", reference_results.display()))?;
    let mut lines = text.lines();
    lines.next();
    let frame_rows: Vec<&FrameRow> = reference
        .frames
        .iter()
        .filter_map(|f| f.as_ref().ok())
        .collect();
    // The fused positions, for the velocity at each frame.
    let positions: Vec<Position> = frame_rows
        .iter()
        .zip(fused)
        .filter_map(|(row, fused)| match fused {
            Fused::Fused(sight, _) => Some(Position {
                time_s: row.time_s,
                enu_m: sight.origin_enu_m.into(),
                range_used: true,
            }),
            Fused::Single(_) => None,
        })
        .collect();
    let station = &runs[0].station;
    let mut out = format!("{HEADER}{WORLD_HEADER}{STATIONS_HEADER}\n");
    // The results have a line per frames.csv row; `fused` an entry per readable one.
    let mut fused_rows = frame_rows.iter().zip(fused);
    for (entry, line) in reference.frames.iter().zip(lines) {
        let fused_row = entry.is_ok().then(|| fused_rows.next()).flatten();
        match fused_row {
            Some((row, Fused::Fused(sight, contributed))) => {
                let velocity = centred_velocity(&positions, row.time_s, &WorldConfig::DEFAULT);
                let (result, world) = fused_frame(row, sight, station, velocity)
                    .context("a fused frame without a mount")?;
                write_row(&mut out, row.frame, &result).context("writing a fused row")?;
                write_world_columns(&mut out, Some(&world)).context("writing a fused row")?;
                let names: Vec<&str> = contributed.iter().map(|&i| runs[i].id.as_str()).collect();
                out.push_str(&format!(",{}\n", names.join("+")));
            }
            Some((_, Fused::Single(_))) => {
                out.push_str(&format!("{line},{}\n", runs[0].id));
            }
            None => out.push_str(&format!("{line},\n")),
        }
    }
    Ok(out)
}

/// The fused sight as a frame result in the reference camera frame of `row` (the nose and its
/// mirror about the image plane, their sigmas from the nose's covariance, the depth's from the
/// origin's) and in E, with the angle of attack against `velocity` (m/s in E) where known.
/// None where the row has no mount pointing.
fn fused_frame(
    row: &FrameRow,
    sight: &FusedSight,
    station: &Station,
    velocity: Option<[f64; 3]>,
) -> Option<(FrameResult, WorldState)> {
    let mount = row.mount?;
    let r_ec = mount.rotation_camera_to_world();
    let r_ce = r_ec.transpose();
    let origin_c = r_ce * (sight.origin_enu_m - Vector3::from(station.enu_m));
    let nose_c = r_ce * sight.nose;
    let mirrored_c = mirror(&nose_c, &origin_c.normalize());
    let (pitch, yaw) = attitude_of(&nose_c.map(|x| x as f32));
    let (pitch_alt, yaw_alt) = attitude_of(&mirrored_c.map(|x| x as f32));
    let (pitch_sd, yaw_sd) = attitude_sd(&(r_ce * sight.nose_cov * r_ec), pitch, yaw);
    let depth_axis = r_ec.column(2).into_owned();
    let tz_sd = (depth_axis.transpose() * sight.origin_cov * depth_axis)[0].sqrt();
    let result = FrameResult {
        status: Status::Ok,
        pose: Pose {
            tx_m: origin_c.x as f32,
            ty_m: origin_c.y as f32,
            tz_m: origin_c.z as f32,
            pitch_deg: pitch,
            yaw_deg: yaw,
        },
        pitch_alt_deg: pitch_alt,
        yaw_alt_deg: yaw_alt,
        yaw_resolved: true,
        range_used: false,
        tz_sd_m: Some(tz_sd as f32),
        pitch_sd_deg: pitch_sd as f32,
        yaw_sd_deg: yaw_sd as f32,
        image_range_m: 0.0,
        ..FrameResult::failed(Status::Ok)
    };
    // The origin in E as fused, not back through the f32 pose.
    let pose = WorldPose {
        origin_enu_m: sight.origin_enu_m.into(),
        ..WorldPose::of(&result.pose, &mount, station)
    };
    let world = WorldState {
        pose,
        aoa: velocity.and_then(|v| AngleOfAttack::of(&sight.nose.into(), &v)),
    };
    Some((result, world))
}

/// One sigma of pitch and yaw, deg, from the nose's covariance in C (rad²): along the nose's
/// derivatives by pitch (unit) and by yaw (of length cos pitch).
fn attitude_sd(cov_c: &Matrix3<f64>, pitch_deg: f32, yaw_deg: f32) -> (f64, f64) {
    let (sp, cp) = f64::from(pitch_deg).to_radians().sin_cos();
    let (sy, cy) = f64::from(yaw_deg).to_radians().sin_cos();
    let by_pitch = Vector3::new(-sp * sy, -cp, -sp * cy);
    let by_yaw = Vector3::new(cp * cy, 0.0, -cp * sy);
    let var = |v: &Vector3<f64>| (v.transpose() * cov_c * v)[0].max(0.0);
    (
        var(&by_pitch).sqrt().to_degrees(),
        var(&by_yaw).sqrt().to_degrees() / (cp * cp).max(1e-12),
    )
}

/// What `imade fuse` did, for `fusion.json` and the terminal.
#[derive(Debug, serde::Serialize)]
struct FusionReport {
    format: &'static str,
    stations: Vec<String>,
    reference_frames: usize,
    fused_frames: usize,
    single_station_frames: BTreeMap<&'static str, usize>,
}

impl FusionReport {
    fn of(ids: &[String], fused: &[Fused]) -> FusionReport {
        let mut single = BTreeMap::new();
        for f in fused {
            if let Fused::Single(why) = f {
                *single.entry(*why).or_insert(0) += 1;
            }
        }
        FusionReport {
            format: "imade-fuse-summary/1",
            stations: ids.to_vec(),
            reference_frames: fused.len(),
            fused_frames: fused
                .iter()
                .filter(|f| matches!(f, Fused::Fused(..)))
                .count(),
            single_station_frames: single,
        }
    }
}

impl std::fmt::Display for FusionReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "stations {}: {} of {} reference frames fused",
            self.stations.join(", "),
            self.fused_frames,
            self.reference_frames
        )?;
        for (why, count) in &self.single_station_frames {
            writeln!(
                f,
                "  {count} frames on station {} alone: {why}",
                self.stations[0]
            )?;
        }
        Ok(())
    }
}
