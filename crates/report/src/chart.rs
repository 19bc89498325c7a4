//! Charts as plain data, rendered to SVG (inline in the report, and as files) and PNG.
//!
//! A [`Chart`] is a stack of [`Panel`]s sharing a width; each panel has series drawn as lines,
//! dots or stems, and optionally a shaded band around zero (the confidence band of a residual
//! correlation). The report crate knows nothing about models: whoever builds a chart puts the
//! numbers in.

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeriesStyle {
    Line,
    Dots,
    /// Vertical lines from zero, for correlation functions.
    Stems,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub style: SeriesStyle,
    /// Index into the report's palette; series of the same meaning share a colour.
    pub color: usize,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Half-width of a shaded band around y = 0 (e.g. a 99 % confidence band).
    pub band: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chart {
    /// File stem for the chart's files (`fig_m2_ds2` → `fig_m2_ds2.svg`, `.png`).
    pub name: String,
    /// Where the report places it: charts of one section appear together, sections in the
    /// order they first occur (e.g. `Submodels`, `thesis protocol: m2`).
    pub section: String,
    pub title: String,
    pub panels: Vec<Panel>,
}

/// Most points a line series is drawn with; longer series are reduced by keeping each
/// bucket's minimum and maximum, so spikes survive (a 15,001-sample run would otherwise make
/// every inline SVG about a megabyte).
pub const MAX_LINE_POINTS: usize = 2400;

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

const PANEL_HEIGHT: u32 = 260;
const WIDTH: u32 = 900;

#[derive(Debug, thiserror::Error)]
pub enum ChartError {
    #[error("chart `{chart}`: {reason}")]
    Render { chart: String, reason: String },
    #[error("chart `{chart}`: writing {path}: {source}")]
    Io {
        chart: String,
        path: std::path::PathBuf,
        source: std::io::Error,
    },
}

static FONT: Once = Once::new();

/// Registers the embedded DejaVu Sans as plotters' `sans-serif`: text layout needs a font,
/// and the report must not depend on the machine's fonts (no fontconfig here, none in CI).
fn register_embedded_font() {
    FONT.call_once(|| {
        // DejaVu Sans is a valid TrueType font; were it ever rejected, charts would still
        // render and plotters would report the missing font per text element.
        let _ = register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
        let _ = register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

/// Reduces a series to at most `max_points`, keeping each bucket's extremes in order.
pub fn decimate(x: &[f64], y: &[f64], max_points: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    if n <= max_points || max_points < 4 {
        return (x[..n].to_vec(), y[..n].to_vec());
    }
    let buckets = max_points / 2;
    let mut xs = Vec::with_capacity(max_points);
    let mut ys = Vec::with_capacity(max_points);
    for b in 0..buckets {
        let (lo, hi) = (
            b * n / buckets,
            ((b + 1) * n / buckets).max(b * n / buckets + 1),
        );
        let slice = &y[lo..hi];
        let (mut imin, mut imax) = (0, 0);
        for (i, v) in slice.iter().enumerate() {
            if *v < slice[imin] {
                imin = i;
            }
            if *v > slice[imax] {
                imax = i;
            }
        }
        for i in if imin <= imax {
            [imin, imax]
        } else {
            [imax, imin]
        } {
            xs.push(x[lo + i]);
            ys.push(y[lo + i]);
        }
    }
    (xs, ys)
}

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

fn padded(range: Option<(f64, f64)>) -> (f64, f64) {
    let (lo, hi) = range.unwrap_or((0.0, 1.0));
    let span = hi - lo;
    let pad = if span > 0.0 {
        0.05 * span
    } else {
        0.5 * lo.abs().max(1.0)
    };
    (lo - pad, hi + pad)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<(), String> {
    let x_range = padded(finite_range(
        panel.series.iter().flat_map(|s| s.x.iter().copied()),
    ));
    let mut y_values: Vec<f64> = panel
        .series
        .iter()
        .flat_map(|s| s.y.iter().copied())
        .collect();
    if let Some(b) = panel.band {
        y_values.extend([b, -b]);
    }
    if panel.series.iter().any(|s| s.style == SeriesStyle::Stems) {
        y_values.push(0.0);
    }
    let y_range = padded(finite_range(y_values.into_iter()));
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(34)
        .y_label_area_size(64)
        .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .label_style(("sans-serif", 12))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    if let Some(b) = panel.band {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(x_range.0, -b), (x_range.1, b)],
                RGBColor(255, 221, 87).mix(0.35).filled(),
            )))
            .map_err(|e| e.to_string())?;
    }
    for s in &panel.series {
        let color = PALETTE[s.color % PALETTE.len()];
        let drawn = match s.style {
            SeriesStyle::Line => {
                let (x, y) = decimate(&s.x, &s.y, MAX_LINE_POINTS);
                chart.draw_series(LineSeries::new(
                    x.into_iter()
                        .zip(y)
                        .filter(|(a, b)| a.is_finite() && b.is_finite()),
                    color.stroke_width(2),
                ))
            }
            SeriesStyle::Dots => chart.draw_series(
                s.x.iter()
                    .zip(&s.y)
                    .filter(|(a, b)| a.is_finite() && b.is_finite())
                    .map(|(&a, &b)| Circle::new((a, b), 2, color.filled())),
            ),
            SeriesStyle::Stems => chart.draw_series(
                s.x.iter()
                    .zip(&s.y)
                    .filter(|(a, b)| a.is_finite() && b.is_finite())
                    .map(|(&a, &b)| {
                        PathElement::new(vec![(a, 0.0), (a, b)], color.stroke_width(2))
                    }),
            ),
        }
        .map_err(|e| e.to_string())?;
        if !s.name.is_empty() {
            drawn.label(&s.name).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
            });
        }
    }
    if panel.series.iter().any(|s| !s.name.is_empty()) {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

fn draw_chart<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    chart: &Chart,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = if chart.title.is_empty() {
        root
    } else {
        root.titled(&chart.title, ("sans-serif", 18))
            .map_err(|e| e.to_string())?
    };
    let areas = root.split_evenly((chart.panels.len().max(1), 1));
    for (area, panel) in areas.iter().zip(&chart.panels) {
        draw_panel(area, panel)?;
    }
    root.present().map_err(|e| e.to_string())
}

fn size(chart: &Chart) -> (u32, u32) {
    let title = if chart.title.is_empty() { 0 } else { 30 };
    (
        WIDTH,
        PANEL_HEIGHT * chart.panels.len().max(1) as u32 + title,
    )
}

/// The chart as an SVG document.
pub fn render_svg(chart: &Chart) -> Result<String, ChartError> {
    register_embedded_font();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size(chart)).into_drawing_area();
        draw_chart(root, chart).map_err(|reason| ChartError::Render {
            chart: chart.name.clone(),
            reason,
        })?;
    }
    Ok(svg)
}

/// Writes the chart as `dir/<name>.svg` and `dir/<name>.png`, each atomically (a temporary
/// file, then a rename). Returns the SVG text for inlining.
pub fn write_chart(dir: &Path, chart: &Chart) -> Result<String, ChartError> {
    let svg = render_svg(chart)?;
    let svg_path = dir.join(format!("{}.svg", chart.name));
    airsus_data::atomic::write_text_atomically(&svg_path, &svg).map_err(|e| ChartError::Io {
        chart: chart.name.clone(),
        path: svg_path.clone(),
        source: std::io::Error::other(e.to_string()),
    })?;
    let png_path = dir.join(format!("{}.png", chart.name));
    // The encoder picks the format from the extension, so the temporary name ends in .png.
    let tmp = dir.join(format!(".{}.tmp-{}.png", chart.name, std::process::id()));
    let drawn = {
        let root = BitMapBackend::new(&tmp, size(chart)).into_drawing_area();
        draw_chart(root, chart)
    };
    if let Err(reason) = drawn {
        let _ = std::fs::remove_file(&tmp);
        return Err(ChartError::Render {
            chart: chart.name.clone(),
            reason,
        });
    }
    std::fs::rename(&tmp, &png_path).map_err(|source| ChartError::Io {
        chart: chart.name.clone(),
        path: png_path,
        source,
    })?;
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_chart() -> Chart {
        let t: Vec<f64> = (0..5000).map(|i| f64::from(i) * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| (t * 0.05).sin()).collect();
        Chart {
            name: "sample".to_owned(),
            section: "test".to_owned(),
            title: "Measured and simulated".to_owned(),
            panels: vec![
                Panel {
                    title: "height".to_owned(),
                    x_label: "time [s]".to_owned(),
                    y_label: "height [mm]".to_owned(),
                    series: vec![Series {
                        name: "measured".to_owned(),
                        x: t.clone(),
                        y: y.clone(),
                        style: SeriesStyle::Line,
                        color: 0,
                    }],
                    band: None,
                },
                Panel {
                    title: "correlation".to_owned(),
                    x_label: "lag".to_owned(),
                    y_label: "r".to_owned(),
                    series: vec![Series {
                        name: String::new(),
                        x: (-5..=5).map(f64::from).collect(),
                        y: (-5..=5).map(|k| 0.1 * f64::from(k)).collect(),
                        style: SeriesStyle::Stems,
                        color: 1,
                    }],
                    band: Some(0.2),
                },
            ],
        }
    }

    #[test]
    fn svg_has_text_from_the_embedded_font_and_stays_small() {
        let svg = render_svg(&sample_chart()).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..50]);
        assert!(svg.contains("Measured and simulated"));
        assert!(svg.contains("height [mm]"));
        assert!(svg.len() < 400_000, "{} bytes", svg.len());
    }

    #[test]
    fn writes_svg_and_png_files() {
        let dir = tempfile::tempdir().unwrap();
        write_chart(dir.path(), &sample_chart()).unwrap();
        let png = std::fs::read(dir.path().join("sample.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        assert!(dir.path().join("sample.svg").exists());
        let leftovers = std::fs::read_dir(dir.path())
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with('.')
            })
            .count();
        assert_eq!(leftovers, 0);
    }

    #[test]
    fn decimation_keeps_extremes_and_bounds_the_count() {
        let x: Vec<f64> = (0..10_000).map(f64::from).collect();
        let mut y = vec![0.0; 10_000];
        y[4321] = 5.0;
        y[777] = -3.0;
        let (xd, yd) = decimate(&x, &y, 1000);
        assert!(xd.len() <= 1000);
        assert!(yd.contains(&5.0) && yd.contains(&-3.0));
        assert!(xd.windows(2).all(|w| w[0] <= w[1]), "order kept");
        let (xs, _) = decimate(&x[..10], &y[..10], 1000);
        assert_eq!(xs.len(), 10);
    }
}
