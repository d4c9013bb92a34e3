//! Estimated against true pose over the frames, like the paper's Fig. 15 (unknown range) and
//! Fig. 16 (known range): Tx, Ty, Tz, pitch and yaw (with the mirrored candidate), and the slant
//! range measured from the image. Tz, pitch and yaw carry error bars of two sigmas either way
//! where the results give their sigmas (`tz_sd_m`, `pitch_sd_deg`, `yaw_sd_deg`).

use super::panel::{ESTIMATE, Mark, SECONDARY, Series, TRUTH, draw_panel};
use crate::clip::{Clip, FrameRow, GroundTruth, ResultRow};
use plotters::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// A column of a results row (a value or its sigma), where the row gives it.
type Column = fn(&ResultRow) -> Option<f64>;

/// Writes the figure for one results file to `path` (1500 x 900 px).
pub fn plot(clip: &Clip, rows: &[ResultRow], title: &str, path: &Path) -> anyhow::Result<()> {
    let truth: Vec<(&FrameRow, GroundTruth)> = clip
        .frames
        .iter()
        .filter_map(|f| f.as_ref().ok())
        .filter_map(|r| Some((r, r.truth?)))
        .collect();
    let ok: HashMap<u64, &ResultRow> = rows
        .iter()
        .filter(|r| r.is_ok())
        .filter_map(|r| Some((r.frame?, r)))
        .collect();
    let true_of = |f: fn(&GroundTruth) -> f64| -> Vec<(f64, f64)> {
        truth.iter().map(|(r, t)| (r.frame as f64, f(t))).collect()
    };
    // The estimate's points (frame, value) and, where `sd` gives one, each point's sigma.
    let estimate_of = |value: Column, sd: Column| -> (Vec<(f64, f64)>, Vec<Option<f64>>) {
        truth
            .iter()
            .filter_map(|(r, _)| {
                let row = ok.get(&r.frame)?;
                Some(((r.frame as f64, value(row)?), sd(row)))
            })
            .unzip()
    };
    let no_sd: Column = |_| None;
    let pair = |truth: Vec<(f64, f64)>, (points, sigmas): (Vec<(f64, f64)>, Vec<Option<f64>>)| {
        vec![
            Series {
                label: "truth",
                mark: Mark::Line,
                color: TRUTH,
                points: truth,
                sigmas: Vec::new(),
            },
            Series {
                label: "estimate",
                mark: Mark::Dots,
                color: ESTIMATE,
                points,
                sigmas,
            },
        ]
    };
    let with_alt = |mut series: Vec<Series<'static>>, (alt, _): (Vec<(f64, f64)>, _)| {
        series.push(Series {
            label: "mirrored candidate",
            mark: Mark::Crosses,
            color: SECONDARY,
            points: alt,
            sigmas: Vec::new(),
        });
        series
    };
    let slant = |t: &GroundTruth| (t.tx_m * t.tx_m + t.ty_m * t.ty_m + t.tz_m * t.tz_m).sqrt();
    let mut range = pair(true_of(slant), estimate_of(|r| r.image_range_m, no_sd));
    range[1].label = "from the image";
    range.push(Series {
        label: "range sensor",
        mark: Mark::Crosses,
        color: SECONDARY,
        points: truth
            .iter()
            .filter_map(|(r, _)| Some((r.frame as f64, r.range_m?)))
            .collect(),
        sigmas: Vec::new(),
    });
    let panels: [(&str, &str, Vec<Series>); 6] = [
        (
            "Tx",
            "m",
            pair(true_of(|t| t.tx_m), estimate_of(|r| r.tx_m, no_sd)),
        ),
        (
            "Ty",
            "m",
            pair(true_of(|t| t.ty_m), estimate_of(|r| r.ty_m, no_sd)),
        ),
        (
            "Tz",
            "m",
            pair(true_of(|t| t.tz_m), estimate_of(|r| r.tz_m, |r| r.tz_sd_m)),
        ),
        (
            "pitch",
            "deg",
            with_alt(
                pair(
                    true_of(|t| t.pitch_deg),
                    estimate_of(|r| r.pitch_deg, |r| r.pitch_sd_deg),
                ),
                estimate_of(|r| r.pitch_alt_deg, no_sd),
            ),
        ),
        (
            "yaw",
            "deg",
            with_alt(
                pair(
                    true_of(|t| t.yaw_deg),
                    estimate_of(|r| r.yaw_deg, |r| r.yaw_sd_deg),
                ),
                estimate_of(|r| r.yaw_alt_deg, no_sd),
            ),
        ),
        ("slant range |T|", "m", range),
    ];
    let root = BitMapBackend::new(path, (1500, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, (super::font::FAMILY, 26))?;
    for (area, (name, unit, series)) in root.split_evenly((2, 3)).iter().zip(panels) {
        draw_panel(area, name, unit, &series)?;
    }
    root.present()?;
    Ok(())
}
