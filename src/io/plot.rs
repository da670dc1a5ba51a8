//! SVG line plots of a run's main result, written beside its CSV (plotters' SVG backend: text
//! stays text, so no font files are needed and a browser or Inkscape opens the file).
//!
//! One small description type, [`Plot`], for every engine: a title, axis labels with units,
//! optional logarithmic axes and any number of labelled series with optional error bars.

use crate::error::{invalid, Error};
use crate::Result;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::path::Path;

/// One labelled curve: points `(x, y)` in the axes' units, and optionally a half-width error
/// bar per point (one standard error, say), drawn as a vertical segment.
#[derive(Debug, Clone, Default)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub y_err: Option<Vec<f64>>,
}

/// A line plot: axis labels carry the units, e.g. `"time (s)"`.
#[derive(Debug, Clone, Default)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub series: Vec<Series>,
}

/// Plot size in SVG pixels.
const SIZE: (u32, u32) = (720, 460);

/// Line colours, cycled over the series (a colour-blind-safe qualitative palette, Okabe & Ito).
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// The closed range of finite values (positive ones on a log axis), padded a little so no
/// point sits on the frame; an empty or single-valued range is widened around its value.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return None;
    }
    if log {
        let (a, b) = (lo.log10(), hi.log10());
        let pad = if b > a { 0.04 * (b - a) } else { 0.5 };
        Some((10f64.powf(a - pad), 10f64.powf(b + pad)))
    } else {
        let pad = if hi > lo {
            0.04 * (hi - lo)
        } else {
            0.5 * lo.abs().max(1e-300)
        };
        Some((lo - pad, hi + pad))
    }
}

/// Writes `plot` as an SVG file at `path` (through a temporary file and a rename). A plot
/// without a single finite point is refused, naming the file: an empty picture is no result.
pub fn write_svg(path: &Path, plot: &Plot) -> Result<()> {
    let svg = render_svg(plot, SIZE).map_err(|e| Error::File {
        path: path.display().to_string(),
        msg: e.to_string(),
    })?;
    super::write_atomic(path, svg.as_bytes())
}

/// The SVG text of `plot` at `size` pixels (for embedding in an HTML page).
pub fn render_svg(plot: &Plot, size: (u32, u32)) -> Result<String> {
    let ys = |s: &Series| -> Vec<f64> {
        let err = s.y_err.as_deref();
        s.points
            .iter()
            .enumerate()
            .flat_map(|(i, &(_, y))| {
                let e = err.and_then(|e| e.get(i).copied()).unwrap_or(0.0).abs();
                [y - e, y + e]
            })
            .collect()
    };
    let x_range = axis_range(
        plot.series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0)),
        plot.log_x,
    );
    let y_range = axis_range(plot.series.iter().flat_map(ys), plot.log_y);
    let (Some((x0, x1)), Some((y0, y1))) = (x_range, y_range) else {
        return invalid(format!("plot '{}' has no finite point to draw", plot.title));
    };
    let rows = plot.series.iter().filter(|s| !s.label.is_empty()).count();
    let (y0, y1) = legend_band((y0, y1), plot.log_y, rows, size.1);
    let spans = (x1 - x0, y1 - y0);
    let mut svg = String::new();
    {
        let backend = SVGBackend::with_string(&mut svg, size);
        let drawn = match (plot.log_x, plot.log_y) {
            (false, false) => draw(backend, plot, x0..x1, y0..y1, spans),
            (true, false) => draw(backend, plot, (x0..x1).log_scale(), y0..y1, spans),
            (false, true) => draw(backend, plot, x0..x1, (y0..y1).log_scale(), spans),
            (true, true) => draw(
                backend,
                plot,
                (x0..x1).log_scale(),
                (y0..y1).log_scale(),
                spans,
            ),
        };
        drawn.map_err(|e| Error::InvalidInput(format!("cannot draw the plot: {e}")))?;
    }
    Ok(svg)
}

/// Pixels of one legend row, and of the legend's frame and margin (plotters' default legend
/// font and spacing).
const LEGEND_ROW_PX: f64 = 20.0;
const LEGEND_FRAME_PX: f64 = 24.0;
/// Pixels of the figure outside the plotting area in height (caption, margins, x labels).
const OUTSIDE_PLOT_PX: f64 = 100.0;

/// The y range `(y0, y1)` raised at the top by an empty band as high as a legend of `rows`
/// rows in a figure `height_px` high, so the legend (upper right) covers no point of any
/// curve; at most 60 % of the axis (log axes: in decades).
fn legend_band((y0, y1): (f64, f64), log: bool, rows: usize, height_px: u32) -> (f64, f64) {
    if rows == 0 {
        return (y0, y1);
    }
    let plot_px = (f64::from(height_px) - OUTSIDE_PLOT_PX).max(1.0);
    let f = ((rows as f64 * LEGEND_ROW_PX + LEGEND_FRAME_PX) / plot_px).min(0.6);
    // the band takes the fraction f of the new axis: (top - y1) = f (top - y0)
    if log {
        let (a, b) = (y0.log10(), y1.log10());
        (y0, 10f64.powf((b - f * a) / (1.0 - f)))
    } else {
        (y0, (y1 - f * y0) / (1.0 - f))
    }
}

/// A tick label: at most four significant digits, exponent form outside 1e-3..1e5; a value
/// within 1e-9 of the axis span `span` of zero is the tick at zero that rounding missed.
fn tick(v: &f64, span: f64) -> String {
    let v = *v;
    if v == 0.0 || v.abs() < 1e-9 * span.abs() {
        return "0".into();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    if (-3..5).contains(&mag) {
        let text = format!("{v:.prec$}", prec = (3 - mag).max(0) as usize);
        let text = if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        };
        if text == "-0" {
            "0".into()
        } else {
            text
        }
    } else {
        let text = format!("{v:.3e}");
        let (m, e) = text.split_once('e').unwrap_or((&text, "0"));
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.')
        } else {
            m
        };
        format!("{m}e{e}")
    }
}

/// Draws the frame, the mesh with labels, every series with its error bars, and the legend.
fn draw<'a, X, Y>(
    backend: SVGBackend<'a>,
    plot: &'a Plot,
    x: X,
    y: Y,
    (x_span, y_span): (f64, f64),
) -> std::result::Result<(), Box<dyn std::error::Error + 'a>>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let root = backend.into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(&plot.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_label_formatter(&|v| tick(v, x_span))
        .y_label_formatter(&|v| tick(v, y_span))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (k, s) in plot.series.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        // the last series (a closed form, where there is one) is drawn narrower on top of the
        // others, so a result it matches stays visible on both sides of it
        let width = if k + 1 == plot.series.len() { 2 } else { 4 };
        let finite: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .collect();
        let line =
            chart.draw_series(LineSeries::new(finite.clone(), colour.stroke_width(width)))?;
        if !s.label.is_empty() {
            line.label(s.label.as_str()).legend(move |(px, py)| {
                PathElement::new(vec![(px, py), (px + 20, py)], colour.stroke_width(width))
            });
        }
        if finite.len() <= 60 {
            chart.draw_series(finite.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        }
        if let Some(err) = &s.y_err {
            let bars = s
                .points
                .iter()
                .zip(err)
                .filter(|((a, b), e)| a.is_finite() && b.is_finite() && e.is_finite())
                .map(|(&(a, b), &e)| {
                    PathElement::new(vec![(a, b - e.abs()), (a, b + e.abs())], colour)
                });
            chart.draw_series(bars)?;
        }
    }
    if plot.series.iter().any(|s| !s.label.is_empty()) {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// A plot of two columns of a CSV table (header row), one series per distinct value of the
/// `group_by` columns: the one way every engine draws its main result from the CSV it wrote.
#[derive(Debug, Clone, Default)]
pub struct CsvPlot<'a> {
    pub title: &'a str,
    /// Column names of x, y and (optionally) the half-width of y's error bar.
    pub x: &'a str,
    pub y: &'a str,
    pub y_err: Option<&'a str>,
    /// Columns whose values name a series ("region=TOP, alpha_deg=90").
    pub group_by: &'a [&'a str],
    /// Axis labels with units.
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub log_x: bool,
    pub log_y: bool,
}

impl CsvPlot<'_> {
    /// The plot of `csv_text`; a missing column or a value that is not a number is an error
    /// naming it (rows whose y is empty, a quantity not defined there, are left out).
    pub fn build(&self, csv_text: &str) -> Result<Plot> {
        let mut reader = csv::Reader::from_reader(csv_text.as_bytes());
        let header = reader
            .headers()
            .map_err(|e| Error::InvalidInput(format!("plot '{}': {e}", self.title)))?
            .clone();
        let col = |name: &str| {
            header.iter().position(|h| h == name).ok_or_else(|| {
                Error::InvalidInput(format!("plot '{}': no column '{name}'", self.title))
            })
        };
        let (ix, iy) = (col(self.x)?, col(self.y)?);
        let ie = self.y_err.map(col).transpose()?;
        let groups: Vec<usize> = self
            .group_by
            .iter()
            .map(|g| col(g))
            .collect::<Result<_>>()?;
        let mut series: Vec<Series> = Vec::new();
        for record in reader.records() {
            let r =
                record.map_err(|e| Error::InvalidInput(format!("plot '{}': {e}", self.title)))?;
            let num = |i: usize| -> Result<Option<f64>> {
                let text = r.get(i).unwrap_or("").trim();
                if text.is_empty() || text == "null" {
                    return Ok(None);
                }
                text.parse().map(Some).map_err(|_| {
                    Error::InvalidInput(format!(
                        "plot '{}': column '{}' holds '{text}', not a number",
                        self.title, &header[i]
                    ))
                })
            };
            let (Some(x), Some(y)) = (num(ix)?, num(iy)?) else {
                continue;
            };
            let label = groups
                .iter()
                .map(|&g| format!("{}={}", &header[g], r.get(g).unwrap_or("")))
                .collect::<Vec<_>>()
                .join(", ");
            let k = match series.iter().position(|s| s.label == label) {
                Some(k) => k,
                None => {
                    series.push(Series {
                        label: label.clone(),
                        points: Vec::new(),
                        y_err: ie.map(|_| Vec::new()),
                    });
                    series.len() - 1
                }
            };
            series[k].points.push((x, y));
            if let (Some(i), Some(errs)) = (ie, series[k].y_err.as_mut()) {
                errs.push(num(i)?.unwrap_or(0.0));
            }
        }
        Ok(Plot {
            title: self.title.to_string(),
            x_label: self.x_label.to_string(),
            y_label: self.y_label.to_string(),
            log_x: self.log_x,
            log_y: self.log_y,
            series,
        })
    }

    /// Builds the plot of `csv_text` and writes it as SVG at `path`.
    pub fn write(&self, path: &Path, csv_text: &str) -> Result<()> {
        write_svg(path, &self.build(csv_text)?)
    }

    /// As [`CsvPlot::write`], for a run's pictures: the CSV beside it holds the result, so a
    /// plot that cannot be drawn (say, a kinetic energy that is 0 throughout on a log axis)
    /// is reported on stderr, naming the file, and the run goes on.
    pub fn write_or_warn(&self, path: &Path, csv_text: &str) {
        if let Err(e) = self.write(path, csv_text) {
            eprintln!("warning: {} not written: {e}", path.display());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("porelab-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn writes_an_svg_with_its_labels_and_every_series() {
        let path = tmp("a.svg");
        let plot = Plot {
            title: "capture".into(),
            x_label: "time (s)".into(),
            y_label: "captured fraction".into(),
            series: vec![
                Series {
                    label: "TOP".into(),
                    points: vec![(0.0, 0.0), (1.0, 0.5), (2.0, 0.9)],
                    y_err: Some(vec![0.0, 0.05, 0.02]),
                },
                Series {
                    label: "SIDE".into(),
                    points: vec![(0.0, 0.0), (2.0, 0.3)],
                    y_err: None,
                },
            ],
            ..Default::default()
        };
        write_svg(&path, &plot).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("<svg"));
        for s in ["capture", "time (s)", "captured fraction", "TOP", "SIDE"] {
            assert!(text.contains(s), "{s} missing from the SVG");
        }
    }

    #[test]
    fn csv_plots_group_rows_into_series_and_name_bad_columns() {
        let csv = "region,time_s,f,se\nTOP,0,0,0\nTOP,1,0.5,0.1\nSIDE,0,0,0\nSIDE,1,,\n";
        let spec = CsvPlot {
            title: "capture",
            x: "time_s",
            y: "f",
            y_err: Some("se"),
            group_by: &["region"],
            x_label: "time (s)",
            y_label: "captured fraction",
            ..Default::default()
        };
        let p = spec.build(csv).unwrap();
        assert_eq!(p.series.len(), 2);
        assert_eq!(p.series[0].label, "region=TOP");
        assert_eq!(p.series[0].points, vec![(0.0, 0.0), (1.0, 0.5)]);
        assert_eq!(p.series[0].y_err, Some(vec![0.0, 0.1]));
        assert_eq!(p.series[1].points.len(), 1, "an empty y is left out");
        assert_eq!(tick(&9.999999999999998e-9, 1e-8), "1e-8");
        assert_eq!(tick(&0.00012, 1.0), "1.2e-4");
        assert_eq!(tick(&0.0012, 1.0), "0.0012");
        assert_eq!(tick(&-0.0, 1.0), "0");
        assert_eq!(tick(&250.0, 1.0), "250");
        // the zero tick of a linear axis, missed by rounding (an LBM profile's -1.355e-20)
        assert_eq!(tick(&-1.355e-20, 2e-3), "0");
        assert_eq!(tick(&-1.355e-20, 1e-19), "-1.355e-20");
        let e = CsvPlot {
            y: "g",
            ..spec.clone()
        }
        .build(csv)
        .unwrap_err()
        .to_string();
        assert!(e.contains("no column 'g'"), "{e}");
        let e = spec
            .build("region,time_s,f,se\nTOP,x,1,0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'time_s' holds 'x'"), "{e}");
    }

    #[test]
    fn legend_band_leaves_the_top_free_for_the_legend() {
        // 2 rows in 460 px: (2 * 20 + 24) / 360 = 0.178 of the new axis above the data
        let (y0, y1) = legend_band((0.0, 1.0), false, 2, 460);
        let f = (y1 - 1.0) / (y1 - y0);
        assert!(y0 == 0.0 && (f - 64.0 / 360.0).abs() < 1e-12, "{f}");
        let (a, b) = legend_band((1e-6, 1e-2), true, 2, 460);
        let f = (b.log10() + 2.0) / (b.log10() - a.log10());
        assert!(a == 1e-6 && (f - 64.0 / 360.0).abs() < 1e-12, "{f}");
        assert_eq!(legend_band((0.0, 1.0), false, 0, 460), (0.0, 1.0));
        // many rows take at most 60 % of the axis
        let (_, y1) = legend_band((0.0, 1.0), false, 40, 460);
        assert!((1.0 - 1.0 / y1 - 0.6).abs() < 1e-12);
    }

    #[test]
    fn log_axes_drop_non_positive_values_and_empty_plots_are_refused() {
        let path = tmp("b.svg");
        let mut plot = Plot {
            title: "K".into(),
            x_label: "N".into(),
            y_label: "error".into(),
            log_x: true,
            log_y: true,
            series: vec![Series {
                label: String::new(),
                points: vec![(10.0, 1e-2), (100.0, 1e-4), (0.0, 0.0)],
                y_err: None,
            }],
        };
        write_svg(&path, &plot).unwrap();
        plot.series[0].points = vec![(f64::NAN, 1.0), (0.0, -1.0)];
        let e = write_svg(&path, &plot).unwrap_err().to_string();
        assert!(e.contains("no finite point"), "{e}");
    }
}
