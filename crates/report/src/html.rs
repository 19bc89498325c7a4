//! `report.html`: one self-contained page (figures inline as SVG, no scripts, no network) that
//! puts our numbers beside the thesis' and says which model to use for what.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::chart::{Chart, write_chart};
use crate::results::{ModelResult, OutputFit, ProtocolResult, StudyResults};
use crate::thesis;

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(transparent)]
    Chart(#[from] crate::chart::ChartError),
    #[error(transparent)]
    Data(#[from] airsus_data::DataError),
    #[error("serialising results.json: {0}")]
    Json(#[from] serde_json::Error),
    #[error("cannot create {path}: {source}")]
    Folder {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// What [`write_report`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportFiles {
    pub html: PathBuf,
    pub json: PathBuf,
    pub figures: Vec<PathBuf>,
    /// Charts that could not be drawn, with the reason; the report says so in their place.
    pub chart_failures: Vec<String>,
}

/// Writes `results.json`, every chart (SVG and PNG under `figures/`) and `report.html` into
/// `dir`. A chart that fails to render is reported in the page and in `chart_failures`; it
/// does not stop the report.
pub fn write_report(
    dir: &Path,
    results: &StudyResults,
    charts: &[Chart],
) -> Result<ReportFiles, ReportError> {
    let figures_dir = dir.join("figures");
    std::fs::create_dir_all(&figures_dir).map_err(|source| ReportError::Folder {
        path: figures_dir.clone(),
        source,
    })?;
    let json = dir.join("results.json");
    airsus_data::atomic::write_text_atomically(&json, &serde_json::to_string_pretty(results)?)?;

    let mut rendered = Vec::with_capacity(charts.len());
    let mut figures = Vec::new();
    let mut chart_failures = Vec::new();
    for chart in charts {
        match write_chart(&figures_dir, chart) {
            Ok(svg) => {
                figures.push(figures_dir.join(format!("{}.svg", chart.name)));
                figures.push(figures_dir.join(format!("{}.png", chart.name)));
                rendered.push((chart, Ok(svg)));
            }
            Err(err) => {
                chart_failures.push(err.to_string());
                rendered.push((chart, Err(err.to_string())));
            }
        }
    }
    let html = dir.join("report.html");
    airsus_data::atomic::write_text_atomically(&html, &render_html(results, &rendered))?;
    Ok(ReportFiles {
        html,
        json,
        figures,
        chart_failures,
    })
}

fn esc(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn pct(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.1}"),
        _ => "–".to_owned(),
    }
}

/// A table cell coloured by fit quality (green ≥ 90 %, amber ≥ 70 %, red below).
fn fit_cell(v: Option<f64>) -> String {
    let class = match v {
        Some(v) if v >= 90.0 => "good",
        Some(v) if v >= 70.0 => "fair",
        Some(_) => "poor",
        None => "none",
    };
    format!("<td class=\"num {class}\">{}</td>", pct(v))
}

const STYLE: &str = "body{font-family:DejaVu Sans,Verdana,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ccc}h3{margin-top:1.5em}\
table{border-collapse:collapse;margin:.8em 0}td,th{border:1px solid #ccc;padding:.25em .6em}th{background:#f3f3f3}\
td.num{text-align:right;font-variant-numeric:tabular-nums}.good{background:#d9f2d9}.fair{background:#fff1c7}.poor{background:#f8d4d4}.none{color:#999}\
.thesis{color:#666;font-style:italic}.error{background:#fde2e2;border-left:4px solid #c33;padding:.5em 1em}\
.note{background:#eef4fb;border-left:4px solid #48c;padding:.5em 1em}figure{margin:1em 0}figcaption{color:#555;font-size:.9em}\
svg{max-width:100%;height:auto}";

fn render_html(results: &StudyResults, charts: &[(&Chart, Result<String, String>)]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>airsus study report</title><style>{STYLE}</style></head><body>"
    );
    let _ = write!(
        h,
        "<h1>Air suspension study</h1><p>Study: <code>{}</code> · nominal truck: <code>{}</code> · runs start: {}{} · airsus {} · pipeline time {:.1} s · <a href=\"results.json\">results.json</a></p>",
        esc(&results.study),
        esc(&results.truck),
        match results.initial_state.as_str() {
            "joint" => format!(
                "history states fitted to the first {:.0} s, refitted with the parameters in turn in estimation runs",
                results.prefix_s
            ),
            "prefix" => format!(
                "history states fitted to the first {:.0} s, held in estimation runs while the parameters were fitted",
                results.prefix_s
            ),
            _ => "static equilibrium at the first measured height".to_owned(),
        },
        if results.allow_trades {
            " · trades allowed: a pooled estimate that explains an estimation run worse than its start values is kept"
        } else {
            ""
        },
        esc(&results.airsus_version),
        results.elapsed_s
    );
    runs_table(&mut h, results);
    summary(&mut h, results);
    recommendations(&mut h, results);
    submodels(&mut h, results);
    for protocol in &results.protocols {
        protocol_section(&mut h, results, protocol);
    }
    figures(&mut h, charts);
    h.push_str("</body></html>\n");
    h
}

fn runs_table(h: &mut String, results: &StudyResults) {
    h.push_str("<h2>Runs</h2><table><tr><th>run</th><th>file</th><th>format</th><th>role</th><th>samples</th><th>duration [s]</th><th>valve action</th></tr>");
    for r in &results.runs {
        let _ = write!(
            h,
            "<tr><td>{}</td><td><code>{}</code></td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{:.0}</td><td>{}</td></tr>",
            esc(&r.name),
            esc(&r.file),
            esc(&r.format),
            esc(&r.role),
            r.samples,
            r.duration_s,
            if r.valve_action { "yes" } else { "no" }
        );
    }
    h.push_str("</table>");
    // What reading a log did to it (resampling above all) is part of the result.
    let noted: Vec<_> = results
        .runs
        .iter()
        .filter(|r| !r.notes.is_empty())
        .collect();
    if !noted.is_empty() {
        h.push_str("<p>How the runs were read:</p><ul>");
        for r in noted {
            for note in &r.notes {
                let _ = write!(h, "<li>{}: {}</li>", esc(&r.name), esc(note));
            }
        }
        h.push_str("</ul>");
    }
}

/// The summary table: models × runs × outputs, estimated NRMSE, per protocol.
fn summary(h: &mut String, results: &StudyResults) {
    h.push_str("<h2>Summary: NRMSE [%] with the estimated parameters</h2>");
    for p in &results.protocols {
        let _ = write!(
            h,
            "<h3>Protocol “{}”: {}</h3>",
            esc(&p.name),
            esc(&p.description)
        );
        let _ = write!(h, "<table><tr><th rowspan=\"2\">model</th>");
        for r in &results.runs {
            let mark = if p.estimation_runs.contains(&r.name) {
                " (est.)"
            } else {
                ""
            };
            let _ = write!(h, "<th colspan=\"2\">{}{mark}</th>", esc(&r.name));
        }
        h.push_str("</tr><tr>");
        for _ in &results.runs {
            h.push_str("<th>height</th><th>pressure</th>");
        }
        h.push_str("</tr>");
        for m in &p.models {
            let _ = write!(h, "<tr><td>{}</td>", esc(&m.model));
            for r in &results.runs {
                let fit = m.run(&r.name).and_then(|f| f.estimated);
                h.push_str(&fit_cell(fit.map(|f| f.height_percent)));
                h.push_str(&fit_cell(fit.map(|f| f.pressure_percent)));
            }
            h.push_str("</tr>");
        }
        h.push_str("<tr class=\"ceiling\"><td><i>noise ceiling</i></td>");
        for r in &results.runs {
            match &r.ceiling {
                Some(c) => {
                    let mark = c.mark();
                    for v in [c.height_percent, c.pressure_percent] {
                        let _ = write!(h, "<td><i>{v:.1}{mark}</i></td>");
                    }
                }
                None => h.push_str("<td>–</td><td>–</td>"),
            }
        }
        h.push_str("</tr>");
        let logged_input =
            |r: &crate::results::RunInfo| r.ceiling.as_ref().and_then(|c| c.logged_input);
        if results.runs.iter().any(|r| logged_input(r).is_some()) {
            h.push_str("<tr class=\"ceiling\"><td><i>ceiling, load as logged</i></td>");
            for r in &results.runs {
                // Where the log shows every change, the ceiling above is this one too.
                match (logged_input(r), &r.ceiling) {
                    (Some(c), _) => {
                        for v in [c.height_percent, c.pressure_percent] {
                            let _ = write!(h, "<td><i>{v:.1}</i></td>");
                        }
                    }
                    (None, Some(c)) => {
                        let mark = c.mark();
                        for v in [c.height_percent, c.pressure_percent] {
                            let _ = write!(h, "<td><i>{v:.1}{mark}</i></td>");
                        }
                    }
                    (None, None) => h.push_str("<td>–</td><td>–</td>"),
                }
            }
            h.push_str("</tr>");
        }
        h.push_str("</table>");
    }
    if results
        .runs
        .iter()
        .any(|r| r.ceiling.as_ref().is_some_and(|c| c.logged_input.is_some()))
    {
        h.push_str("<p class=\"note\">Ceiling, load as logged: where the truck felt load changes its log does not show (a loading mishap), the NRMSE of the noise-free outputs of the run as its log tells it (every logged change as the truck felt it, the unlogged ones left out) against the measurements: the best a model driven by the logged load can score.</p>");
    }
    if results.runs.iter().any(|r| r.ceiling.is_some()) {
        h.push_str("<p class=\"note\">Noise ceiling: the NRMSE of the noise-free outputs against the measurements, the best any model can score; ~ marks a ceiling estimated from the measurements' own noise (no truth file). Noise std per run: ");
        let noise: Vec<String> = results
            .runs
            .iter()
            .filter_map(|r| {
                let c = r.ceiling.as_ref()?;
                Some(format!(
                    "{} {:.3} mm / {:.3} kPa",
                    esc(&r.name),
                    c.height_noise_std_mm,
                    c.pressure_noise_std_kpa
                ))
            })
            .collect();
        h.push_str(&noise.join(", "));
        h.push_str(".</p>");
    }
}

/// Which model to use for what: the study's findings, in words.
fn recommendations(h: &mut String, results: &StudyResults) {
    h.push_str("<h2>Which model for what</h2>");
    let findings = &results.findings;
    if findings.uses.is_empty() && findings.valve_data.is_none() {
        h.push_str(
            "<p class=\"note\">No grey-box protocol ran, so there is nothing to compare.</p>",
        );
        return;
    }
    h.push_str("<ul>");
    for use_ in &findings.uses {
        let Some(first) = use_.ranking.first() else {
            continue;
        };
        let mut best = format!(
            "<code>{}</code> ({:.1} %)",
            esc(&first.model),
            first.mean_nrmse_percent
        );
        if let Some(other) = &use_.best_other_than_truck {
            let _ = write!(
                best,
                ", the virtual truck's own structure; among the thesis models <code>{}</code> ({:.1} %)",
                esc(&other.model),
                other.mean_nrmse_percent
            );
        }
        let all = use_
            .ranking
            .iter()
            .map(|m| format!("{} {:.1} %", esc(&m.model), m.mean_nrmse_percent))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = match use_.purpose.as_str() {
            "axle_load" => write!(
                h,
                "<li><b>Axle-load estimation and loading simulations:</b> {best} reproduces the loading runs best (mean NRMSE of height and pressure; all: {all}). Weighing reads the static balance, so what matters is the pressure level after each step.</li>"
            ),
            "level_control" => write!(
                h,
                "<li><b>Level-controller design:</b> {best} follows the valve runs best (all: {all}). A level controller acts only through the valve, so fill and exhaust dynamics must be right.</li>"
            ),
            other => write!(h, "<li><b>{}:</b> {best} (all: {all}).</li>", esc(other)),
        };
    }
    if let Some(gain) = &findings.valve_data {
        let per_model: Vec<String> = gain
            .models
            .iter()
            .map(|m| {
                format!(
                    "{}: height {:.1} → {:.1} %, pressure {:.1} → {:.1} %",
                    esc(&m.model),
                    m.height_before_percent,
                    m.height_after_percent,
                    m.pressure_before_percent,
                    m.pressure_after_percent
                )
            })
            .collect();
        let _ = write!(
            h,
            "<li><b>What valve-action data buys</b> on the valve runs not used for estimation ({}), estimating on “{}” instead of “{}”: {}. A closed-valve run cannot determine the gas volume's scale or the flow resistances (SPEC §4).</li>",
            esc(&gain.runs.join(", ")),
            esc(&gain.after_protocol),
            esc(&gain.before_protocol),
            per_model.join("; ")
        );
    }
    h.push_str("</ul>");
}

fn submodels(h: &mut String, results: &StudyResults) {
    h.push_str("<h2>Submodel fits (thesis 5.2)</h2><table><tr><th>fit</th><th>parameters</th><th>NRMSE est. [%]</th><th>NRMSE val. [%]</th><th class=\"thesis\">thesis</th><th>notes</th></tr>");
    for fit in &results.submodels.fits {
        let params: Vec<String> = fit
            .parameters
            .iter()
            .map(|p| match p.std {
                Some(s) => format!(
                    "{} = {:.5e} ± {:.1e} {}",
                    esc(&p.name),
                    p.value,
                    s,
                    esc(&p.unit)
                ),
                None => format!("{} = {:.5e} {}", esc(&p.name), p.value, esc(&p.unit)),
            })
            .collect();
        let reference = match fit.name.as_str() {
            "cross_section" => format!(
                "{} / {} (Table 5.1)",
                thesis::TABLE_5_1_CROSS_SECTION.0,
                thesis::TABLE_5_1_CROSS_SECTION.1
            ),
            "fill_valve" => format!("val. {} (Table 5.3)", thesis::TABLE_5_3_VALVE.0),
            "exhaust_valve" => format!("val. {} (Table 5.3)", thesis::TABLE_5_3_VALVE.1),
            "slow_dynamics" => "est. 95.8 (5.2.4)".to_owned(),
            _ => "–".to_owned(),
        };
        let notes = match &fit.error {
            Some(e) => format!("<span class=\"error\">failed: {}</span>", esc(e)),
            None => fit
                .notes
                .iter()
                .map(|n| esc(n))
                .collect::<Vec<_>>()
                .join("<br>"),
        };
        let _ = write!(
            h,
            "<tr><td>{}<br><small>{}</small></td><td>{}</td>{}{}<td class=\"thesis\">{}</td><td>{}</td></tr>",
            esc(&fit.name),
            esc(&fit.description),
            params.join("<br>"),
            fit_cell(fit.nrmse_estimation_percent),
            fit_cell(fit.nrmse_validation_percent),
            reference,
            notes
        );
    }
    h.push_str("</table>");
}

/// The shortest and longest of the transition times, s; `None` without any.
fn span_s(transitions: &[crate::results::LoadTransitions]) -> Option<(f64, f64)> {
    let (shortest, longest) = transitions
        .iter()
        .flat_map(|t| t.durations_s.iter().copied())
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), d| {
            (lo.min(d), hi.max(d))
        });
    shortest.is_finite().then_some((shortest, longest))
}

fn protocol_section(h: &mut String, results: &StudyResults, p: &ProtocolResult) {
    let _ = write!(
        h,
        "<h2>Grey-box estimation, protocol “{}”</h2><p>{} Estimation runs: {}.</p>",
        esc(&p.name),
        esc(&p.description),
        esc(&p.estimation_runs.join(", "))
    );
    // Estimation-data table beside thesis Tables 5.10–5.12.
    h.push_str("<table><tr><th>model</th><th>freed</th><th>nominal height</th><th>nominal pressure</th><th>estimated height</th><th>estimated pressure</th><th class=\"thesis\">thesis (nominal → est. 2)</th><th>simulations</th><th>time [s]</th><th>stop</th></tr>");
    for m in &p.models {
        let est_runs: Vec<&crate::results::RunFit> = m
            .runs
            .iter()
            .filter(|r| p.estimation_runs.contains(&r.run))
            .collect();
        let avg = |f: &dyn Fn(&crate::results::RunFit) -> Option<f64>| -> Option<f64> {
            let v: Vec<f64> = est_runs.iter().filter_map(|r| f(r)).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        let reference = thesis::GREYBOX
            .iter()
            .find(|r| r.model == m.model)
            .map(|r| {
                format!(
                    "{:.1}/{:.1} → {:.1}/{:.1} (Table {}, {})",
                    r.nominal.0, r.nominal.1, r.estimated.0, r.estimated.1, r.table, r.free
                )
            })
            .unwrap_or_else(|| "–".to_owned());
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td>{}{}{}{}<td class=\"thesis\">{}</td><td class=\"num\">{}</td><td class=\"num\">{:.2}</td><td>{}</td></tr>",
            esc(&m.model),
            esc(&m.free.join(", ")),
            fit_cell(avg(&|r| r.nominal.map(|f| f.height_percent))),
            fit_cell(avg(&|r| r.nominal.map(|f| f.pressure_percent))),
            fit_cell(avg(&|r| r.estimated.map(|f| f.height_percent))),
            fit_cell(avg(&|r| r.estimated.map(|f| f.pressure_percent))),
            reference,
            if m.failed_simulations > 0 {
                format!("{} ({} failed)", m.simulations, m.failed_simulations)
            } else {
                m.simulations.to_string()
            },
            m.estimation_time_s,
            esc(&{
                let mut stop = m.stop_reason.as_deref().unwrap_or("–").to_owned();
                if let Some(g) = m.gradient_norm {
                    stop.push_str(&format!(" (gradient {g:.1e})"));
                }
                if let Some(tau) = m.load_ramp_s {
                    stop.push_str(&format!("; load eased over {tau:.1} s"));
                }
                if let Some((shortest, longest)) = span_s(&m.load_transitions) {
                    stop.push_str(&format!(
                        " (estimation runs: each change over its own, {shortest:.1}–{longest:.1} s)"
                    ));
                }
                if let Some((shortest, longest)) = span_s(&m.validation_transitions) {
                    stop.push_str(&format!(
                        "; validation runs: each change over its own, fitted with the parameters fixed, {shortest:.1}–{longest:.1} s"
                    ));
                }
                let failed_starts = if m.failed_starts > 0 {
                    format!(" ({} failed)", m.failed_starts)
                } else {
                    String::new()
                };
                let screened = if m.screened_starts > 0 {
                    format!(
                        "; {} points screened ({} did not simulate), {} better than the start",
                        m.screened_starts, m.screened_failed, m.screened_better
                    )
                } else {
                    String::new()
                };
                match m.local_optima_losses.as_slice() {
                    [best, .., worst] if m.starts > 1 => format!(
                        "{stop}{screened}; {} starts{failed_starts}, local optima's losses {best:.3e} to {worst:.3e}",
                        m.starts
                    ),
                    _ => format!("{stop}{screened}"),
                }
            })
        );
    }
    h.push_str("</table>");

    // Validation beside thesis Tables 5.13–5.16.
    h.push_str("<h3>Validation</h3><table><tr><th>model</th><th>run</th><th>height</th><th>pressure</th><th class=\"thesis\">thesis height / pressure</th><th>residual correlation outside the 99 % band</th></tr>");
    for m in &p.models {
        for r in m
            .runs
            .iter()
            .filter(|r| !p.estimation_runs.contains(&r.run))
        {
            let data_set = results
                .runs
                .iter()
                .find(|info| info.name == r.run)
                .and_then(|info| info.thesis_data_set);
            let reference = data_set
                .and_then(|n| thesis::validation(&m.model, n as usize))
                .map(|(a, b)| format!("{a:.1} / {b:.1}"))
                .unwrap_or_else(|| "–".to_owned());
            let residuals: Vec<String> = r
                .residuals
                .iter()
                .filter(|s| s.note.is_none() && s.lags_outside > 0)
                .map(|s| {
                    format!(
                        "{}×{}: {}/{}",
                        esc(&s.output),
                        esc(&s.input),
                        s.lags_outside,
                        s.lags_total
                    )
                })
                .collect();
            let cells = match &r.error {
                Some(e) => format!("<td colspan=\"2\" class=\"error\">{}</td>", esc(e)),
                None => format!(
                    "{}{}",
                    fit_cell(r.estimated.map(|f| f.height_percent)),
                    fit_cell(r.estimated.map(|f| f.pressure_percent))
                ),
            };
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td>{}<td class=\"thesis\">{}</td><td><small>{}</small></td></tr>",
                esc(&m.model),
                esc(&r.run),
                cells,
                reference,
                if residuals.is_empty() {
                    "none".to_owned()
                } else {
                    residuals.join(", ")
                }
            );
        }
    }
    h.push_str("</table>");

    for m in &p.models {
        let _ = write!(
            h,
            "<h3>{} <small>{}</small></h3>",
            esc(&m.model),
            esc(&m.description)
        );
        if let Some(e) = &m.error {
            let _ = write!(h, "<p class=\"error\">This model failed: {}</p>", esc(e));
        }
        if !m.estimates.is_empty() {
            h.push_str("<table><tr><th>parameter</th><th>nominal</th><th>estimate</th><th>± std</th><th>± std, correlated residuals</th><th>unit</th><th>determined by the runs</th></tr>");
            for e in &m.estimates {
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td class=\"num\">{:.5e}</td><td class=\"num\">{:.5e}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td>{}</td></tr>",
                    esc(&e.name),
                    e.nominal,
                    e.estimate,
                    e.std.map_or("–".to_owned(), |s| format!("{s:.2e}")),
                    e.std_correlated
                        .map_or("–".to_owned(), |s| format!("{s:.2e}")),
                    esc(&e.unit),
                    if e.identifiable {
                        "yes".to_owned()
                    } else {
                        // A start of the global stage other than the nominal one may have
                        // won: the parameter then stays where that start drew it.
                        let kept = if e.estimate == e.nominal {
                            "kept nominal"
                        } else {
                            "kept where the fit's start left it"
                        };
                        match &e.not_identifiable_because {
                            Some(why) => format!("<b>no</b> ({kept}): {}", esc(why)),
                            None => format!("<b>no</b> ({kept})"),
                        }
                    }
                );
            }
            h.push_str("</table>");
        }
        for note in &m.notes {
            let _ = write!(h, "<p class=\"note\">{}</p>", esc(note));
        }
        pooled_table(h, m);
        if let Some(file) = &m.truck_file {
            let _ = write!(
                h,
                "<p>Estimated truck file: <a href=\"{0}\"><code>{0}</code></a></p>",
                esc(file)
            );
        }
    }
}

/// Where the pooled estimate explained an estimation run worse than the start values did
/// (issue #12), its fit of each estimation run beside the start values' and the kept
/// estimate's.
fn pooled_table(h: &mut String, m: &ModelResult) {
    let pooled: Vec<_> = m.runs.iter().filter(|r| r.pooled.is_some()).collect();
    if pooled.is_empty() {
        return;
    }
    h.push_str("<table><tr><th>estimation run</th><th>start values height / pressure</th><th>pooled estimate</th><th>kept estimate</th></tr>");
    let pair = |fit: Option<OutputFit>| {
        fit.map_or("–".to_owned(), |f| {
            format!("{:.1} / {:.1}", f.height_percent, f.pressure_percent)
        })
    };
    for r in pooled {
        let _ = write!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            esc(&r.run),
            pair(r.nominal),
            pair(r.pooled),
            pair(r.estimated)
        );
    }
    h.push_str("</table>");
}

fn figures(h: &mut String, charts: &[(&Chart, Result<String, String>)]) {
    if charts.is_empty() {
        return;
    }
    h.push_str("<h2>Figures</h2>");
    let mut sections: Vec<&str> = Vec::new();
    for (c, _) in charts {
        if !sections.contains(&c.section.as_str()) {
            sections.push(&c.section);
        }
    }
    for section in sections {
        let _ = write!(h, "<h3>{}</h3>", esc(section));
        for (chart, svg) in charts.iter().filter(|(c, _)| c.section == section) {
            match svg {
                Ok(svg) => {
                    // The SVG document's XML prolog, if any, is not allowed inside HTML.
                    let body = svg.find("<svg").map_or(svg.as_str(), |i| &svg[i..]);
                    let _ = write!(
                        h,
                        "<figure>{}<figcaption>{} (<a href=\"figures/{2}.svg\">SVG</a>, <a href=\"figures/{2}.png\">PNG</a>)</figcaption></figure>",
                        body,
                        esc(&chart.title),
                        esc(&chart.name)
                    );
                }
                Err(e) => {
                    let _ = write!(
                        h,
                        "<p class=\"error\">Figure {} could not be drawn: {}</p>",
                        esc(&chart.name),
                        esc(e)
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::{Panel, Series, SeriesStyle};
    use crate::results::*;

    fn results() -> StudyResults {
        let fit = |h: f64, p: f64| {
            Some(OutputFit {
                height_percent: h,
                pressure_percent: p,
            })
        };
        let run = |name: &str, role: &str, est: Option<OutputFit>| RunFit {
            run: name.to_owned(),
            role: role.to_owned(),
            nominal: fit(50.0, 40.0),
            estimated: est,
            pooled: None,
            residuals: vec![ResidualSummary {
                output: "height".to_owned(),
                input: "wheel_load".to_owned(),
                confidence: 0.99,
                band: 0.05,
                lags_outside: 3,
                lags_total: 51,
                worst_ratio: 2.0,
                note: None,
            }],
            error: None,
        };
        let good = ModelResult {
            model: "m2".to_owned(),
            description: "Model 2".to_owned(),
            free: vec!["m2".to_owned(), "rflow1".to_owned()],
            estimates: vec![
                ParameterEstimate {
                    name: "m2".to_owned(),
                    unit: "kg".to_owned(),
                    nominal: 520.0,
                    estimate: 561.0,
                    std: Some(3.0),
                    std_correlated: Some(30.0),
                    identifiable: true,
                    not_identifiable_because: None,
                },
                ParameterEstimate {
                    name: "rflow1".to_owned(),
                    unit: "Pa s/mol".to_owned(),
                    nominal: 2.5e6,
                    estimate: 2.5e6,
                    std: None,
                    std_correlated: None,
                    identifiable: false,
                    not_identifiable_because: Some(
                        "no sensitivity: the outputs do not depend on it in these runs".to_owned(),
                    ),
                },
            ],
            stop_reason: Some("converged".to_owned()),
            simulations: 57,
            starts: 4,
            local_optima_losses: vec![0.012, 0.013, 0.2, 1.5],
            failed_simulations: 3,
            failed_starts: 1,
            screened_starts: 32,
            screened_failed: 5,
            screened_better: 3,
            estimation_time_s: 0.3,
            gradient_norm: Some(3.2e-7),
            load_ramp_s: Some(4.25),
            load_transitions: vec![crate::results::LoadTransitions {
                run: "data-set 1".to_owned(),
                durations_s: vec![3.2, 6.9],
            }],
            validation_transitions: vec![crate::results::LoadTransitions {
                run: "data-set 2".to_owned(),
                durations_s: vec![4.4, 7.5],
            }],
            runs: vec![
                run("data-set 1", "estimation", fit(95.0, 93.0)),
                run("data-set 2", "validation", fit(91.0, 88.0)),
                run("data-set 3", "validation", fit(60.0, 75.0)),
            ],
            truck_file: Some("m2_thesis.toml".to_owned()),
            notes: vec!["rflow1 is not determined by data-set 1 <closed valve>".to_owned()],
            error: None,
        };
        let failed = ModelResult {
            description: "Model 3".to_owned(),
            error: Some("no static equilibrium at 329 kPa".to_owned()),
            ..ModelResult::new("m3")
        };
        StudyResults {
            schema_version: SCHEMA_VERSION,
            airsus_version: "0.1.0".to_owned(),
            study: "built-in".to_owned(),
            truck: "truck.toml".to_owned(),
            initial_state: "equilibrium".to_owned(),
            prefix_s: 10.0,
            load_ramp: None,
            exclude_after_load_change_s: 0.0,
            validation_transitions: None,
            allow_trades: false,
            runs: ["data-set 1", "data-set 2", "data-set 3"]
                .iter()
                .enumerate()
                .map(|(i, n)| RunInfo {
                    name: (*n).to_owned(),
                    file: format!("ds{}.csv", i + 1),
                    role: if i == 0 { "estimation" } else { "validation" }.to_owned(),
                    samples: 100,
                    duration_s: 10.0,
                    valve_action: i == 2,
                    thesis_data_set: Some(i as u32 + 1),
                    ceiling: Some(NoiseCeiling {
                        source: if i == 0 { "truth" } else { "estimated" }.to_owned(),
                        height_percent: 98.9,
                        pressure_percent: 99.4,
                        height_noise_std_mm: 0.15,
                        pressure_noise_std_kpa: 0.2,
                        logged_input: (i == 1).then_some(LoggedInputCeiling {
                            height_percent: 92.8,
                            pressure_percent: 90.8,
                        }),
                    }),
                    format: "CSV".to_owned(),
                    notes: Vec::new(),
                })
                .collect(),
            submodels: SubmodelResults {
                fits: vec![SubmodelFit {
                    name: "fill_valve".to_owned(),
                    description: "R_flow1".to_owned(),
                    parameters: vec![],
                    nrmse_estimation_percent: None,
                    nrmse_validation_percent: None,
                    notes: vec![],
                    error: Some("no fill discharge in the study".to_owned()),
                }],
            },
            protocols: vec![ProtocolResult {
                name: "thesis".to_owned(),
                description: "estimation on data-set 1".to_owned(),
                estimation_runs: vec!["data-set 1".to_owned()],
                models: vec![good, failed],
            }],
            elapsed_s: 2.0,
            // Decided by the study; the report only renders it.
            findings: Findings {
                uses: vec![ModelUse {
                    purpose: "level_control".to_owned(),
                    protocol: "thesis".to_owned(),
                    runs: vec!["data-set 3".to_owned()],
                    ranking: vec![RankedModel {
                        model: "m2".to_owned(),
                        mean_nrmse_percent: 67.5,
                    }],
                    best_other_than_truck: None,
                }],
                valve_data: None,
            },
        }
    }

    fn charts() -> Vec<Chart> {
        vec![
            Chart {
                name: "ok".to_owned(),
                section: "thesis protocol: m2".to_owned(),
                title: "m2 on data-set 2".to_owned(),
                panels: vec![Panel {
                    title: "height".to_owned(),
                    x_label: "time [s]".to_owned(),
                    y_label: "height [mm]".to_owned(),
                    series: vec![Series {
                        name: "measured".to_owned(),
                        x: vec![0.0, 1.0, 2.0],
                        y: vec![240.0, 238.0, 239.0],
                        style: SeriesStyle::Line,
                        color: 0,
                    }],
                    band: None,
                }],
            },
            Chart {
                name: "all_nan".to_owned(),
                section: "thesis protocol: m3".to_owned(),
                title: "nothing finite".to_owned(),
                panels: vec![Panel {
                    series: vec![Series {
                        name: "broken".to_owned(),
                        x: vec![f64::NAN],
                        y: vec![f64::NAN],
                        style: SeriesStyle::Dots,
                        color: 1,
                    }],
                    ..Default::default()
                }],
            },
        ]
    }

    #[test]
    fn a_pooled_estimate_is_shown_beside_the_kept_one_and_allowed_trades_are_said() {
        let dir = tempfile::tempdir().unwrap();
        let plain = write_report(&dir.path().join("plain"), &results(), &[]).unwrap();
        let plain = std::fs::read_to_string(&plain.html).unwrap();
        assert!(!plain.contains("<th>pooled estimate</th>") && !plain.contains("trades allowed"));
        let mut traded = results();
        traded.allow_trades = true;
        traded.protocols[0].models[0].runs[0].pooled = Some(OutputFit {
            height_percent: 12.34,
            pressure_percent: -45.67,
        });
        let files = write_report(&dir.path().join("traded"), &traded, &[]).unwrap();
        let html = std::fs::read_to_string(&files.html).unwrap();
        assert!(
            html.contains("<th>pooled estimate</th>") && html.contains("12.3 / -45.7"),
            "the pooled fit is tabled"
        );
        assert!(html.contains("trades allowed: a pooled estimate"));
    }

    #[test]
    fn a_report_with_a_failed_model_still_renders_and_says_what_failed() {
        let dir = tempfile::tempdir().unwrap();
        let files = write_report(dir.path(), &results(), &charts()).unwrap();
        let html = std::fs::read_to_string(&files.html).unwrap();
        assert!(html.contains("This model failed: no static equilibrium at 329 kPa"));
        assert!(html.contains("failed: no fill discharge in the study"));
        assert!(
            html.contains("<b>no</b> (kept nominal): no sensitivity: the outputs do not depend"),
            "non-identifiable parameters are marked, with the reason"
        );
        // Left where a winning start of the global stage drew it, not at the nominal value:
        // said so.
        let mut drawn = results();
        let estimate = drawn.protocols[0].models[0]
            .estimates
            .iter_mut()
            .find(|e| !e.identifiable)
            .unwrap();
        estimate.estimate = 1.3 * estimate.nominal;
        let files = write_report(dir.path(), &drawn, &charts()).unwrap();
        let moved = std::fs::read_to_string(&files.html).unwrap();
        assert!(
            moved.contains("<b>no</b> (kept where the fit's start left it): no sensitivity"),
            "a parameter the fit could not determine, away from its nominal value"
        );
        assert!(!moved.contains("(kept nominal)"));
        // Notes are escaped, not injected.
        assert!(html.contains("&lt;closed valve&gt;"));
        // Our numbers beside the thesis': Table 5.14 for m2 on data-set 2.
        assert!(
            html.contains("86.9 / 89.7"),
            "thesis validation numbers shown"
        );
        assert!(html.contains("Table 5.11"));
        assert!(
            html.contains(
                "converged (gradient 3.2e-7); load eased over 4.2 s (estimation runs: each change over its own, 3.2–6.9 s); validation runs: each change over its own, fitted with the parameters fixed, 4.4–7.5 s; 32 points screened (5 did not simulate), 3 better than the start; 4 starts (1 failed), local optima's losses 1.200e-2 to 1.500e0"
            ),
            "the global stage's spread"
        );
        assert!(
            html.contains("<td class=\"num\">57 (3 failed)</td>"),
            "failed trial simulations counted"
        );
        // Every fit beside the noise ceiling; an estimated one is marked.
        assert!(
            html.contains("<td><i>noise ceiling</i></td><td><i>98.9</i></td><td><i>99.4</i></td><td><i>98.9~</i></td>"),
            "ceiling row"
        );
        assert!(
            html.contains("<td><i>ceiling, load as logged</i></td><td><i>98.9</i></td><td><i>99.4</i></td><td><i>92.8</i></td><td><i>90.8</i></td>"),
            "logged-input ceiling row"
        );
        assert!(
            html.contains("<b>Level-controller design:</b> <code>m2</code> (67.5 %)"),
            "the study's findings in words"
        );
        assert!(html.contains("<svg"), "figures inline");
        // Self-contained: no scripts and nothing fetched (the SVG namespace URI is a name).
        assert!(!html.contains("<script"));
        for fetch in ["src=\"http", "href=\"http", "url(http", "@import"] {
            assert!(!html.contains(fetch), "external resource: {fetch}");
        }
        assert!(files.chart_failures.is_empty() || html.contains("could not be drawn"));
    }

    #[test]
    fn a_chart_that_cannot_be_written_is_reported_in_its_place_and_the_rest_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let r = results();
        let mut charts = vec![charts()[0].clone()];
        // A file name inside a folder that does not exist: the SVG write must fail.
        let mut unwritable = charts[0].clone();
        unwritable.name = "no_such_folder/fig_m2".to_owned();
        unwritable.title = "the unwritable one".to_owned();
        charts.push(unwritable);
        let files = write_report(dir.path(), &r, &charts).unwrap();
        assert_eq!(files.chart_failures.len(), 1, "{:?}", files.chart_failures);
        assert!(
            files.chart_failures[0].contains("no_such_folder"),
            "{:?}",
            files.chart_failures
        );
        let html = std::fs::read_to_string(&files.html).unwrap();
        assert_eq!(html.matches("could not be drawn").count(), 1);
        assert!(html.contains("Figure no_such_folder/fig_m2 could not be drawn"));
        assert!(files.figures.contains(&dir.path().join("figures/ok.svg")));
        assert!(dir.path().join("figures/ok.png").exists());
        assert!(files.json.exists());
    }

    #[test]
    fn results_json_round_trips_from_disk() {
        let dir = tempfile::tempdir().unwrap();
        let r = results();
        let files = write_report(dir.path(), &r, &[]).unwrap();
        let back: StudyResults =
            serde_json::from_str(&std::fs::read_to_string(files.json).unwrap()).unwrap();
        assert_eq!(back, r);
    }
}
