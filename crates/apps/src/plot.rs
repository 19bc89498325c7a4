//! Plots with `plotters`: SVG (by file extension `.svg`) or PNG.
//!
//! Text needs a font: plotters' `ab_glyph` backend draws only fonts registered with
//! `register_font`, and it has no system lookup (no fontconfig). We register DejaVu Sans from
//! the `dejavu` crate (the TTF compiled into the binary) as `sans-serif`, so plots render the
//! same everywhere, offline.

use std::path::Path;
use std::sync::Once;

use airsus_data::ValveState;
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::control::ClosedLoopRun;
use crate::error::AppError;

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        // The bytes are a valid TTF shipped by the crate; a failure would only lose text.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

const COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

fn plot_err(path: &Path, e: impl std::fmt::Display) -> AppError {
    AppError::Plot {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

/// Renders into `path`, SVG (by the `.svg` extension, with `draw`) or PNG (with `draw_png`,
/// the same drawing on the other backend: a closure cannot be generic over it), whole or not at
/// all like every other output: into memory (SVG) or a temporary file beside the target (PNG:
/// the encoder picks the format from the extension, so the temporary name ends in .png), then
/// renamed.
fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl Fn(&DrawingArea<SVGBackend<'_>, plotters::coord::Shift>) -> Result<(), String>,
    draw_png: impl Fn(&DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<(), String>,
) -> Result<(), AppError> {
    register_font();
    let svg = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    if svg {
        let mut text = String::new();
        {
            let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
            draw(&root).map_err(|e| plot_err(path, e))?;
            root.present().map_err(|e| plot_err(path, e))?;
        }
        airsus_data::atomic::write_text_atomically(path, &text).map_err(|e| plot_err(path, e))
    } else {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        let stem = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "plot".to_owned());
        let tmp = dir.join(format!(".{stem}.tmp-{}.png", std::process::id()));
        let drawn = (|| {
            let root = BitMapBackend::new(&tmp, size).into_drawing_area();
            draw_png(&root).map_err(|e| plot_err(path, e))?;
            root.present().map_err(|e| plot_err(path, e))?;
            drop(root);
            std::fs::rename(&tmp, path).map_err(|e| plot_err(path, e))
        })();
        if drawn.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        drawn
    }
}

/// Height (true) with target and band, valve command, and load of closed-loop runs of the
/// same scenario side by side.
pub fn plot_closed_loop(
    path: &Path,
    runs: &[ClosedLoopRun],
    tolerance_m: f64,
    title: &str,
) -> Result<(), AppError> {
    render(
        path,
        (1200, 900),
        |root| draw_closed_loop(root, runs, tolerance_m, title).map_err(|e| e.to_string()),
        |root| draw_closed_loop(root, runs, tolerance_m, title).map_err(|e| e.to_string()),
    )
}

/// What [`plot_weighing`] draws: the estimate over a run, its standard deviation, whether
/// each sample is at standstill (the `standstill` quality flag), and the true load where
/// known.
pub struct WeighingPlot<'a> {
    pub time_s: &'a [f64],
    pub wheel_load_kg: &'a [f64],
    pub std_kg: &'a [f64],
    pub standstill: &'a [bool],
    pub truth_kg: Option<&'a [f64]>,
    pub title: &'a str,
}

/// The wheel load over a run with its 95 % interval and the standstills marked; with the
/// truth, a second panel of the error (%) against the interval's half-width.
pub fn plot_weighing(path: &Path, plot: &WeighingPlot<'_>) -> Result<(), AppError> {
    let n = plot.time_s.len();
    if [
        plot.wheel_load_kg.len(),
        plot.std_kg.len(),
        plot.standstill.len(),
    ]
    .iter()
    .any(|&m| m != n)
        || plot.truth_kg.is_some_and(|t| t.len() != n)
    {
        return Err(plot_err(
            path,
            "time, load, standard deviation, standstill flags and truth differ in length",
        ));
    }
    if n < 2 {
        return Err(plot_err(path, "fewer than two samples"));
    }
    let (t0, t1) = (plot.time_s[0], plot.time_s[n - 1]);
    if !(t0.is_finite() && t1.is_finite() && t1 > t0) {
        return Err(plot_err(
            path,
            format!("the time axis must run forward over finite times, got {t0} to {t1} s"),
        ));
    }
    if !plot.wheel_load_kg.iter().any(|m| m.is_finite()) {
        return Err(plot_err(path, "no estimate is a number"));
    }
    render(
        path,
        (1200, 800),
        |root| draw_weighing(root, plot).map_err(|e| e.to_string()),
        |root| draw_weighing(root, plot).map_err(|e| e.to_string()),
    )
}

/// At most this many points per drawn line: a 25-minute run at 100 ms has 15,001, which an SVG
/// carries as megabytes of path and a reader cannot resolve anyway.
const MAX_PLOTTED_POINTS: usize = 3000;

fn draw_weighing<B: DrawingBackend>(
    root: &DrawingArea<B, plotters::coord::Shift>,
    plot: &WeighingPlot<'_>,
) -> DrawResult<B> {
    root.fill(&WHITE)?;
    let root = root.titled(plot.title, ("sans-serif", 22))?;
    let n = plot.time_s.len();
    let stride = n.div_ceil(MAX_PLOTTED_POINTS).max(1);
    let picked: Vec<usize> = (0..n).step_by(stride).collect();
    let (t0, t1) = (plot.time_s[0], plot.time_s[n - 1]);
    // The load axis spans the estimate and the truth, not the interval: it is hundreds of
    // kilograms wide on the first sample, before the filter has read anything.
    let finite = |v: &f64| v.is_finite();
    let values = plot
        .wheel_load_kg
        .iter()
        .chain(plot.truth_kg.unwrap_or(&[]))
        .filter(|v| finite(v));
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
        (a.min(v), b.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return Ok(());
    }
    let pad = 0.05 * (hi - lo).max(10.0);
    let (lo, hi) = (lo - pad, hi + pad);
    let panels = if plot.truth_kg.is_some() {
        root.split_evenly((2, 1))
    } else {
        vec![root.clone()]
    };
    let mut chart = ChartBuilder::on(&panels[0])
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(70)
        .build_cartesian_2d(t0..t1, lo..hi)?;
    chart
        .configure_mesh()
        .y_desc("wheel load (kg)")
        .x_desc("time (s)")
        .draw()?;
    let c = COLOURS[0];
    let clamp = |v: f64| v.clamp(lo, hi);
    let mut band: Vec<(f64, f64)> = picked
        .iter()
        .map(|&k| {
            (
                plot.time_s[k],
                clamp(plot.wheel_load_kg[k] + 1.96 * plot.std_kg[k]),
            )
        })
        .collect();
    band.extend(picked.iter().rev().map(|&k| {
        (
            plot.time_s[k],
            clamp(plot.wheel_load_kg[k] - 1.96 * plot.std_kg[k]),
        )
    }));
    chart
        .draw_series(std::iter::once(Polygon::new(band, c.mix(0.2).filled())))?
        .label("95 % interval")
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.mix(0.2).filled()));
    chart
        .draw_series(LineSeries::new(
            picked
                .iter()
                .map(|&k| (plot.time_s[k], clamp(plot.wheel_load_kg[k]))),
            c.stroke_width(2),
        ))?
        .label("estimate")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    // The standstills (read the scale here) as a strip along the bottom.
    let strip = lo + 0.01 * (hi - lo);
    let green = COLOURS[2];
    chart
        .draw_series(
            picked
                .iter()
                .filter(|&&k| plot.standstill[k])
                .map(|&k| Circle::new((plot.time_s[k], strip), 1, green.filled())),
        )?
        .label("standstill")
        .legend(move |(x, y)| Circle::new((x + 10, y), 3, green.filled()));
    if let Some(truth) = plot.truth_kg {
        chart
            .draw_series(LineSeries::new(
                picked.iter().map(|&k| (plot.time_s[k], clamp(truth[k]))),
                BLACK.stroke_width(1),
            ))?
            .label("true load")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;

    let Some(truth) = plot.truth_kg else {
        return Ok(());
    };
    let percent = |k: usize, v: f64| 100.0 * v / truth[k];
    // The error axis: the 99th percentile of the errors and the interval's half-widths over
    // the standstills (every sample where the run has none), at least ±0.5 %: the first
    // samples, before the filter has read anything, would set it otherwise.
    let standstills = picked.iter().filter(|&&k| plot.standstill[k]).count();
    let mut spread: Vec<f64> = picked
        .iter()
        .filter(|&&k| standstills == 0 || plot.standstill[k])
        .flat_map(|&k| {
            [
                percent(k, (plot.wheel_load_kg[k] - truth[k]).abs()),
                percent(k, 1.96 * plot.std_kg[k]),
            ]
        })
        .filter(|v| v.is_finite())
        .collect();
    spread.sort_by(f64::total_cmp);
    let p99 = spread
        .get((0.99 * spread.len() as f64) as usize)
        .or(spread.last())
        .copied()
        .unwrap_or(0.0);
    let span = 1.2 * p99.max(0.5);
    let mut error = ChartBuilder::on(&panels[1])
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(70)
        .build_cartesian_2d(t0..t1, -span..span)?;
    error
        .configure_mesh()
        .y_desc("error (% of the true load)")
        .x_desc("time (s)")
        .draw()?;
    let clamp_e = |v: f64| v.clamp(-span, span);
    let mut band: Vec<(f64, f64)> = picked
        .iter()
        .map(|&k| (plot.time_s[k], clamp_e(percent(k, 1.96 * plot.std_kg[k]))))
        .collect();
    band.extend(
        picked
            .iter()
            .rev()
            .map(|&k| (plot.time_s[k], clamp_e(-percent(k, 1.96 * plot.std_kg[k])))),
    );
    error
        .draw_series(std::iter::once(Polygon::new(band, c.mix(0.2).filled())))?
        .label("95 % interval")
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.mix(0.2).filled()));
    let red = COLOURS[1];
    error
        .draw_series(LineSeries::new(
            picked.iter().map(|&k| {
                (
                    plot.time_s[k],
                    clamp_e(percent(k, plot.wheel_load_kg[k] - truth[k])),
                )
            }),
            red.stroke_width(1),
        ))?
        .label("estimate - truth")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(1)));
    error.draw_series(
        picked
            .iter()
            .filter(|&&k| plot.standstill[k])
            .map(|&k| Circle::new((plot.time_s[k], -0.97 * span), 1, green.filled())),
    )?;
    error
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

type DrawResult<B> = Result<(), DrawingAreaErrorKind<<B as DrawingBackend>::ErrorType>>;

fn draw_closed_loop<B: DrawingBackend>(
    root: &DrawingArea<B, plotters::coord::Shift>,
    runs: &[ClosedLoopRun],
    tolerance_m: f64,
    title: &str,
) -> DrawResult<B> {
    root.fill(&WHITE)?;
    let Some(first) = runs.first() else {
        return Ok(());
    };
    let root = root.titled(title, ("sans-serif", 22))?;
    let panels = root.split_evenly((3, 1));
    let t_end = first.time_s.last().copied().unwrap_or(1.0);
    let mm = |v: f64| v * 1e3;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for r in runs {
        for (&h, &t) in r.height_m.iter().zip(&r.target_m) {
            lo = lo.min(mm(h)).min(mm(t - tolerance_m));
            hi = hi.max(mm(h)).max(mm(t + tolerance_m));
        }
    }
    let mut chart = ChartBuilder::on(&panels[0])
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, (lo - 2.0)..(hi + 2.0))?;
    chart
        .configure_mesh()
        .y_desc("sensor height (mm)")
        .x_desc("time (s)")
        .draw()?;
    let target: Vec<(f64, f64)> = first
        .time_s
        .iter()
        .zip(&first.target_m)
        .map(|(&t, &h)| (t, mm(h)))
        .collect();
    for offset in [-tolerance_m, tolerance_m] {
        chart.draw_series(LineSeries::new(
            target.iter().map(|&(t, h)| (t, h + mm(offset))),
            BLACK.mix(0.3),
        ))?;
    }
    chart
        .draw_series(LineSeries::new(
            target.iter().copied(),
            BLACK.stroke_width(1),
        ))?
        .label("target ± band")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
    for (i, r) in runs.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(
                r.time_s.iter().zip(&r.height_m).map(|(&t, &h)| (t, mm(h))),
                c.stroke_width(2),
            ))?
            .label(r.controller.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;

    // Valve: +1 fill, -1 exhaust, offset per controller.
    let n = runs.len() as f64;
    let mut valve = ChartBuilder::on(&panels[1])
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, -1.2..(1.2 + 0.1 * n))?;
    valve
        .configure_mesh()
        .y_desc("valve (+1 fill, -1 exhaust)")
        .x_desc("time (s)")
        .draw()?;
    for (i, r) in runs.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let offset = 0.1 * i as f64;
        let level = |v: ValveState| match v {
            ValveState::Closed => 0.0,
            ValveState::Fill => 1.0,
            ValveState::Exhaust => -1.0,
        };
        let mut points = Vec::with_capacity(2 * r.time_s.len());
        for k in 0..r.time_s.len() {
            let y = level(r.valve[k]) + offset;
            points.push((r.time_s[k], y));
            if let Some(&t_next) = r.time_s.get(k + 1) {
                points.push((t_next, y));
            }
        }
        valve.draw_series(LineSeries::new(points, c.stroke_width(2)))?;
    }

    let (mut plo, mut phi) = (f64::INFINITY, f64::NEG_INFINITY);
    for r in runs {
        for &p in &r.bellow_gauge_pa {
            plo = plo.min(p / 1e3);
            phi = phi.max(p / 1e3);
        }
    }
    let mut pressure = ChartBuilder::on(&panels[2])
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, (plo - 5.0)..(phi + 5.0))?;
    pressure
        .configure_mesh()
        .y_desc("bellow pressure (kPa gauge)")
        .x_desc("time (s)")
        .draw()?;
    for (i, r) in runs.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        pressure.draw_series(LineSeries::new(
            r.time_s
                .iter()
                .zip(&r.bellow_gauge_pa)
                .map(|(&t, &p)| (t, p / 1e3)),
            c.stroke_width(1),
        ))?;
    }
    Ok(())
}
