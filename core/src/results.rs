//! The imade-results/1 row format (`docs/formats.md`), written through
//! `core::fmt::Write` so that the host and the firmware produce the same bytes.

use crate::frame::{FrameResult, Status};
use crate::segment::TrackUse;
use crate::world::WorldState;
use core::fmt::{self, Write};

/// The header line (without a line end). The spec's columns, then imade's own.
pub const HEADER: &str = "frame,status,tx_m,ty_m,tz_m,pitch_deg,yaw_deg,yaw_alt_deg,yaw_resolved,range_used,roll_deg,tz_sd_m,pitch_sd_deg,yaw_sd_deg,pitch_alt_deg,image_range_m,track,roll_sd_deg";

/// The world frame's columns (`crate::world`), after [`HEADER`]'s where the clip gives the
/// tracking mount's pointing: the chosen candidate's nose azimuth and elevation, deg, the body
/// origin east, north and up, m, and the angle of attack with its components up and right of
/// the velocity, deg.
pub const WORLD_HEADER: &str =
    ",nose_az_deg,nose_el_deg,e_m,n_m,u_m,aoa_deg,aoa_up_deg,aoa_right_deg";

/// Writes one row (without a line end) for `frame`.
pub fn write_row(out: &mut impl Write, frame: u64, result: &FrameResult) -> fmt::Result {
    if result.status != Status::Ok {
        return write_status_row(out, Some(frame), result.status.as_str());
    }
    let p = &result.pose;
    write!(
        out,
        "{frame},ok,{:.4},{:.4},{:.3},{:.4},{:.4},{:.4},{},{},",
        p.tx_m,
        p.ty_m,
        p.tz_m,
        p.pitch_deg,
        p.yaw_deg,
        result.yaw_alt_deg,
        result.yaw_resolved,
        result.range_used
    )?;
    if let Some(roll) = result.roll_deg {
        write!(out, "{roll:.3}")?;
    }
    write!(out, ",")?;
    if let Some(sd) = result.tz_sd_m {
        write!(out, "{sd:.3}")?;
    }
    write!(
        out,
        ",{:.4},{:.4},{:.4},{:.3},{},",
        result.pitch_sd_deg,
        result.yaw_sd_deg,
        result.pitch_alt_deg,
        result.image_range_m,
        result.track.map_or("", TrackUse::as_str)
    )?;
    if let Some(sd) = result.roll_sd_deg {
        write!(out, "{sd:.3}")?;
    }
    Ok(())
}

/// Writes the row of a frame that produced no pose, with `status` (lower case, no commas); the
/// frame column is left empty where the frame number itself could not be read.
pub fn write_status_row(out: &mut impl Write, frame: Option<u64>, status: &str) -> fmt::Result {
    if let Some(frame) = frame {
        write!(out, "{frame}")?;
    }
    write!(out, ",{status},,,,,,,false,false,,,,,,,,")
}

/// Writes a row's [`WORLD_HEADER`] columns (after [`write_row`] or [`write_status_row`]): the
/// frame's `world` state, empty where it has none (and the angle of attack empty where it has
/// none).
pub fn write_world_columns(out: &mut impl Write, world: Option<&WorldState>) -> fmt::Result {
    let Some(world) = world else {
        return write!(out, ",,,,,,,,");
    };
    let (w, [e, n, u]) = (&world.pose, world.pose.origin_enu_m);
    write!(
        out,
        ",{:.4},{:.4},{e:.3},{n:.3},{u:.3}",
        w.nose_az_deg, w.nose_el_deg
    )?;
    match &world.aoa {
        Some(a) => write!(
            out,
            ",{:.4},{:.4},{:.4}",
            a.total_deg, a.up_deg, a.right_deg
        ),
        None => write!(out, ",,,"),
    }
}
