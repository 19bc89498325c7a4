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

/// Height (true) with target and band, valve command, and load of closed-loop runs of the
/// same scenario side by side.
pub fn plot_closed_loop(
    path: &Path,
    runs: &[ClosedLoopRun],
    tolerance_m: f64,
    title: &str,
) -> Result<(), AppError> {
    register_font();
    let svg = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("svg"));
    // Whole or not at all, like every other output: render into memory (SVG) or a temporary
    // file beside the target (PNG: the encoder picks the format from the extension, so the
    // temporary name ends in .png), then rename.
    if svg {
        let mut text = String::new();
        {
            let root = SVGBackend::with_string(&mut text, (1200, 900)).into_drawing_area();
            draw_closed_loop(&root, runs, tolerance_m, title).map_err(|e| plot_err(path, e))?;
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
            let root = BitMapBackend::new(&tmp, (1200, 900)).into_drawing_area();
            draw_closed_loop(&root, runs, tolerance_m, title).map_err(|e| plot_err(path, e))?;
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
