//! The markdown report of one or more evaluations, side by side with the paper's figures.

use super::Evaluation;
use super::paper::Parameter;
use super::stats::Summary;
use std::fmt::Write;

/// A number with precision suited to its size.
fn num(v: f64) -> String {
    let a = v.abs();
    if a < 1.0 {
        format!("{v:.3}")
    } else if a < 100.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.1}")
    }
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map_or_else(|| "-".into(), f)
}

/// The report: a pose-error table with one column group per evaluation, then the IoU table.
pub fn markdown(evaluations: &[&Evaluation]) -> String {
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = write_pose_table(&mut s, evaluations);
    let _ = write_iou_table(&mut s, evaluations);
    s
}

/// One evaluation's cells of a statistics row: median, mean, p90 and the paper's figure (`-`
/// where a statistic or the paper's figure is missing).
fn write_stats(s: &mut String, stats: Option<Summary>, paper: Option<f64>) -> std::fmt::Result {
    write!(
        s,
        " {} | {} | {} | {} |",
        opt(stats.map(|x| x.median), num),
        opt(stats.map(|x| x.mean), num),
        opt(stats.map(|x| x.p90), num),
        opt(paper, num)
    )
}

/// One world-frame row's statistics of an evaluation.
type WorldStat = fn(&Evaluation) -> Option<Summary>;

fn write_pose_table(s: &mut String, evaluations: &[&Evaluation]) -> std::fmt::Result {
    writeln!(
        s,
        "### Pose errors normalized to 1 km (|estimate - truth| / true depth in km)\n"
    )?;
    for e in evaluations {
        writeln!(
            s,
            "- {}: `{}` on `{}`: {} of {} frames with truth have a pose ({} result rows)",
            e.pose.case.label(),
            e.results.display(),
            e.clip.display(),
            e.pose.frames_with_pose,
            e.pose.frames_with_truth,
            e.result_rows
        )?;
    }
    write!(s, "\n| parameter | unit |")?;
    for e in evaluations {
        write!(
            s,
            " {} median | mean | p90 | paper (about) |",
            e.pose.case.label()
        )?;
    }
    write!(s, "\n| --- | --- |")?;
    for _ in evaluations {
        write!(s, " ---: | ---: | ---: | ---: |")?;
    }
    writeln!(s)?;
    for (i, parameter) in Parameter::ALL.iter().enumerate() {
        write!(s, "| {} | {} |", parameter.label(), parameter.unit())?;
        for e in evaluations {
            let p = e.pose.parameters.get(i);
            write_stats(s, p.and_then(|p| p.stats), p.and_then(|p| p.paper))?;
        }
        writeln!(s)?;
    }
    write!(
        s,
        "| roll (chosen candidate where it is the better one) | deg/km |"
    )?;
    for e in evaluations {
        write_stats(s, e.pose.roll, None)?;
    }
    write!(s, "\n| frames with a roll | % of poses |")?;
    for e in evaluations {
        let share = (e.pose.frames_with_pose > 0)
            .then(|| e.pose.frames_with_roll as f64 / e.pose.frames_with_pose as f64);
        write!(
            s,
            " {} | | | |",
            opt(share, |f| format!("{:.1}", 100.0 * f))
        )?;
    }
    let world_rows: [(&str, &str, WorldStat); 6] = [
        (
            "nose azimuth, world frame (chosen candidate)",
            "deg/km",
            |e| e.world.as_ref().and_then(|w| w.nose_az),
        ),
        (
            "nose elevation, world frame (chosen candidate)",
            "deg/km",
            |e| e.world.as_ref().and_then(|w| w.nose_el),
        ),
        ("body origin, world frame (distance)", "m/km", |e| {
            e.world.as_ref().and_then(|w| w.origin)
        }),
        ("angle of attack, total (not normalized)", "deg", |e| {
            e.world.as_ref().and_then(|w| w.aoa)
        }),
        ("angle of attack, up (not normalized)", "deg", |e| {
            e.world.as_ref().and_then(|w| w.aoa_up)
        }),
        ("angle of attack, right (not normalized)", "deg", |e| {
            e.world.as_ref().and_then(|w| w.aoa_right)
        }),
    ];
    if evaluations.iter().any(|e| e.world.is_some()) {
        for (label, unit, stats) in world_rows {
            write!(s, "\n| {label} | {unit} |")?;
            for e in evaluations {
                write_stats(s, stats(e), None)?;
            }
        }
    }
    let shares: [(&str, Share); 7] = [
        ("yaw choice correct", |e| e.pose.yaw_choice_correct),
        ("yaw choice resolved (`yaw_resolved`)", |e| {
            e.pose.yaw_resolved
        }),
        ("yaw choice correct where resolved", |e| {
            e.pose.resolved_choice_correct
        }),
        ("Tz within two of its sigmas (tz_sd_m)", |e| {
            e.pose.tz_within_two_sd
        }),
        (
            "pitch within two of its sigmas (pitch_sd_deg, nearer candidate)",
            |e| e.pose.pitch_within_two_sd,
        ),
        (
            "yaw within two of its sigmas (yaw_sd_deg, nearer candidate)",
            |e| e.pose.yaw_within_two_sd,
        ),
        ("roll within two of its sigmas (roll_sd_deg)", |e| {
            e.pose.roll_within_two_sd
        }),
    ];
    for (label, share) in shares {
        write!(s, "\n| {label} | % |")?;
        for e in evaluations {
            write!(
                s,
                " {} | | | |",
                opt(share(e), |f| format!("{:.1}", 100.0 * f))
            )?;
        }
    }
    writeln!(s, "\n")
}

/// A share of an evaluation's frames (None where it has no frame to judge).
type Share = fn(&Evaluation) -> Option<f64>;

fn write_iou_table(s: &mut String, evaluations: &[&Evaluation]) -> std::fmt::Result {
    writeln!(
        s,
        "### Segmentation IoU against the ground-truth masks (a frame without a mask scores 0)\n"
    )?;
    if evaluations.iter().all(|e| e.segmentation.is_empty()) {
        return writeln!(
            s,
            "No stage masks beside the results (run with `--save-masks`).\n"
        );
    }
    writeln!(
        s,
        "| run | stage | frames | no mask | min | q1 | median | q3 | max | mean | paper median |"
    )?;
    writeln!(
        s,
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"
    )?;
    for e in evaluations {
        for stage in &e.segmentation {
            let b = stage.stats;
            writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                e.pose.case.label(),
                stage.stage,
                stage.frames,
                stage.missing,
                opt(b.map(|x| x.min), num),
                opt(b.map(|x| x.q1), num),
                opt(b.map(|x| x.median), num),
                opt(b.map(|x| x.q3), num),
                opt(b.map(|x| x.max), num),
                opt(b.map(|x| x.mean), num),
                stage.paper.map_or_else(
                    || "-".into(),
                    |p| format!("{} ({})", num(p.median), p.method)
                )
            )?;
        }
    }
    writeln!(s)
}
