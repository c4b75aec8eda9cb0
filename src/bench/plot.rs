//! Log-log line plots as PNG (plotters' bitmap backend, written with the `image` crate).
//!
//! Text is drawn with the sans-serif font the editor already carries (egui's Ubuntu Light, from
//! `epaint_default_fonts`), registered once with plotters' `ab_glyph` backend: the plots look the
//! same on every machine, also on one without any font installed (a GPU server, a container).

use super::BenchError;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// Registers the embedded font as plotters' "sans-serif" (once per process); the error, if any.
fn register_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font("sans-serif", FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
                .map_err(|_| "the embedded font (Ubuntu Light) is not a valid font file".to_string())
        })
        .clone()
}

/// One curve.
pub struct Series {
    pub name: String,
    pub color: RGBColor,
    /// (x, y), both positive (others are left out).
    pub points: Vec<(f64, f64)>,
    /// Per point: on the Pareto front (drawn filled and joined); `None` joins every point in x order.
    pub front: Option<Vec<bool>>,
}

pub struct Plot<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub series: Vec<Series>,
}

pub const COLORS: [RGBColor; 5] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
];

fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return 0.1..10.0;
    }
    if hi <= lo * 1.5 {
        return lo / 2.0..hi * 2.0;
    }
    // A margin of a tenth of a decade on each side.
    let pad = (hi / lo).powf(0.06);
    lo / pad..hi * pad
}

/// Labelled ticks of a log axis: decades, plus 2 and 5 (or every integer multiple) when the range
/// spans few decades. plotters labels only whole decades, which leaves an axis spanning less than
/// one (1 200 to 6 700 ms) without a single label.
fn log_ticks(r: &std::ops::Range<f64>) -> (Vec<f64>, Vec<f64>) {
    let decades = (r.end / r.start).log10();
    let bold: &[f64] = if decades <= 1.2 {
        &[1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    } else if decades <= 3.5 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let (mut ticks, mut light) = (Vec::new(), Vec::new());
    let mut e = r.start.log10().floor() as i32;
    while 10f64.powi(e) <= r.end {
        for m in 1..10 {
            let x = m as f64 * 10f64.powi(e);
            if x >= r.start && x <= r.end {
                light.push(x);
            }
        }
        for m in bold {
            let x = m * 10f64.powi(e);
            if x >= r.start && x <= r.end {
                ticks.push(x);
            }
        }
        e += 1;
    }
    (ticks, light)
}

/// The corner the curves leave most empty, for the legend: every curve sampled along its segments
/// in the plot's log coordinates and counted in a box of 40% x 22% of the area at each corner and
/// at the middle of each side (ties: the corners first, upper right first).
fn legend_corner(series: &[Series], xr: &std::ops::Range<f64>, yr: &std::ops::Range<f64>) -> SeriesLabelPosition {
    let norm = |v: f64, r: &std::ops::Range<f64>| (v.ln() - r.start.ln()) / (r.end.ln() - r.start.ln());
    // Candidate boxes in order of preference: (position, x range, y range), y upward.
    let boxes = [
        (SeriesLabelPosition::UpperRight, (0.6, 1.0), (0.78, 1.0)),
        (SeriesLabelPosition::UpperLeft, (0.0, 0.4), (0.78, 1.0)),
        (SeriesLabelPosition::LowerRight, (0.6, 1.0), (0.0, 0.22)),
        (SeriesLabelPosition::LowerLeft, (0.0, 0.4), (0.0, 0.22)),
        (SeriesLabelPosition::MiddleRight, (0.6, 1.0), (0.39, 0.61)),
        (SeriesLabelPosition::MiddleLeft, (0.0, 0.4), (0.39, 0.61)),
    ];
    let mut counts = [0usize; 6];
    for s in series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite())
            .map(|p| (norm(p.0, xr), norm(p.1, yr)))
            .collect();
        let mut samples = pts.clone();
        for w in pts.windows(2) {
            samples.extend((1..16).map(|k| {
                let t = k as f64 / 16.0;
                (w[0].0 + t * (w[1].0 - w[0].0), w[0].1 + t * (w[1].1 - w[0].1))
            }));
        }
        for (x, y) in samples {
            for (c, (_, bx, by)) in counts.iter_mut().zip(&boxes) {
                *c += (x >= bx.0 && x <= bx.1 && y >= by.0 && y <= by.1) as usize;
            }
        }
    }
    let best = (0..boxes.len()).min_by_key(|&i| (counts[i], i)).unwrap_or(0);
    boxes[best].0.clone()
}

/// Draws `plot` as a `width x height` PNG at `path`.
pub fn draw(plot: &Plot, path: &Path, width: u32, height: u32) -> Result<(), BenchError> {
    let err = |e: String| BenchError::Plot { path: path.to_path_buf(), message: e };
    register_font().map_err(err)?;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let all = || plot.series.iter().flat_map(|s| s.points.iter());
        let xr = log_range(all().map(|p| p.0));
        let yr = log_range(all().map(|p| p.1));
        let mut builder = ChartBuilder::on(&root);
        builder.margin(16);
        builder.caption(plot.title, ("sans-serif", 22)).x_label_area_size(48).y_label_area_size(72);
        let ((xt, xl), (yt, yl)) = (log_ticks(&xr), log_ticks(&yr));
        let x_axis = xr.clone().log_scale().with_key_points(xt).with_light_points(xl);
        let y_axis = yr.clone().log_scale().with_key_points(yt).with_light_points(yl);
        let mut chart = builder.build_cartesian_2d(x_axis, y_axis).map_err(|e| err(e.to_string()))?;
        let mut mesh = chart.configure_mesh();
        mesh.light_line_style(RGBColor(242, 242, 242));
        mesh.x_labels(8)
            .y_labels(10)
            .x_desc(plot.x_desc)
            .y_desc(plot.y_desc)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .x_label_formatter(&|v| short(*v))
            .y_label_formatter(&|v| short(*v));
        mesh.draw().map_err(|e| err(e.to_string()))?;

        for s in &plot.series {
            let pts: Vec<(usize, (f64, f64))> = s
                .points
                .iter()
                .copied()
                .enumerate()
                .filter(|(_, (x, y))| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
                .collect();
            let color = s.color;
            let on_front = |i: usize| s.front.as_ref().is_none_or(|f| f.get(i).copied().unwrap_or(false));
            let mut line: Vec<(f64, f64)> = pts.iter().filter(|(i, _)| on_front(*i)).map(|(_, p)| *p).collect();
            line.sort_by(|a, b| a.0.total_cmp(&b.0));
            let series =
                chart.draw_series(LineSeries::new(line, color.stroke_width(2))).map_err(|e| err(e.to_string()))?;
            series
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
            // Front points filled, the others hollow.
            chart
                .draw_series(pts.iter().map(|(i, p)| {
                    let style = if on_front(*i) { color.filled() } else { color.stroke_width(1) };
                    Circle::new(*p, 4, style)
                }))
                .map_err(|e| err(e.to_string()))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(legend_corner(&plot.series, &xr, &yr))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    let img =
        image::RgbImage::from_raw(width, height, buf).ok_or_else(|| err("plot buffer has the wrong size".into()))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| BenchError::Io {
            op: "create",
            path: dir.to_path_buf(),
            source,
        })?;
    }
    img.save_with_format(path, image::ImageFormat::Png).map_err(|e| err(e.to_string()))
}

/// Tick labels: 0.001, 0.5, 20, 3e4 (log axes span decades).
fn short(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * y.abs())
    }

    /// Every log axis gets labels, also one spanning less than a decade.
    #[test]
    fn log_axes_are_labelled_within_a_decade_and_across_many() {
        let (t, _) = log_ticks(&(1200.0..6700.0));
        assert!(close(&t, &[1500.0, 2000.0, 3000.0, 4000.0, 5000.0, 6000.0]), "{t:?}");
        let (t, light) = log_ticks(&(0.03..2.0));
        assert!(close(&t, &[0.05, 0.1, 0.2, 0.5, 1.0, 2.0]), "{t:?}");
        assert!(light.len() > t.len());
        let (t, _) = log_ticks(&(0.5..2.0e5));
        assert!(close(&t, &[1.0, 10.0, 100.0, 1e3, 1e4, 1e5]), "{t:?}");
    }

    /// The title is drawn with the embedded font: dark pixels above the chart, on any machine (the
    /// H200 server had no font installed, and the system-font lookup failed the whole bench there).
    #[test]
    fn plots_carry_their_title_without_system_fonts() {
        let dir = std::env::temp_dir().join(format!("epivox-plot-{}", std::process::id()));
        let path = dir.join("plot.png");
        let series =
            vec![Series { name: "vsv".into(), color: COLORS[0], points: vec![(1.0, 0.1), (10.0, 0.01)], front: None }];
        draw(&Plot { title: "Error against time", x_desc: "ms", y_desc: "error", series }, &path, 400, 300)
            .unwrap_or_else(|e| panic!("{e}"));
        let img = image::open(&path).unwrap_or_else(|e| panic!("{e}")).to_rgb8();
        // The caption's band: the margin (16 px) down to the chart's top.
        let dark = (16..40).flat_map(|y| (0..400).map(move |x| (x, y))).filter(|&(x, y)| img.get_pixel(x, y)[0] < 128);
        assert!(dark.count() > 50, "no title text drawn");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
