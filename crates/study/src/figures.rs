//! The report's figures as charts: measured against simulated (thesis Figs 5.14–5.52),
//! residual correlations with their bands, the force map and its fit (Fig 5.8), the discharge
//! flow fits (Figs 5.9–5.13) and pressure against height (Fig 5.7).

use airsus_data::{Channel, TruckParameters};
use airsus_estimate::submodel::derivative::savitzky_golay_slope;
use airsus_report::chart::{Chart, Panel, Series, SeriesStyle};
use airsus_sim::SimulationResponse;

use crate::input::{StudyInput, StudyRunData};
use crate::models::ResidualCorrelation;

fn line(name: &str, x: &[f64], y: Vec<f64>, color: usize) -> Series {
    Series {
        name: name.to_owned(),
        x: x.to_vec(),
        y,
        style: SeriesStyle::Line,
        color,
    }
}

fn slug(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// Measured height and pressure of a run against every model's simulation.
pub fn measured_vs_simulated(
    section: &str,
    run: &StudyRunData,
    models: &[(String, &SimulationResponse)],
) -> Option<Chart> {
    let measured = run.run.outputs.as_ref()?;
    let t = &run.run.time_s;
    let mut height = vec![line(
        "measured",
        t,
        measured.sensor_height_m.iter().map(|h| h * 1e3).collect(),
        7,
    )];
    let mut pressure = vec![line(
        "measured",
        t,
        measured.bellow_gauge_pa.iter().map(|p| p * 1e-3).collect(),
        7,
    )];
    for (i, (name, r)) in models.iter().enumerate() {
        height.push(line(
            name,
            t,
            r.sensor_height_m.iter().map(|h| h * 1e3).collect(),
            i,
        ));
        pressure.push(line(
            name,
            t,
            r.bellow_gauge_pa.iter().map(|p| p * 1e-3).collect(),
            i,
        ));
    }
    Some(Chart {
        name: format!("sim_{}_{}", slug(section), slug(&run.name)),
        section: section.to_owned(),
        title: format!("{}: measured and simulated", run.name),
        panels: vec![
            Panel {
                title: "sensor height".to_owned(),
                x_label: "time [s]".to_owned(),
                y_label: "height [mm]".to_owned(),
                series: height,
                band: None,
            },
            Panel {
                title: "bellow pressure".to_owned(),
                x_label: "time [s]".to_owned(),
                y_label: "gauge pressure [kPa]".to_owned(),
                series: pressure,
                band: None,
            },
        ],
    })
}

/// Residual correlations of one model on one run: autocorrelation and cross-correlation
/// with each input that varies, both outputs, each panel with its 99 % band.
pub fn residual_chart(
    section: &str,
    model: &str,
    run: &StudyRunData,
    correlations: &[ResidualCorrelation],
) -> Option<Chart> {
    let label = |input: &'static str| -> &'static str {
        match input {
            "self" => "autocorrelation",
            "wheel_load" => "× wheel load",
            "valve" => "× valve",
            "supply" => "× supply pressure",
            other => other,
        }
    };
    // Constant inputs (a closed valve throughout) have no correlation to show.
    let panels: Vec<Panel> = correlations
        .iter()
        .filter_map(|c| {
            c.result
                .as_ref()
                .ok()
                .map(|r| correlation_panel(format!("{} residual: {}", c.output, label(c.input)), r))
        })
        .collect();
    (!panels.is_empty()).then(|| Chart {
        name: format!(
            "resid_{}_{}_{}",
            slug(section),
            slug(model),
            slug(&run.name)
        ),
        section: section.to_owned(),
        title: format!(
            "{model} on {}: residual analysis (eq 3.35/3.36, 99 % band)",
            run.name
        ),
        panels,
    })
}

fn correlation_panel(title: String, c: &airsus_validate::Correlation) -> Panel {
    Panel {
        title,
        x_label: "lag [samples]".to_owned(),
        y_label: "correlation".to_owned(),
        series: vec![Series {
            name: String::new(),
            x: c.lags.iter().map(|&l| l as f64).collect(),
            y: c.values.clone(),
            style: SeriesStyle::Stems,
            color: 0,
        }],
        band: Some(c.band),
    }
}

/// The force map and the fitted effective area times pressure (thesis Fig 5.8).
pub fn force_map_chart(input: &StudyInput, truck: &TruckParameters) -> Option<Chart> {
    let map = input.force_map.as_ref()?;
    let mut pressures: Vec<f64> = map.bellow_gauge_pa.clone();
    pressures.sort_by(f64::total_cmp);
    pressures.dedup_by(|a, b| (*a - *b).abs() < 1.0);
    let mut series = Vec::new();
    for (i, &p) in pressures.iter().enumerate() {
        let idx: Vec<usize> = (0..map.len())
            .filter(|&k| (map.bellow_gauge_pa[k] - p).abs() < 1.0)
            .collect();
        let h: Vec<f64> = idx.iter().map(|&k| map.bellow_height_m[k] * 1e3).collect();
        series.push(Series {
            name: format!("{:.0} kPa measured", p * 1e-3),
            x: h,
            y: idx.iter().map(|&k| map.force_n[k] * 1e-3).collect(),
            style: SeriesStyle::Dots,
            color: i,
        });
        let (lo, hi) = idx
            .iter()
            .map(|&k| map.bellow_height_m[k])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        let grid: Vec<f64> = (0..=40)
            .map(|j| lo + (hi - lo) * f64::from(j) / 40.0)
            .collect();
        series.push(Series {
            name: String::new(),
            x: grid.iter().map(|h| h * 1e3).collect(),
            y: grid
                .iter()
                .map(|&h| p * truck.bellow.effective_area.area_m2(h, p) * 1e-3)
                .collect(),
            style: SeriesStyle::Line,
            color: i,
        });
    }
    Some(Chart {
        name: "force_map".to_owned(),
        section: "Submodels".to_owned(),
        title: "Bellow force map and the fitted effective area (thesis Fig 5.8)".to_owned(),
        panels: vec![Panel {
            title: "dots: lab measurements; lines: p·A_eff(h) with the fitted polynomial"
                .to_owned(),
            x_label: "bellow height [mm]".to_owned(),
            y_label: "force [kN]".to_owned(),
            series,
            band: None,
        }],
    })
}

/// Air flow out of each discharge tank, from the measured pressure and from the fitted
/// resistance (thesis Figs 5.9–5.13).
pub fn discharge_chart(input: &StudyInput, truck: &TruckParameters) -> Option<Chart> {
    if input.discharges.is_empty() {
        return None;
    }
    let half_window = 5;
    let r_gas = truck.environment.gas_constant_j_mol_k;
    let panels = input
        .discharges
        .iter()
        .map(|d| {
            let ts = d.discharge.sample_time_s;
            let slope = savitzky_golay_slope(&d.discharge.tank_gauge_pa, ts, half_window);
            let scale = d.tank_volume_m3 / (r_gas * d.temperature_k);
            let t: Vec<f64> = d.discharge.time_s[half_window..half_window + slope.len()].to_vec();
            let ambient = truck.environment.ambient_pressure_pa;
            let model: Vec<f64> = d.discharge.tank_gauge_pa[half_window..half_window + slope.len()]
                .iter()
                .map(|p| match d.channel {
                    Channel::Fill => {
                        truck
                            .valve
                            .fill_flow_mol_s(p + ambient, ambient, d.temperature_k)
                    }
                    Channel::Exhaust => {
                        truck
                            .valve
                            .exhaust_flow_mol_s(p + ambient, ambient, d.temperature_k)
                    }
                })
                .collect();
            Panel {
                title: format!(
                    "{} ({} channel, {})",
                    d.name,
                    d.channel.as_str(),
                    d.role.as_str()
                ),
                x_label: "time [s]".to_owned(),
                y_label: "flow [mol/s]".to_owned(),
                series: vec![
                    line(
                        "from the tank pressure (eq 5.6)",
                        &t,
                        slope.iter().map(|s| -s * scale).collect(),
                        7,
                    ),
                    line("fitted valve law (eq 3.19)", &t, model, 1),
                ],
                band: None,
            }
        })
        .collect();
    Some(Chart {
        name: "discharges".to_owned(),
        section: "Submodels".to_owned(),
        title: "Tank discharges: air flow and the fitted flow resistance (thesis Figs 5.9-5.13)"
            .to_owned(),
        panels,
    })
}

/// Pressure against bellow height on the closed-valve runs, with the gas law through the
/// first sample using the fitted cross-section (thesis Fig 5.7).
pub fn pressure_height_chart(input: &StudyInput, truck: &TruckParameters) -> Option<Chart> {
    let ambient = truck.environment.ambient_pressure_pa;
    let mut series = Vec::new();
    for (i, r) in input.runs.iter().filter(|r| !r.valve_action()).enumerate() {
        let (Some(out), Some(h_b)) = (
            r.run.outputs.as_ref(),
            crate::coverage::bellow_heights_m(&r.run, truck),
        ) else {
            continue;
        };
        let step = (h_b.len() / 1500).max(1);
        series.push(Series {
            name: format!("{} measured", r.name),
            x: h_b.iter().step_by(step).map(|h| h * 1e3).collect(),
            y: out
                .bellow_gauge_pa
                .iter()
                .step_by(step)
                .map(|p| p * 1e-3)
                .collect(),
            style: SeriesStyle::Dots,
            color: i,
        });
        let pv = (out.bellow_gauge_pa[0] + ambient)
            * truck
                .bellow
                .gas_volume
                .volume_m3(&truck.bellow.effective_area, h_b[0]);
        let (lo, hi) = h_b
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let grid: Vec<f64> = (0..=40)
            .map(|j| lo + (hi - lo) * f64::from(j) / 40.0)
            .collect();
        series.push(Series {
            name: format!("{} gas law", r.name),
            x: grid.iter().map(|h| h * 1e3).collect(),
            y: grid
                .iter()
                .map(|&h| {
                    (pv / truck
                        .bellow
                        .gas_volume
                        .volume_m3(&truck.bellow.effective_area, h)
                        - ambient)
                        * 1e-3
                })
                .collect(),
            style: SeriesStyle::Line,
            color: i,
        });
    }
    (!series.is_empty()).then(|| Chart {
        name: "pressure_vs_height".to_owned(),
        section: "Submodels".to_owned(),
        title: "Pressure against bellow height, valve closed (thesis Fig 5.7)".to_owned(),
        panels: vec![Panel {
            title: "dots: measured; lines: p V(h) = const through the first sample, fitted A(h)"
                .to_owned(),
            x_label: "bellow height [mm]".to_owned(),
            y_label: "gauge pressure [kPa]".to_owned(),
            series,
            band: None,
        }],
    })
}
