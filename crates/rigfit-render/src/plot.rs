//! Line charts: per-frame curves for `track` and `surface`, and the benchmarks' plots
//! (linear or logarithmic axes, several named series on the same axes).

use tiny_skia::{LineCap, LineJoin, Paint, PathBuilder, Stroke, Transform};

use crate::color::{self, Color};
use crate::image::{Image, text_width};

/// One named curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    /// `(x, y)` points in order; non-finite ones (and non-positive ones on a log axis) are
    /// skipped.
    pub points: Vec<(f64, f64)>,
    /// `None`: the palette colour of the series' position.
    pub color: Option<Color>,
}

impl Series {
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            color: None,
        }
    }
}

/// A line chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_log: bool,
    pub y_log: bool,
    /// The picture's size in pixels.
    pub width: u32,
    pub height: u32,
    pub series: Vec<Series>,
}

impl Chart {
    /// An empty 720 x 360 chart with linear axes.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_log: false,
            y_log: false,
            width: 720,
            height: 360,
            series: Vec::new(),
        }
    }
}

/// Per-frame figures of a tracking run (`track`, `surface`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Error against ground truth per frame, when ground truth is given.
    pub error: Option<Vec<f64>>,
    /// What the error is measured in, e.g. "mean joint error (m)".
    pub error_label: String,
    /// Points the solver kept per frame.
    pub inliers: Vec<f64>,
    /// Seconds the solver took per frame.
    pub seconds: Vec<f64>,
}

/// A curve over frames: `values[i]` at frame `i`.
pub fn plot_series(title: &str, y_label: &str, values: &[f64], width: u32, height: u32) -> Image {
    let mut chart = Chart::new(title, "frame", y_label);
    chart.width = width;
    chart.height = height;
    let mut series = Series::new(
        title,
        values
            .iter()
            .enumerate()
            .map(|(i, &v)| (i as f64, v))
            .collect(),
    );
    series.color = Some(color::palette(0));
    chart.series.push(series);
    line_chart(&chart)
}

/// The per-frame plots, one above the other, each `width` wide: error (when given), inlier
/// count and milliseconds per frame.
pub fn frame_plots(stats: &FrameStats, width: u32) -> Image {
    let height = 240;
    let mut plots = Vec::new();
    if let Some(error) = &stats.error {
        let label = if stats.error_label.is_empty() {
            "error"
        } else {
            &stats.error_label
        };
        plots.push(plot_series("error per frame", label, error, width, height));
    }
    plots.push(plot_series(
        "inliers per frame",
        "inliers",
        &stats.inliers,
        width,
        height,
    ));
    let ms: Vec<f64> = stats.seconds.iter().map(|s| s * 1000.0).collect();
    plots.push(plot_series("time per frame", "ms", &ms, width, height));
    Image::stack_vertical(&plots, color::BACKGROUND)
}

/// One axis: its range and how values map onto it.
#[derive(Clone, Copy, Debug)]
struct Axis {
    log: bool,
    /// The range, in log10 units on a log axis.
    lo: f64,
    hi: f64,
}

impl Axis {
    fn from_values(values: impl Iterator<Item = f64>, log: bool) -> Self {
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
            let v = if log { v.log10() } else { v };
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            (lo, hi) = (0.0, 1.0);
        }
        if log {
            lo = lo.floor();
            hi = hi.ceil().max(lo + 1.0);
        } else {
            if lo > 0.0 && lo < 0.5 * hi {
                lo = 0.0;
            }
            if hi - lo < 1e-12 * hi.abs().max(1e-300) {
                let pad = if hi == 0.0 { 1.0 } else { hi.abs() * 0.1 };
                (lo, hi) = (lo - pad, hi + pad);
            }
            let step = nice_step(hi - lo);
            lo = (lo / step).floor() * step;
            hi = (hi / step).ceil() * step;
        }
        Self { log, lo, hi }
    }

    /// The position of `v` along the axis, 0 at `lo` and 1 at `hi` (`None` when it cannot
    /// be shown).
    fn fraction(&self, v: f64) -> Option<f64> {
        let v = if self.log {
            if v <= 0.0 {
                return None;
            }
            v.log10()
        } else {
            v
        };
        v.is_finite().then(|| (v - self.lo) / (self.hi - self.lo))
    }

    /// Labelled ticks `(value, label)` and unlabelled minor ticks.
    fn ticks(&self) -> (Vec<(f64, String)>, Vec<f64>) {
        let mut major = Vec::new();
        let mut minor = Vec::new();
        if self.log {
            let (lo, hi) = (self.lo as i32, self.hi as i32);
            let every = ((hi - lo) as usize).div_ceil(8).max(1);
            for k in lo..=hi {
                let v = 10f64.powi(k);
                if (k - lo) as usize % every == 0 {
                    major.push((v, format_log_tick(k)));
                }
                if k < hi {
                    for m in 2..10 {
                        // Few decades: 2 and 5 get labels too.
                        if hi - lo <= 2 && (m == 2 || m == 5) {
                            major.push((m as f64 * v, format_log_value(m, k)));
                        } else {
                            minor.push(m as f64 * v);
                        }
                    }
                }
            }
        } else {
            let step = nice_step(self.hi - self.lo);
            let n = ((self.hi - self.lo) / step).round() as i64;
            for i in 0..=n {
                let v = self.lo + i as f64 * step;
                major.push((v, format_tick(v, step)));
            }
        }
        (major, minor)
    }
}

/// A step of 1, 2 or 5 times a power of ten giving four to eight ticks over `span`.
fn nice_step(span: f64) -> f64 {
    let raw = span.abs().max(1e-300) / 6.0;
    let power = 10f64.powf(raw.log10().floor());
    let m = raw / power;
    let nice = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * power
}

fn format_tick(v: f64, step: f64) -> String {
    let v = if v.abs() < step * 1e-9 { 0.0 } else { v };
    if step >= 1.0 && v.abs() < 1e7 {
        format!("{v:.0}")
    } else if step >= 1e-4 {
        let decimals = (-step.log10()).ceil().max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.1e}")
    }
}

/// `mantissa * 10^k` written plainly when short.
fn format_log_value(mantissa: u32, k: i32) -> String {
    if (0..=6).contains(&k) {
        format!("{}", mantissa as u64 * 10u64.pow(k as u32))
    } else if (-4..0).contains(&k) {
        format!("{}", mantissa as f64 * 10f64.powi(k))
    } else {
        format!("{mantissa}e{k}")
    }
}

fn format_log_tick(k: i32) -> String {
    if (0..=6).contains(&k) {
        format!("{}", 10u64.pow(k as u32))
    } else if (-4..0).contains(&k) {
        format!("{}", 10f64.powi(k))
    } else {
        format!("1e{k}")
    }
}

/// Draws `chart`.
pub fn line_chart(chart: &Chart) -> Image {
    let (w, h) = (chart.width.clamp(200, 4096), chart.height.clamp(120, 4096));
    let mut image = Image::new(w, h, color::BACKGROUND);
    let scale = 1;
    // The header: the title, then the y label and the legend on the lines below it.
    let title_scale = if text_width(&chart.title, 2) <= w as i64 - 16 {
        2
    } else {
        1
    };
    image.text(8, 6, &chart.title, title_scale, color::INK);
    let mut line_y = 6 + 8 * title_scale as i64 + 8;
    let y_label = if chart.y_log {
        format!("{} (log)", chart.y_label)
    } else {
        chart.y_label.clone()
    };
    let mut cursor = 8 + image.text(8, line_y, &y_label, scale, color::INK);
    if chart.series.len() > 1 {
        cursor += 24;
        for (i, series) in chart.series.iter().enumerate() {
            let c = series.color.unwrap_or_else(|| color::palette(i));
            let entry = 28 + text_width(&series.name, scale);
            if cursor + entry > w as i64 - 8 {
                cursor = 8;
                line_y += 14;
            }
            image.fill_pixels(cursor, line_y + 2, 22, 4, c);
            image.text(cursor + 28, line_y, &series.name, scale, color::INK);
            cursor += entry + 20;
        }
    }
    let (left, right, top, bottom) = (78.0, 28.0, (line_y + 20) as f64, 40.0);
    let plot_w = w as f64 - left - right;
    let plot_h = h as f64 - top - bottom;
    let all = || chart.series.iter().flat_map(|s| s.points.iter());
    let x_axis = Axis::from_values(all().map(|p| p.0), chart.x_log);
    let y_axis = Axis::from_values(all().map(|p| p.1), chart.y_log);
    let px = |v: f64| x_axis.fraction(v).map(|f| left + f * plot_w);
    let py = |v: f64| y_axis.fraction(v).map(|f| top + (1.0 - f) * plot_h);

    // Grid and ticks.
    let (x_major, x_minor) = x_axis.ticks();
    let (y_major, y_minor) = y_axis.ticks();
    for v in x_minor.iter().chain(x_major.iter().map(|t| &t.0)) {
        if let Some(x) = px(*v) {
            image.fill_pixels(x.round() as i64, top as i64, 1, plot_h as i64, color::GRID);
        }
    }
    for v in y_minor.iter().chain(y_major.iter().map(|t| &t.0)) {
        if let Some(y) = py(*v) {
            image.fill_pixels(left as i64, y.round() as i64, plot_w as i64, 1, color::GRID);
        }
    }
    for (v, label) in &x_major {
        if let Some(x) = px(*v) {
            let x = x.round() as i64;
            image.fill_pixels(x, (top + plot_h) as i64, 1, 5, color::INK);
            image.text(
                x - text_width(label, scale) / 2,
                (top + plot_h) as i64 + 8,
                label,
                scale,
                color::INK,
            );
        }
    }
    for (v, label) in &y_major {
        if let Some(y) = py(*v) {
            let y = y.round() as i64;
            image.fill_pixels(left as i64 - 5, y, 5, 1, color::INK);
            image.text(
                left as i64 - 8 - text_width(label, scale),
                y - 4,
                label,
                scale,
                color::INK,
            );
        }
    }
    // Axes.
    image.fill_pixels(left as i64, top as i64, 1, plot_h as i64 + 1, color::INK);
    image.fill_pixels(
        left as i64,
        (top + plot_h) as i64,
        plot_w as i64 + 1,
        1,
        color::INK,
    );
    // The x label, under the axis at the right.
    let x_label = if chart.x_log {
        format!("{} (log)", chart.x_label)
    } else {
        chart.x_label.clone()
    };
    image.text(
        left as i64 + plot_w as i64 - text_width(&x_label, scale),
        h as i64 - 14,
        &x_label,
        scale,
        color::INK,
    );

    // The curves.
    let points_total: usize = chart.series.iter().map(|s| s.points.len()).sum();
    for (i, series) in chart.series.iter().enumerate() {
        let c = series.color.unwrap_or_else(|| color::palette(i));
        let pts: Vec<(f32, f32)> = series
            .points
            .iter()
            .filter_map(|&(x, y)| Some((px(x)? as f32, py(y)? as f32)))
            .collect();
        let mut pb = PathBuilder::new();
        for (k, &(x, y)) in pts.iter().enumerate() {
            if k == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        let mut paint = Paint::default();
        paint.set_color(c.to_skia());
        paint.anti_alias = true;
        if pts.len() >= 2 {
            if let Some(path) = pb.finish() {
                let stroke = Stroke {
                    width: 2.0,
                    line_cap: LineCap::Round,
                    line_join: LineJoin::Round,
                    ..Stroke::default()
                };
                image
                    .pixmap
                    .stroke_path(&path, &paint, &stroke, Transform::identity(), None);
            }
        }
        if pts.len() <= 60 || points_total <= 200 {
            for &(x, y) in &pts {
                if let Some(path) = PathBuilder::from_circle(x, y, 3.5) {
                    image.pixmap.fill_path(
                        &path,
                        &paint,
                        tiny_skia::FillRule::Winding,
                        Transform::identity(),
                        None,
                    );
                }
            }
        }
    }

    image
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(6.0), 1.0);
        assert_eq!(nice_step(12.0), 2.0);
        assert_eq!(nice_step(30.0), 5.0);
        assert!((nice_step(0.06) - 0.01).abs() < 1e-15);
    }

    #[test]
    fn log_axis_spans_whole_decades() {
        let few = Axis::from_values([12.0, 80.0].into_iter(), true);
        let labels: Vec<String> = few.ticks().0.into_iter().map(|t| t.1).collect();
        assert_eq!(labels, ["10", "20", "50", "100"]);
        let a = Axis::from_values([3.0, 4500.0].into_iter(), true);
        assert_eq!((a.lo, a.hi), (0.0, 4.0));
        let (major, minor) = a.ticks();
        assert_eq!(major.len(), 5);
        assert_eq!(major[3].1, "1000");
        assert_eq!(minor.len(), 32);
    }

    #[test]
    fn chart_draws_its_curve() {
        let mut chart = Chart::new("t", "x", "y");
        chart
            .series
            .push(Series::new("a", vec![(0.0, 0.0), (1.0, 1.0)]));
        let image = line_chart(&chart);
        assert_eq!((image.width(), image.height()), (720, 360));
        // The diagonal is drawn in the first palette colour, across most of the width.
        let columns = (0..image.width())
            .filter(|&x| (0..image.height()).any(|y| image.pixel(x, y) == Some(color::palette(0))))
            .count();
        assert!(columns > 500, "{columns} columns with the curve");
    }
}
