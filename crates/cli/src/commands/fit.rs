//! `airsus fit <submodel>`: the thesis' submodel fits (5.2), each printing its parameters
//! and residual NRMSE, optionally writing an updated truck file (`--out`, starting from
//! `--truck` or the reference truck).
//!
//! * `cross-section` — `A(h) = A0 + A1 h` from a closed-valve run (eq 5.1–5.3, Table 5.1);
//! * `effective-area` — 4th-degree `A_eff(h)` (eq 3.16/5.4) or a monotone spline from a bellow
//!   force map;
//! * `wall-friction` — the `truck` structure's `fc` from a force map's up/down hysteresis;
//! * `valve` — `R_flow1`, `R_flow2` from tank discharges (eq 3.19/5.5/5.6, Table 5.3), from a
//!   study file or from `--discharge` files with their metadata;
//! * `slow-dynamics` — the OE block of Model 2 extended from one load step (5.2.4).

use airsus_data::atomic::refuse_overwriting_inputs;
use std::path::{Path, PathBuf};

use airsus_data::{
    Channel, Role, TruckParameters, read_discharge, read_force_map, read_study, read_truck,
    write_truck,
};
use airsus_estimate::submodel::{
    CrossSectionOptions, CrossSectionScale, DischargeData, EffectiveAreaOptions, LinearValveFit,
    OrificeDischargeFit, OrificeFit, OrificeFitOptions, SlowDynamicsOptions, ValveFitOptions,
    fit_cross_section, fit_effective_area, fit_effective_area_spline, fit_linear_valve,
    fit_orifice, fit_slow_dynamics, fit_valve, fit_wall_friction,
};
use airsus_ident::linear::OeOrders;
use anyhow::{Context, bail};

/// Fit one submodel to lab or run data (thesis 5.2).
#[derive(Debug, Clone, clap::Args)]
pub struct FitArgs {
    #[command(subcommand)]
    pub fit: FitCommand,
    /// Truck parameter file to start from (default: the reference truck).
    #[arg(long, global = true)]
    pub truck: Option<PathBuf>,
    /// Write the truck with the fitted parameters to this file.
    #[arg(long, global = true)]
    pub out: Option<PathBuf>,
    /// Print the result as JSON.
    #[arg(long, global = true)]
    pub json: bool,
}

#[derive(Debug, Clone, clap::Subcommand)]
pub enum FitCommand {
    /// Gas-volume cross-section A(h) = A0 + A1 h from a closed-valve load-step run. The run
    /// fixes only the shape A1/A0; the scale A0 is kept from the truck unless
    /// --known-volume-l and --at-height-mm are given.
    CrossSection {
        /// Closed-valve run (estimation).
        #[arg(long)]
        run: PathBuf,
        /// Closed-valve run(s) to validate on; repeatable.
        #[arg(long)]
        validation: Vec<PathBuf>,
        /// Known gas volume of the circuit, litres, at --at-height-mm.
        #[arg(long, requires = "at_height_mm")]
        known_volume_l: Option<f64>,
        /// Bellow height of --known-volume-l, mm.
        #[arg(long, requires = "known_volume_l")]
        at_height_mm: Option<f64>,
        /// Fit only samples at least this long after the logged load last changed, s (the
        /// study uses 120: a load step heats or cools the gas, and the wall creeps, for tens of
        /// seconds). Default: every sample, as thesis 5.2.1.
        #[arg(long)]
        settled_after_s: Option<f64>,
    },
    /// Effective area: per-height least squares of F = p A_eff, then the quartic (thesis
    /// 5.2.2) or a monotone spline through the heights. A truck whose law stretches the area
    /// with pressure (`kap`) gets the areas at zero pressure.
    EffectiveArea {
        /// Bellow force map (CSV: bellow_height_mm, pressure_kpa, force_n).
        #[arg(long)]
        force_map: PathBuf,
        /// Polynomial degree (the truck file holds degree 4).
        #[arg(long, default_value_t = 4)]
        degree: usize,
        /// The law to fit: `polynomial` (eq 5.4) or `spline` (one knot per map height, at most
        /// 16). Default: the --truck file's law (a spline for a spline, else the quartic).
        #[arg(long, value_enum)]
        law: Option<AreaLawArg>,
        /// Fit the area's growth with pressure `kap` from the map too (two heights measured at
        /// two pressures or more): the areas are those at zero pressure, and the law written
        /// stretches them (`polynomial_pressure`, or the spline with `growth_per_100kpa`).
        /// Without it: the --truck file's `kap`, or `F = p A(h)` as the thesis.
        #[arg(long)]
        fit_kap: bool,
    },
    /// Wall friction `fc` (the `truck` structure's `[effects] friction_force_n`) from the
    /// hysteresis of a force map measured in up and down sweeps: half the difference of the
    /// downward and upward forces at one height and pressure.
    WallFriction {
        /// Bellow force map (CSV: bellow_height_mm, pressure_kpa, force_n), rows in the order
        /// measured.
        #[arg(long)]
        force_map: PathBuf,
        /// Heights closer than this are one height (a move smaller than it is none), mm.
        #[arg(long, default_value_t = 0.1)]
        height_tolerance_mm: f64,
    },
    /// Valve flow resistances from tank discharges, via the ideal gas law and a
    /// Savitzky–Golay derivative of the tank pressure.
    Valve {
        /// Study file: its [[discharge]] entries are used.
        #[arg(long, conflicts_with = "discharge")]
        study: Option<PathBuf>,
        /// Tank-discharge file (CSV: time_s, tank_kpa); repeatable.
        #[arg(long)]
        discharge: Vec<PathBuf>,
        /// Channel of each --discharge (one value for all, or one per file).
        #[arg(long, value_enum, value_delimiter = ',')]
        channel: Vec<ChannelArg>,
        /// Tank volume in litres (one value, or one per file).
        #[arg(long, value_delimiter = ',')]
        tank_volume_l: Vec<f64>,
        /// Gas temperature in K (one value, or one per file; default 293.15).
        #[arg(long, value_delimiter = ',')]
        temperature_k: Vec<f64>,
        /// Role of each --discharge (default estimation).
        #[arg(long, value_enum, value_delimiter = ',')]
        role: Vec<RoleArg>,
        /// Savitzky–Golay half window (window 2m+1 samples).
        #[arg(long, default_value_t = 5)]
        half_window: usize,
        /// The law to fit: `linear` (the thesis' resistances, isothermal, eq 5.5/5.6),
        /// `linear-cooling` (the same resistances, the tank's gas simulated with its cooling,
        /// as the study gives the `truck` structure) or `orifice` (ISO 6358 c1, c2, bcr, the
        /// tank's gas simulated). The residuals of the last two tell which law the valve
        /// follows. Default: the --truck file's valve law.
        #[arg(long, value_enum)]
        law: Option<ValveLawArg>,
    },
    /// Slow-dynamics OE model (load change → slow height change) from one load step.
    SlowDynamics {
        /// Run with a load step (valve closed).
        #[arg(long)]
        run: PathBuf,
        /// Time of the step to use, s (default: the largest load change).
        #[arg(long)]
        step_time_s: Option<f64>,
        /// Seconds after the step before the window starts (fast response settled).
        #[arg(long, default_value_t = 3.0)]
        settle_s: f64,
        /// Longest window, s (default: up to the next load change).
        #[arg(long)]
        window_s: Option<f64>,
        #[arg(long, default_value_t = 1)]
        nb: usize,
        #[arg(long, default_value_t = 1)]
        nf: usize,
        #[arg(long, default_value_t = 2)]
        nk: usize,
    },
}

impl FitCommand {
    /// The files this fit reads (a study's own files are checked when it is read).
    fn input_paths(&self) -> Vec<&Path> {
        match self {
            Self::CrossSection {
                run, validation, ..
            } => std::iter::once(run.as_path())
                .chain(validation.iter().map(PathBuf::as_path))
                .collect(),
            Self::EffectiveArea { force_map, .. } | Self::WallFriction { force_map, .. } => {
                vec![force_map]
            }
            Self::Valve {
                study, discharge, ..
            } => study
                .iter()
                .chain(discharge)
                .map(PathBuf::as_path)
                .collect(),
            Self::SlowDynamics { run, .. } => vec![run],
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ValveLawArg {
    Linear,
    LinearCooling,
    Orifice,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AreaLawArg {
    Polynomial,
    Spline,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ChannelArg {
    Fill,
    Exhaust,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RoleArg {
    Estimation,
    Validation,
}

/// One value for all files, or one per file.
fn per_file<T: Copy>(
    values: &[T],
    n: usize,
    flag: &str,
    default: Option<T>,
) -> anyhow::Result<Vec<T>> {
    match (values.len(), default) {
        (0, Some(d)) => Ok(vec![d; n]),
        (0, None) => bail!("{flag} is required with --discharge"),
        (1, _) => Ok(vec![values[0]; n]),
        (k, _) if k == n => Ok(values.to_vec()),
        (k, _) => bail!("{flag} has {k} values for {n} discharge files: give one, or one per file"),
    }
}

fn load_truck(path: Option<&Path>) -> anyhow::Result<TruckParameters> {
    Ok(match path {
        Some(p) => read_truck(p)?.parameters,
        None => TruckParameters::reference(),
    })
}

fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

pub fn run(args: &FitArgs) -> anyhow::Result<()> {
    if let Some(out) = &args.out {
        let mut inputs: Vec<&Path> = args.truck.iter().map(PathBuf::as_path).collect();
        inputs.extend(args.fit.input_paths());
        refuse_overwriting_inputs(out, &inputs)?;
    }
    let mut truck = load_truck(args.truck.as_deref())?;
    match &args.fit {
        FitCommand::CrossSection {
            run,
            validation,
            known_volume_l,
            at_height_mm,
            settled_after_s,
        } => {
            if let Some(settle) = settled_after_s
                && !(settle.is_finite() && *settle >= 0.0)
            {
                bail!("--settled-after-s must be a time of zero or more seconds, got {settle}");
            }
            let est = airsus_logs::read_plain_run(run)
                .with_context(|| format!("run {}", run.display()))?;
            let vals = validation
                .iter()
                .map(|p| {
                    airsus_logs::read_plain_run(p)
                        .with_context(|| format!("validation run {}", p.display()))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let val_refs: Vec<&_> = vals.iter().collect();
            let scale = match (known_volume_l, at_height_mm) {
                (Some(v), Some(h)) => CrossSectionScale::KnownVolume {
                    bellow_height_m: h * 1e-3,
                    volume_m3: v * 1e-3,
                },
                _ => CrossSectionScale::KeepA0,
            };
            let options = CrossSectionOptions {
                scale,
                settled_after_s: *settled_after_s,
                ..CrossSectionOptions::default()
            };
            let fit = fit_cross_section(&est, &val_refs, &truck, &options)?;
            if args.json {
                print_json(&fit)?;
            } else {
                println!(
                    "Cross-section A(h) = A0 + A1 h (thesis eq 5.1-5.3), run {}",
                    est.name
                );
                println!(
                    "  shape A1/A0 = {:.5} ± {:.5} 1/m (what a closed-valve run determines)",
                    fit.ratio_per_m, fit.ratio_std_per_m
                );
                match fit.scale {
                    CrossSectionScale::KeepA0 => println!(
                        "  A0 = {:.5} m² kept from the truck (a closed-valve run cannot determine the scale)",
                        fit.a0_m2
                    ),
                    CrossSectionScale::KnownVolume { .. } => {
                        println!("  A0 = {:.5} m² from the known volume", fit.a0_m2)
                    }
                }
                println!("  A1 = {:.5} ± {:.5} m", fit.a1_m, fit.a1_std_m);
                println!(
                    "  {} samples in {} load holds{}, bellow height {:.1}-{:.1} mm{}",
                    fit.samples,
                    fit.holds,
                    settled_after_s.map_or(String::new(), |s| format!(
                        " ({s} s or more after a load change)"
                    )),
                    fit.bellow_height_range_m.0 * 1e3,
                    fit.bellow_height_range_m.1 * 1e3,
                    if fit.converged {
                        ""
                    } else {
                        " (Gauss-Newton NOT converged)"
                    }
                );
                println!(
                    "  pressure-model NRMSE: estimation {:.2} %",
                    fit.nrmse_estimation_percent
                );
                for (name, v) in &fit.nrmse_validation_percent {
                    let every = if fit.validation_on_every_sample.contains(name) {
                        " (every sample: its loads are not held long enough for settled ones)"
                    } else {
                        ""
                    };
                    println!("                        validation {name}: {v:.2} %{every}");
                }
            }
            fit.write_to(&mut truck);
        }
        FitCommand::EffectiveArea {
            force_map,
            degree,
            law,
            fit_kap,
        } => {
            let map = read_force_map(force_map)?;
            let options = EffectiveAreaOptions {
                degree: *degree,
                fit_growth: *fit_kap,
                ..EffectiveAreaOptions::for_truck(&truck)
            };
            let law = law.unwrap_or(if truck.bellow.effective_area.knots().is_some() {
                AreaLawArg::Spline
            } else {
                AreaLawArg::Polynomial
            });
            if law == AreaLawArg::Spline {
                let fit = fit_effective_area_spline(&map, &options)?;
                if args.json {
                    print_json(&fit)?;
                } else {
                    println!(
                        "Effective area A_eff(h), monotone spline (eq 3.16), {} points at {} heights, {} knots",
                        fit.points,
                        fit.map_heights,
                        fit.heights_m.len()
                    );
                    for (i, ((h, a), s)) in fit
                        .heights_m
                        .iter()
                        .zip(&fit.areas_m2)
                        .zip(&fit.areas_std_m2)
                        .enumerate()
                    {
                        println!("  s{i:<2} at {:>6.1} mm = {a:.6} ± {s:.6} m²", h * 1e3);
                    }
                    if let Some(kap) = fit.growth_per_100kpa {
                        println!(
                            "  areas at zero pressure; kap = {kap} per 100 kPa {}",
                            if *fit_kap {
                                "fitted to the map"
                            } else {
                                "from the truck"
                            }
                        );
                    }
                    println!("  NRMSE: force {:.2} %", fit.force_nrmse_percent);
                }
                if args.out.is_some() {
                    fit.write_to(&mut truck)?;
                }
            } else {
                let fit = fit_effective_area(&map, &options)?;
                if args.json {
                    print_json(&fit)?;
                } else {
                    println!(
                        "Effective area A_eff(h) = sum p_i h^i (thesis eq 3.16/5.4), {} points at {} heights",
                        fit.points,
                        fit.per_height.len()
                    );
                    for (i, (p, s)) in fit.poly.iter().zip(&fit.poly_std).enumerate() {
                        println!("  p{i} = {p:>12.5} ± {s:.5}");
                    }
                    if let Some(kap) = fit.growth_per_100kpa {
                        match fit.growth_std_per_100kpa {
                            Some(std) => println!(
                                "  kap = {kap:.5} ± {std:.5} per 100 kPa (fitted to the map; the p_i are the area at zero pressure)"
                            ),
                            None => println!(
                                "  kap = {kap} per 100 kPa from the truck (the p_i are the area at zero pressure)"
                            ),
                        }
                    }
                    println!(
                        "  NRMSE: area vs per-height LS {:.2} %, force {:.2} %",
                        fit.area_nrmse_percent, fit.force_nrmse_percent
                    );
                }
                if args.out.is_some() {
                    if *fit_kap
                        && matches!(
                            truck.bellow.effective_area,
                            airsus_data::EffectiveAreaLaw::Polynomial { .. }
                        )
                    {
                        // The thesis' quartic has no growth to write the fitted one into: the
                        // law becomes the quartic that stretches with pressure.
                        truck.bellow.effective_area = fit.law()?;
                    } else {
                        fit.write_to(&mut truck)?;
                    }
                }
            }
        }
        FitCommand::WallFriction {
            force_map,
            height_tolerance_mm,
        } => {
            if !(height_tolerance_mm.is_finite() && *height_tolerance_mm >= 0.0) {
                bail!(
                    "--height-tolerance-mm must be a length of zero or more, got {height_tolerance_mm}"
                );
            }
            let map = read_force_map(force_map)?;
            let fit = fit_wall_friction(&map, height_tolerance_mm * 1e-3)?;
            if args.json {
                print_json(&fit)?;
            } else {
                println!(
                    "Wall friction from the force map's sweeps: fc = {:.1} ± {:.1} N ({} up/down pairs)",
                    fit.friction_force_n, fit.friction_force_std_n, fit.pairs
                );
            }
            airsus_data::params::set(
                &mut truck,
                airsus_data::params::Field::WallFrictionForce,
                fit.friction_force_n,
            );
        }
        FitCommand::Valve {
            study,
            discharge,
            channel,
            tank_volume_l,
            temperature_k,
            role,
            half_window,
            law,
        } => {
            // (name, file, channel, volume m³, temperature, role)
            let mut specs = Vec::new();
            if let Some(study_path) = study {
                let s = read_study(study_path)?;
                if let Some(out) = &args.out {
                    refuse_overwriting_inputs(out, &s.files())?;
                }
                if s.discharges.is_empty() {
                    bail!("study {} lists no [[discharge]]", study_path.display());
                }
                for d in s.discharges {
                    specs.push((d.file, d.channel, d.tank_volume_m3, d.temperature_k, d.role));
                }
            } else {
                let n = discharge.len();
                if n == 0 {
                    bail!("give --study or at least one --discharge");
                }
                let channels = per_file(channel, n, "--channel", None)?;
                let volumes = per_file(tank_volume_l, n, "--tank-volume-l", None)?;
                let temps = per_file(temperature_k, n, "--temperature-k", Some(293.15))?;
                let roles = per_file(role, n, "--role", Some(RoleArg::Estimation))?;
                for i in 0..n {
                    specs.push((
                        discharge[i].clone(),
                        match channels[i] {
                            ChannelArg::Fill => Channel::Fill,
                            ChannelArg::Exhaust => Channel::Exhaust,
                        },
                        volumes[i] * 1e-3,
                        temps[i],
                        match roles[i] {
                            RoleArg::Estimation => Role::Estimation,
                            RoleArg::Validation => Role::Validation,
                        },
                    ));
                }
            }
            let loaded = specs
                .iter()
                .map(|(file, ..)| {
                    read_discharge(file).with_context(|| format!("discharge {}", file.display()))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let data: Vec<DischargeData<'_>> = specs
                .iter()
                .zip(&loaded)
                .map(|((file, ch, v, t, r), d)| DischargeData {
                    name: file.display().to_string(),
                    discharge: d,
                    channel: *ch,
                    tank_volume_m3: *v,
                    temperature_k: *t,
                    role: *r,
                })
                .collect();
            let law = law.unwrap_or(match truck.valve {
                airsus_data::ValveFlowLaw::Orifice { .. } => ValveLawArg::Orifice,
                _ => ValveLawArg::Linear,
            });
            if law == ValveLawArg::Orifice {
                let fit = fit_orifice(&data, &OrificeFitOptions::for_truck(&truck))?;
                if args.json {
                    print_json(&fit)?;
                } else {
                    print_orifice_fit(&fit);
                }
                written_or_noted(args, fit.write_to(&mut truck))?;
                return finish(args, &truck);
            }
            if law == ValveLawArg::LinearCooling {
                let fit = fit_linear_valve(&data, &OrificeFitOptions::for_truck(&truck))?;
                if args.json {
                    print_json(&fit)?;
                } else {
                    print_linear_cooling_fit(&fit);
                }
                written_or_noted(args, fit.write_to(&mut truck))?;
                return finish(args, &truck);
            }
            let options = ValveFitOptions {
                half_window: *half_window,
                ..ValveFitOptions::for_truck(&truck)
            };
            let fit = fit_valve(&data, &options)?;
            if args.json {
                print_json(&fit)?;
            } else {
                println!(
                    "Valve flow resistances (thesis eq 3.19/5.5/5.6), Savitzky-Golay slope over {} samples",
                    2 * half_window + 1
                );
                for (label, c) in [
                    ("R_flow1 (fill)", &fit.fill),
                    ("R_flow2 (exhaust)", &fit.exhaust),
                ] {
                    match c {
                        Some(c) => {
                            println!(
                                "  {label} = {:.4e} ± {:.2e} Pa s/mol",
                                c.resistance_pa_s_per_mol, c.resistance_std
                            );
                            for d in &c.discharges {
                                println!(
                                    "    {:<40} {:<10} {:>6} samples  flow NRMSE {}",
                                    d.name,
                                    d.role.as_str(),
                                    d.samples_used,
                                    d.nrmse_percent
                                        .map_or_else(|| "—".to_owned(), |v| format!("{v:.2} %"))
                                );
                            }
                        }
                        None => println!("  {label}: no estimation discharge, not fitted"),
                    }
                }
            }
            // A truck under another valve law keeps it: said, and an error only when the
            // updated file was asked for.
            written_or_noted(args, fit.write_to(&mut truck))?;
        }
        FitCommand::SlowDynamics {
            run,
            step_time_s,
            settle_s,
            window_s,
            nb,
            nf,
            nk,
        } => {
            let r = airsus_logs::read_plain_run(run)
                .with_context(|| format!("run {}", run.display()))?;
            let options = SlowDynamicsOptions {
                orders: OeOrders::siso(*nb, *nf, *nk),
                step_time_s: *step_time_s,
                settle_s: *settle_s,
                window_s: *window_s,
                ..SlowDynamicsOptions::default()
            };
            let fit = fit_slow_dynamics(&r, &options)?;
            if args.json {
                print_json(&fit)?;
            } else {
                println!(
                    "Slow dynamics OE [nb nf nk] = [{nb} {nf} {nk}] (thesis 5.2.4), step {:+.0} kg at {:.1} s, window {:.1}-{:.1} s",
                    fit.step_kg, fit.step_time_s, fit.window_s.0, fit.window_s.1
                );
                for p in &fit.estimate.parameters {
                    println!(
                        "  {:<4} = {:>12.4e} ± {:.3e} (on the window)",
                        p.name, p.value, p.std
                    );
                }
                println!(
                    "  b after the settling correction (÷{:.4}): {:?} m/kg",
                    fit.gain_correction, fit.b
                );
                println!(
                    "  static gain {:.4e} m/kg{}",
                    fit.static_gain_m_per_kg,
                    fit.time_constant_s
                        .map_or_else(String::new, |t| format!(", time constant {t:.1} s"))
                );
                println!("  NRMSE on the window {:.2} %", fit.nrmse_percent);
            }
            fit.write_to(&mut truck);
        }
    }
    finish(args, &truck)
}

/// A fit that its truck file cannot take (another law, a value out of range): an error when
/// the updated file was asked for (`--out`), a note otherwise.
fn written_or_noted(
    args: &FitArgs,
    written: Result<(), airsus_estimate::EstimateError>,
) -> anyhow::Result<()> {
    match written {
        Err(e) if args.out.is_some() => Err(e.into()),
        Err(e) => {
            eprintln!("note: {e}");
            Ok(())
        }
        Ok(()) => Ok(()),
    }
}

/// Writes the updated truck where `--out` asks for it.
fn finish(args: &FitArgs, truck: &TruckParameters) -> anyhow::Result<()> {
    if let Some(out) = &args.out {
        write_truck(out, truck)?;
        if !args.json {
            println!("updated truck written to {}", out.display());
        }
    }
    Ok(())
}

fn print_linear_cooling_fit(fit: &LinearValveFit) {
    println!(
        "Valve flow resistances (thesis eq 3.19), the tank's gas simulated with its cooling; residual {:.0} Pa",
        fit.residual_rms_pa
    );
    for (label, value, std) in [
        (
            "R_flow1 (fill)",
            fit.fill_resistance_pa_s_per_mol,
            fit.std[0],
        ),
        (
            "R_flow2 (exhaust)",
            fit.exhaust_resistance_pa_s_per_mol,
            fit.std[1],
        ),
    ] {
        match value {
            Some(v) => println!("  {label:<17} = {v:.4e} ± {} Pa s/mol", spread(std)),
            None => println!("  {label:<17}: no estimation discharge, not fitted"),
        }
    }
    println!(
        "  tank wall         = {:.1} ± {} s (the rig's, not the truck's)",
        fit.tank_thermal_time_s,
        spread(fit.std[2])
    );
    print_tank_discharges(&fit.discharges);
}

/// A standard deviation, or a dash where none is known.
fn spread(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2e}")
    } else {
        "—".to_owned()
    }
}

fn print_tank_discharges(discharges: &[OrificeDischargeFit]) {
    for d in discharges {
        println!(
            "    {:<40} {:<10} tank pressure NRMSE {:.2} %",
            d.name,
            d.role.as_str(),
            d.nrmse_percent
        );
    }
}

fn print_orifice_fit(fit: &OrificeFit) {
    println!(
        "Valve orifice (ISO 6358), the tank's gas simulated with its cooling; residual {:.0} Pa",
        fit.residual_rms_pa
    );
    for (label, value, std) in [
        ("c1 (fill)", fit.fill_conductance_m3_s_pa, fit.std[0]),
        ("c2 (exhaust)", fit.exhaust_conductance_m3_s_pa, fit.std[1]),
    ] {
        match value {
            Some(v) => println!("  {label:<13} = {v:.4e} ± {} m3/(s Pa)", spread(std)),
            None => println!("  {label:<13}: no estimation discharge, not fitted"),
        }
    }
    println!(
        "  bcr           = {:.4} ± {}",
        fit.critical_pressure_ratio,
        spread(fit.std[2])
    );
    println!(
        "  tank wall     = {:.1} ± {} s (the rig's, not the truck's)",
        fit.tank_thermal_time_s,
        spread(fit.std[3])
    );
    print_tank_discharges(&fit.discharges);
}
