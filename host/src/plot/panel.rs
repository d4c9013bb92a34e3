//! One line/scatter panel of frame-indexed values, the building block of the pose figures.

use super::font::FAMILY;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// A line through the points (the truth).
    Line,
    /// Filled dots (the estimate).
    Dots,
    /// Small crosses (a secondary estimate, such as the mirrored candidate).
    Crosses,
}

/// One series of (frame, value) points.
pub struct Series<'a> {
    /// Legend text.
    pub label: &'a str,
    /// How it is drawn.
    pub mark: Mark,
    /// Its colour.
    pub color: RGBColor,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// One sigma of each point where it has one (a bar of two sigmas either way is drawn);
    /// empty, or one entry per point.
    pub sigmas: Vec<Option<f64>>,
}

/// The paper's colours: truth blue, estimate orange.
pub const TRUTH: RGBColor = RGBColor(31, 119, 180);
/// See [`TRUTH`].
pub const ESTIMATE: RGBColor = RGBColor(255, 127, 14);
/// Secondary estimates.
pub const SECONDARY: RGBColor = RGBColor(150, 150, 150);

/// The span of the values with a 5 % margin (a unit span around a constant).
pub fn span(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return 0.0..1.0;
    }
    let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 };
    lo - pad..hi + pad
}

/// Draws a panel titled `title` with y axis `unit` over frame numbers; the y axis spans the
/// points, and error bars are clipped to it.
pub fn draw_panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    title: &str,
    unit: &str,
    series: &[Series],
) -> anyhow::Result<()> {
    let all = || series.iter().flat_map(|s| s.points.iter());
    let x = span(all().map(|p| p.0));
    let y = span(all().map(|p| p.1));
    let y_range = y.clone();
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FAMILY, 22))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc("frame")
        .y_desc(unit)
        .label_style((FAMILY, 14))
        .draw()?;
    for s in series {
        let color = s.color;
        let bars = s
            .points
            .iter()
            .zip(&s.sigmas)
            .filter_map(|(&(x, value), sd)| Some((x, value, (*sd)?)))
            .map(|(x, value, sd)| {
                // Clipped to the panel, so that one wide bar cannot hide the others.
                let clip = |v: f64| v.clamp(y_range.start, y_range.end);
                ErrorBar::new_vertical(
                    x,
                    clip(value - 2.0 * sd),
                    value,
                    clip(value + 2.0 * sd),
                    color.mix(0.5).stroke_width(1),
                    4,
                )
            });
        chart.draw_series(bars)?;
        let drawn = match s.mark {
            Mark::Line => chart.draw_series(LineSeries::new(
                s.points.iter().copied(),
                color.stroke_width(2),
            ))?,
            Mark::Dots => {
                chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 3, color.filled())))?
            }
            Mark::Crosses => chart.draw_series(
                s.points
                    .iter()
                    .map(|&p| Cross::new(p, 3, color.stroke_width(1))),
            )?,
        };
        drawn.label(s.label).legend(legend_mark(color));
    }
    draw_legend(&mut chart)
}

/// A chart with f64 axes on a bitmap, as the figures' panels are.
pub type Chart<'a> =
    ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A series' mark in the legend: a dot of its colour.
pub fn legend_mark(color: RGBColor) -> impl Fn((i32, i32)) -> Circle<(i32, i32), i32> {
    move |(x, y)| Circle::new((x + 8, y), 4, color.filled())
}

/// Draws the legend of `chart`'s labelled series, in the panels' style.
pub fn draw_legend(chart: &mut Chart<'_>) -> anyhow::Result<()> {
    chart
        .configure_series_labels()
        .label_font((FAMILY, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
