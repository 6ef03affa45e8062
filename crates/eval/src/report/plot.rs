//! PNG line charts for the report (plotters, bitmap backend, no system fonts).
//!
//! Text is drawn with DejaVu Sans, committed under `assets/fonts/` (Bitstream Vera
//! licence, `assets/fonts/DejaVuSans-LICENSE.txt`) and registered with plotters'
//! `ab_glyph` font backend, so plots render the same on any machine.

use std::path::Path;
use std::sync::Once;

use anyhow::{Result, anyhow};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

const FONT: &[u8] = include_bytes!("../../../../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_err() {
            tracing::warn!("the embedded plot font could not be parsed; plots carry no text");
        }
    });
}

/// One line of a chart.
#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// What a chart shows.
#[derive(Debug, Clone)]
pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub log_x: bool,
    pub log_y: bool,
}

/// The range of `v` padded for a chart (log: multiplicative, linear: 5 %).
fn range(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = v
        .filter(|x| x.is_finite() && (!log || *x > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !lo.is_finite() {
        (lo, hi) = if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        if hi <= lo {
            (lo, hi) = (lo / 2.0, hi * 2.0);
        }
        (lo / 1.3, hi * 1.3)
    } else {
        if hi <= lo {
            (lo, hi) = (lo - 0.5, hi + 0.5);
        }
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    }
}

/// Draws `series` as lines with point markers into a 900×560 PNG at `path`.
pub fn line_chart(path: &Path, chart: &Chart, series: &[Series]) -> Result<()> {
    register_font();
    let pts = || series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = range(pts().map(|p| p.0), chart.log_x);
    let (y0, y1) = range(pts().map(|p| p.1), chart.log_y);
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(chart.title, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(70);
    // Four coordinate kinds: plotters types each combination differently.
    match (chart.log_x, chart.log_y) {
        (false, false) => draw(builder.build_cartesian_2d(x0..x1, y0..y1), chart, series),
        (true, false) => draw(
            builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1),
            chart,
            series,
        ),
        (false, true) => draw(
            builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()),
            chart,
            series,
        ),
        (true, true) => draw(
            builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()),
            chart,
            series,
        ),
    }?;
    root.present()
        .map_err(|e| anyhow!("writing {}: {e}", path.display()))?;
    Ok(())
}

/// A chart context as `ChartBuilder::build_cartesian_2d` returns it.
type Built<'a, X, Y> = Result<
    ChartContext<'a, BitMapBackend<'a>, Cartesian2d<X, Y>>,
    DrawingAreaErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>,
>;

fn draw<'a, X, Y>(ctx: Built<'a, X, Y>, chart: &Chart, series: &[Series]) -> Result<()>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut ctx = ctx.map_err(|e| anyhow!("{e}"))?;
    ctx.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    for (i, s) in series.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let style = ShapeStyle::from(colour).stroke_width(2);
        ctx.draw_series(LineSeries::new(s.points.iter().copied(), style))
            .map_err(|e| anyhow!("{e}"))?
            .label(s.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        ctx.draw_series(
            s.points
                .iter()
                .map(|&p| Circle::new(p, 3, ShapeStyle::from(colour).filled())),
        )
        .map_err(|e| anyhow!("{e}"))?;
    }
    if series.len() > 1 {
        ctx.configure_series_labels()
            .label_font((FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
    }
    Ok(())
}

/// A tick label: at most four significant digits, no trailing zeros (log axes tick at
/// steps like 0.1 × 3 that f64 does not hold exactly).
fn tick(v: &f64) -> String {
    if *v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Least-squares slope of log(y) against log(x) (the exponent of a power law).
pub fn loglog_slope(points: &[(f64, f64)]) -> Option<f64> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if p.len() < 2 {
        return None;
    }
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law() {
        let p: Vec<_> = [1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|&x| (x, 3.0 * x * x))
            .collect();
        assert!((loglog_slope(&p).unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(loglog_slope(&[(1.0, 1.0)]), None);
    }

    #[test]
    fn ticks_read_as_numbers() {
        assert_eq!(tick(&0.30000000000000004), "0.3");
        assert_eq!(tick(&2.0), "2");
        assert_eq!(tick(&12345.0), "12345");
        assert_eq!(tick(&0.00125), "0.00125");
        assert_eq!(tick(&0.0), "0");
    }
}
