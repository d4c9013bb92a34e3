//! Tukey box plots drawn with plotters primitives: the box from the 25th to the 75th percentile
//! with the median, whiskers to the most extreme values within 1.5 interquartile ranges, and the
//! values beyond drawn one by one as '+' (the convention of the paper's Fig. 19).

use super::font::FAMILY;
use crate::eval::stats::quantile;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Box-plot geometry of a sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Tukey {
    /// 25th percentile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// 75th percentile.
    pub q3: f64,
    /// Lower whisker end.
    pub low: f64,
    /// Upper whisker end.
    pub high: f64,
    /// Values beyond the whiskers.
    pub outliers: Vec<f64>,
}

/// The box-plot geometry of the finite values; None when there are none.
pub fn tukey(values: &[f64]) -> Option<Tukey> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let (q1, median, q3) = (quantile(&v, 0.25)?, quantile(&v, 0.5)?, quantile(&v, 0.75)?);
    let (lo_fence, hi_fence) = (q1 - 1.5 * (q3 - q1), q3 + 1.5 * (q3 - q1));
    let inside = || {
        v.iter()
            .copied()
            .filter(|x| (lo_fence..=hi_fence).contains(x))
    };
    Some(Tukey {
        q1,
        median,
        q3,
        low: inside().next().unwrap_or(q1),
        high: inside().next_back().unwrap_or(q3),
        outliers: v
            .iter()
            .copied()
            .filter(|x| !(lo_fence..=hi_fence).contains(x))
            .collect(),
    })
}

/// A chart with a numeric x axis whose integer positions are categories.
pub type CategoryChart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws one box centred at `x`, `width` wide in axis units; outliers above `clip_top` are drawn
/// at it (so that a long tail does not squash the boxes).
pub fn draw_box(
    chart: &mut CategoryChart,
    x: f64,
    width: f64,
    t: &Tukey,
    color: RGBColor,
    clip_top: f64,
) -> anyhow::Result<()> {
    let (l, r) = (x - width / 2.0, x + width / 2.0);
    let style = color.stroke_width(2);
    chart.draw_series([Rectangle::new(
        [(l, t.q1), (r, t.q3)],
        color.mix(0.25).filled(),
    )])?;
    chart.draw_series([Rectangle::new([(l, t.q1), (r, t.q3)], style)])?;
    chart.draw_series([
        PathElement::new(vec![(l, t.median), (r, t.median)], BLACK.stroke_width(3)),
        PathElement::new(vec![(x, t.q3), (x, t.high.min(clip_top))], style),
        PathElement::new(vec![(x, t.q1), (x, t.low)], style),
        PathElement::new(
            vec![
                (x - width / 4.0, t.high.min(clip_top)),
                (x + width / 4.0, t.high.min(clip_top)),
            ],
            style,
        ),
        PathElement::new(
            vec![(x - width / 4.0, t.low), (x + width / 4.0, t.low)],
            style,
        ),
    ])?;
    chart.draw_series(
        t.outliers
            .iter()
            .map(|&y| Cross::new((x, y.min(clip_top)), 4, color.stroke_width(1))),
    )?;
    Ok(())
}

/// A chart over `labels.len()` categories at x = 0, 1, ... with the y axis `y`, mesh drawn.
pub fn category_chart<'a, 'b>(
    area: &'a DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>,
    title: &str,
    labels: &[String],
    y: std::ops::Range<f64>,
    y_desc: &str,
) -> anyhow::Result<CategoryChart<'a, 'b>> {
    let n = labels.len().max(1);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FAMILY, 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..n as f64 - 0.5, y)?;
    let name = |x: &f64| {
        let i = x.round();
        if (x - i).abs() < 1e-6 && i >= 0.0 {
            labels.get(i as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&name)
        .y_desc(y_desc)
        .label_style((FAMILY, 14))
        .draw()?;
    Ok(chart)
}

/// Draws the paper's figure as a short red bar at `x`.
pub fn draw_paper_mark(
    chart: &mut CategoryChart,
    x: f64,
    width: f64,
    y: f64,
) -> anyhow::Result<()> {
    chart.draw_series([PathElement::new(
        vec![(x - width / 2.0, y), (x + width / 2.0, y)],
        PAPER.stroke_width(3),
    )])?;
    Ok(())
}

/// Colour of the paper's figures.
pub const PAPER: RGBColor = RGBColor(214, 39, 40);

/// Colours of the runs compared side by side.
pub const RUNS: [RGBColor; 4] = [
    RGBColor(255, 127, 14),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

#[cfg(test)]
mod tests {
    use super::tukey;

    #[test]
    fn whiskers_stop_at_the_last_value_inside_the_fences() {
        // q1 = 2, q3 = 4, fences -1 and 7: 100 is an outlier, the upper whisker ends at 5.
        let t = tukey(&[1.0, 2.0, 3.0, 4.0, 5.0, 2.0, 4.0, 3.0, 100.0]).unwrap();
        assert_eq!((t.q1, t.median, t.q3), (2.0, 3.0, 4.0));
        assert_eq!((t.low, t.high), (1.0, 5.0));
        assert_eq!(t.outliers, vec![100.0]);
        assert!(tukey(&[]).is_none());
    }
}
