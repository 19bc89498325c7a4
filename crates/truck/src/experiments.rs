//! The reference experiments of thesis 5.1 (SPEC §6), produced by the virtual truck and
//! written in the data contract's formats: `airsus generate --out DIR [--seed N]`.
//!
//! DIR receives
//! - `ds1.csv` … `ds4.csv`: the runs as the truck's logger records them (clean load steps,
//!   sensor noise and quantisation, the supply tank's pressure as measured); `lev1.csv`,
//!   `lev2.csv`: levelling runs (load steps while the truck's ECU levels, [`levelling_run`]);
//!   `road1.csv`, `road2.csv`: road runs (humps and potholes; an ISO 8608 road);
//! - `force_map.csv`, `fill_a.csv`, `fill_b.csv`, `exhaust_a.csv`, `exhaust_b.csv`: lab data;
//! - `truck.toml`: what a manufacturer would know is true (geometry, tire, damper,
//!   environment); the parameters to be estimated at the SPEC's nominal guesses;
//! - `study.toml` (the thesis' protocol: estimate on data-set 1) and `study_valve.toml`
//!   (ours: data-set 1, the valve pulses of data-set 3, levelling run 1 and road run 1;
//!   [`REFERENCE_RUNS`]);
//! - `truth/`: the noise-free truth of every run (true load, true tank pressure, true outputs)
//!   and `truth/truck.toml`, the true values of the thesis-structure parameters;
//!   `truth/truck_structure.toml`, the whole truth as a file of the `truck` structure (its
//!   laws and `[effects]`), from which the `truck` model is the virtual truck itself.
//!
//! Everything is deterministic for a seed: the same seed writes the same bytes.

use std::path::{Path, PathBuf};

use airsus_data::{
    Channel, Role, Run, RunInputs, RunOutputs, RunPrecision, Study, StudyDischarge, StudyRun,
    TruckParameters, write_discharge, write_force_map, write_run, write_run_with_precision,
    write_study, write_truck,
};
use airsus_model::{InitialCondition, InputSample, SuspensionModel};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, SolverOptions, simulate};

use crate::closed_loop::{ClosedLoopConfig, LevelScenario, Plant, simulate_closed_loop};
use crate::ecu::{DeadbandController, GuardSettings};
use crate::error::TruckError;
use crate::lab::{DischargeTest, measure_discharge, measure_force_map};
use crate::model::{SupplyMode, TruckModel};
use crate::scenario::{
    Scenario, data_set_1, data_set_2, data_set_3, data_set_4, levelling_1, levelling_2, road_1,
    road_2,
};
use crate::sensors::{NoiseSource, SensorSpec};
use crate::truth::VirtualTruck;

/// Ride height at the start of every run (sensor), m.
pub const START_SENSOR_HEIGHT_M: f64 = 0.235;
/// Supply-tank gauge pressure at the start of every run, Pa.
pub const START_SUPPLY_GAUGE_PA: f64 = 850e3;

/// One generated run: as logged and as it truly was.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedRun {
    pub logged: Run,
    pub truth: Run,
    /// Where the truck felt load changes its log does not show (data-set 2's mishap): the
    /// noise-free run as the log tells it (every logged change ramped as the truck felt it,
    /// the unlogged ones left out; [`Scenario::as_logged`]). Its outputs against the
    /// measurements are the ceiling of a model driven by the logged load.
    pub truth_logged_input: Option<Run>,
    pub description: String,
}

/// Runs the virtual truck through `scenario` and logs it. `wall_friction_n` preloads the
/// bellow wall friction (how the truck got to its start height).
pub fn run_experiment(
    truck: &VirtualTruck,
    scenario: &Scenario,
    wall_friction_n: f64,
    seed: u64,
) -> Result<GeneratedRun, TruckError> {
    run_experiment_with(
        truck,
        scenario,
        wall_friction_n,
        seed,
        &SolverOptions::default(),
    )
}

pub fn run_experiment_with(
    truck: &VirtualTruck,
    scenario: &Scenario,
    wall_friction_n: f64,
    seed: u64,
    options: &SolverOptions,
) -> Result<GeneratedRun, TruckError> {
    let model = TruckModel::new(truck.clone(), SupplyMode::Tank);
    let (truth, measured) = noise_free(&model, scenario, wall_friction_n, options)?;
    let truth_logged_input = match scenario.as_logged() {
        Some(as_logged) => Some(noise_free(&model, &as_logged, wall_friction_n, options)?.0),
        None => None,
    };
    let tank_truth = &truth.inputs.supply_gauge_pa;
    let mut noise = NoiseSource::new(seed ^ 0x5e75_0001);
    let logged_outputs = RunOutputs {
        sensor_height_m: noise.measure(&measured.sensor_height_m, SensorSpec::HEIGHT_M),
        bellow_gauge_pa: noise.measure(&measured.bellow_gauge_pa, SensorSpec::BELLOW_PRESSURE_PA),
    };
    let logged_supply = noise.measure(tank_truth, SensorSpec::SUPPLY_PRESSURE_PA);
    let logged = Run {
        name: scenario.name.clone(),
        time_s: scenario.time_s.clone(),
        sample_time_s: crate::scenario::SAMPLE_TIME_S,
        inputs: RunInputs {
            wheel_load_kg: scenario.logged_load_kg.clone(),
            valve: scenario.valve.clone(),
            supply_gauge_pa: logged_supply,
            road_height_m: scenario.road_height_m.clone(),
        },
        outputs: Some(logged_outputs),
    };
    Ok(GeneratedRun {
        logged,
        truth,
        truth_logged_input,
        description: scenario.description.clone(),
    })
}

/// The virtual truck through `scenario` without sensors: the truth run (true load, the
/// tank's gauge pressure as supply, noise-free outputs) and its outputs.
fn noise_free(
    model: &TruckModel,
    scenario: &Scenario,
    wall_friction_n: f64,
    options: &SolverOptions,
) -> Result<(Run, RunOutputs), TruckError> {
    let n = scenario.len();
    let supply = vec![START_SUPPLY_GAUGE_PA; n];
    let inputs = InputSeries::new(
        &scenario.time_s,
        &scenario.true_load_kg,
        &scenario.valve,
        &supply,
        &scenario.road_height_m,
    )?;
    let x0 = model.equilibrium_with_friction(
        &input_at(scenario, 0),
        &InitialCondition::SensorHeight {
            height_m: START_SENSOR_HEIGHT_M,
        },
        wall_friction_n,
    )?;
    let problem = SimulationProblem::new(
        model as &dyn SuspensionModel,
        inputs,
        InitialState::State(x0),
    )
    .with_options(options.clone().with_states(true));
    let response = simulate(&problem)?;
    let states = response.states.as_ref().ok_or_else(|| {
        TruckError::Discharge(
            "the simulator returned no states although they were requested".to_owned(),
        )
    })?;
    let tank_truth: Vec<f64> = (0..n)
        .map(|k| {
            states
                .at(k)
                .map_or(f64::NAN, |x| model.tank_gauge_pa(x, &input_at(scenario, k)))
        })
        .collect();
    let outputs = RunOutputs {
        sensor_height_m: response.sensor_height_m,
        bellow_gauge_pa: response.bellow_gauge_pa,
    };
    let truth = Run {
        name: scenario.name.clone(),
        time_s: scenario.time_s.clone(),
        sample_time_s: crate::scenario::SAMPLE_TIME_S,
        inputs: RunInputs {
            wheel_load_kg: scenario.true_load_kg.clone(),
            valve: scenario.valve.clone(),
            supply_gauge_pa: tank_truth,
            road_height_m: scenario.road_height_m.clone(),
        },
        outputs: Some(outputs.clone()),
    };
    Ok((truth, outputs))
}

/// The decimals of a logged run: each sensor at its resolution (0.1 mm, 0.1 kPa, 1 kPa
/// supply), the time at the sample clock's, the logged load to 0.1 kg, the road to 0.01 mm.
pub fn logged_precision() -> RunPrecision {
    RunPrecision {
        time_decimals: RunPrecision::decimals_for_step(crate::scenario::SAMPLE_TIME_S),
        wheel_load_decimals: Some(1),
        supply_decimals: RunPrecision::decimals_for_step(
            SensorSpec::SUPPLY_PRESSURE_PA.resolution / 1e3,
        ),
        road_decimals: Some(2),
        height_decimals: RunPrecision::decimals_for_step(SensorSpec::HEIGHT_M.resolution * 1e3),
        pressure_decimals: RunPrecision::decimals_for_step(
            SensorSpec::BELLOW_PRESSURE_PA.resolution / 1e3,
        ),
    }
}

/// The virtual truck's extra effects as TOML, keyed by the `truck` model's parameter names,
/// so an estimate of the `truck` structure can be compared with the truth.
pub fn effects_toml(truck: &VirtualTruck) -> String {
    let e = &truck.effect_parameters;
    let f = &truck.effects;
    format!(
        "# The virtual truck's effects beyond the thesis structure (truth, not a truck file).\n\
         [effects]\ncreep = {}\nhysteresis = {}\nheat_exchange = {}\norifice_flow = {}\nsupply_line = {}\n\n\
         [parameters]  # names as the `truck` model's --free names\n\
         kc = {:?}      # creep stiffness, N/m\ntc = {:?}      # creep time constant, s\n\
         fc = {:?}      # wall friction (Dahl) sliding force, N\nkdahl = {:?}   # Dahl pre-sliding stiffness, N/m\n\
         tth = {:?}     # thermal time constant of the bellow gas, s\n\
         c1 = {:?}      # ISO 6358 sonic conductance, fill, m3/(s Pa)\nc2 = {:?}      # ISO 6358 sonic conductance, exhaust, m3/(s Pa)\n\
         bcr = {:?}     # ISO 6358 critical pressure ratio\nrline = {:?}   # supply line resistance, Pa s/mol\n\
         kap = {:?}     # effective-area growth per 100 kPa (wall stretch)\n\n\
         [supply]\ntank_volume_m3 = {:?}\ncompressor_flow_mol_s = {:?}\ngovernor_cutout_gauge_pa = {:?}\ngovernor_band_pa = {:?}\nline_volume_m3 = {:?}\n",
        f.creep,
        f.hysteresis,
        f.heat_exchange,
        f.orifice_flow,
        f.supply_line,
        e.creep_stiffness_n_per_m,
        e.creep_time_constant_s,
        e.friction_force_n,
        e.friction_stiffness_n_per_m,
        e.thermal_time_constant_s,
        e.fill_conductance_m3_s_pa,
        e.exhaust_conductance_m3_s_pa,
        e.critical_pressure_ratio,
        e.line_resistance_pa_s_per_mol,
        e.area_pressure_coefficient,
        e.tank_volume_m3,
        e.compressor_flow_mol_s,
        e.governor_cutout_gauge_pa,
        e.governor_band_pa,
        e.line_volume_m3,
    )
}

/// The inputs acting at sample `k` of a scenario (true load, supply at its starting value).
fn input_at(scenario: &Scenario, k: usize) -> InputSample {
    InputSample {
        wheel_load_kg: scenario.true_load_kg[k],
        valve: scenario.valve[k],
        supply_gauge_pa: START_SUPPLY_GAUGE_PA,
        road_height_m: scenario.road_height_m[k],
        road_rate_m_s: 0.0,
    }
}

/// The discharge tests: each channel twice, from 800 and 750 kPa, 20 l tank, 90 s at 50 ms.
pub fn reference_discharges() -> Vec<(String, DischargeTest, Role)> {
    let test = |channel: Channel, start_kpa: f64| DischargeTest {
        channel,
        tank_volume_m3: 0.020,
        temperature_k: 293.15,
        start_gauge_pa: start_kpa * 1e3,
        duration_s: 90.0,
        sample_time_s: 0.05,
    };
    vec![
        (
            "fill_a".to_owned(),
            test(Channel::Fill, 800.0),
            Role::Estimation,
        ),
        (
            "fill_b".to_owned(),
            test(Channel::Fill, 750.0),
            Role::Validation,
        ),
        (
            "exhaust_a".to_owned(),
            test(Channel::Exhaust, 800.0),
            Role::Estimation,
        ),
        (
            "exhaust_b".to_owned(),
            test(Channel::Exhaust, 750.0),
            Role::Validation,
        ),
    ]
}

/// What [`generate`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedStudy {
    /// The thesis protocol: estimation on data-set 1 only.
    pub study: PathBuf,
    /// Our protocol: estimation on data-sets 1 and 3, levelling run 1 and road run 1.
    pub study_valve: PathBuf,
    pub files: Vec<PathBuf>,
}

/// Generates the whole reference study into `out_dir` (created if needed). `progress` is told
/// what is being done, step by step.
pub fn generate(
    out_dir: &Path,
    seed: u64,
    progress: &mut dyn FnMut(&str),
) -> Result<GeneratedStudy, TruckError> {
    generate_variant(out_dir, seed, 0, progress)
}

/// [`generate`] with member `variant` of the virtual truck family
/// ([`VirtualTruck::variant`]; 0 is the reference truck). The nominal `truck.toml` the study
/// starts from is the same for every variant: the engineer's first guess does not know which
/// truck it is; `truth/` holds the variant's own values.
pub fn generate_variant(
    out_dir: &Path,
    seed: u64,
    variant: u32,
    progress: &mut dyn FnMut(&str),
) -> Result<GeneratedStudy, TruckError> {
    let truth_dir = out_dir.join("truth");
    std::fs::create_dir_all(&truth_dir).map_err(|source| TruckError::OutputFolder {
        path: truth_dir.clone(),
        source,
    })?;
    let truck = VirtualTruck::variant(variant);
    let mut files = Vec::new();

    let nominal = TruckParameters::reference();
    let truck_path = out_dir.join("truck.toml");
    write_truck(&truck_path, &nominal)?;
    files.push(truck_path.clone());
    let true_truck = truth_dir.join("truck.toml");
    write_truck(&true_truck, &truck.physical)?;
    files.push(true_truck);
    // The truth as a file of the `truck` structure (its laws and effects resolved): the
    // `truck` model built from it is the virtual truck, so an estimate can be compared with
    // it and a study or a grey-box fit started at it.
    let mut resolved = truck.clone();
    resolved.resolve_laws();
    let structure = truth_dir.join("truck_structure.toml");
    write_truck(&structure, &resolved.physical)?;
    files.push(structure);
    let effects = truth_dir.join("effects.toml");
    airsus_data::atomic::write_text_atomically(
        &effects,
        &format!(
            "# Virtual truck variant {variant} (0 = the reference truck).\n{}",
            effects_toml(&truck)
        ),
    )?;
    files.push(effects);

    let mut runs = Vec::new();
    for (i, run) in reference_runs(&truck, seed, progress)?
        .into_iter()
        .enumerate()
    {
        // The study files name each run by its place in REFERENCE_RUNS.
        debug_assert_eq!(run.logged.name, REFERENCE_RUNS[i].file);
        let file = out_dir.join(format!("{}.csv", run.logged.name));
        write_run_with_precision(&file, &run.logged, &logged_precision())?;
        let truth_file = truth_dir.join(format!("{}.csv", run.truth.name));
        write_run(&truth_file, &run.truth)?;
        files.push(file.clone());
        files.push(truth_file.clone());
        let as_logged = match &run.truth_logged_input {
            Some(truth) => {
                let path = truth_dir.join(format!("{}_logged_input.csv", truth.name));
                write_run(&path, truth)?;
                files.push(path.clone());
                Some(path)
            }
            None => None,
        };
        runs.push((i, file, truth_file, as_logged));
    }

    progress("bellow force map");
    let map_path = out_dir.join("force_map.csv");
    write_force_map(&map_path, &measure_force_map(&truck, seed))?;
    files.push(map_path.clone());

    let mut discharges = Vec::new();
    for (k, (name, test, role)) in reference_discharges().into_iter().enumerate() {
        progress(&format!("tank discharge {name}"));
        let path = out_dir.join(format!("{name}.csv"));
        write_discharge(
            &path,
            &measure_discharge(&truck, &test, seed.wrapping_add(100 + k as u64))?,
        )?;
        files.push(path.clone());
        discharges.push(StudyDischarge {
            file: path,
            channel: test.channel,
            tank_volume_m3: test.tank_volume_m3,
            temperature_k: test.temperature_k,
            role,
        });
    }

    let study_with = |estimated: fn(&ReferenceRun) -> bool| Study {
        truck: truck_path.clone(),
        runs: runs
            .iter()
            .map(|(i, file, truth, as_logged)| StudyRun {
                name: REFERENCE_RUNS[*i].study_name.to_owned(),
                file: file.clone(),
                role: if estimated(&REFERENCE_RUNS[*i]) {
                    Role::Estimation
                } else {
                    Role::Validation
                },
                truth: Some(truth.clone()),
                truth_logged_input: as_logged.clone(),
                source: Default::default(),
            })
            .collect(),
        force_map: Some(map_path.clone()),
        discharges: discharges.clone(),
    };
    let study = out_dir.join("study.toml");
    write_study(&study, &study_with(|r| r.thesis_estimation))?;
    let study_valve = out_dir.join("study_valve.toml");
    write_study(&study_valve, &study_with(|r| r.our_estimation))?;
    files.push(study.clone());
    files.push(study_valve.clone());
    Ok(GeneratedStudy {
        study,
        study_valve,
        files,
    })
}

/// The reference runs: how each is named in a study and which protocol estimates on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceRun {
    /// File stem (`ds1`, `lev1`, ...).
    pub file: &'static str,
    /// The run's name in the study files.
    pub study_name: &'static str,
    /// The thesis protocol (`study.toml`) estimates on it.
    pub thesis_estimation: bool,
    /// Our protocol (`study_valve.toml`) estimates on it.
    pub our_estimation: bool,
}

/// The thesis' four data-sets (SPEC §6), then the levelling and road runs (#13): our protocol
/// estimates on a loading, a valve, a levelling and a road run and validates on the rest; the
/// thesis protocol estimates on data-set 1 alone.
pub const REFERENCE_RUNS: [ReferenceRun; 8] = [
    ReferenceRun {
        file: "ds1",
        study_name: "data-set 1",
        thesis_estimation: true,
        our_estimation: true,
    },
    ReferenceRun {
        file: "ds2",
        study_name: "data-set 2",
        thesis_estimation: false,
        our_estimation: false,
    },
    ReferenceRun {
        file: "ds3",
        study_name: "data-set 3",
        thesis_estimation: false,
        our_estimation: true,
    },
    ReferenceRun {
        file: "ds4",
        study_name: "data-set 4",
        thesis_estimation: false,
        our_estimation: false,
    },
    ReferenceRun {
        file: "lev1",
        study_name: "levelling 1",
        thesis_estimation: false,
        our_estimation: true,
    },
    ReferenceRun {
        file: "lev2",
        study_name: "levelling 2",
        thesis_estimation: false,
        our_estimation: false,
    },
    ReferenceRun {
        file: "road1",
        study_name: "road 1",
        thesis_estimation: false,
        our_estimation: true,
    },
    ReferenceRun {
        file: "road2",
        study_name: "road 2",
        thesis_estimation: false,
        our_estimation: false,
    },
];

/// The reference runs of [`REFERENCE_RUNS`], in its order. Data-sets 1–2 start after the truck
/// was lowered onto its ride height (wall friction holding up), 3–4 after it was raised
/// (friction holding down), so they start at the same height with different pressures, as
/// thesis 6.1 reports; the levelling runs start with the wall unloaded (the closed loop starts
/// in equilibrium), road run 1 lowered and road run 2 raised.
pub fn reference_runs(
    truck: &VirtualTruck,
    seed: u64,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<GeneratedRun>, TruckError> {
    let m2 = truck.physical.mass.unsprung_kg;
    let friction = truck.effect_parameters.friction_force_n;
    // (scenario, wall friction at the start, the ECU levels)
    let plan = [
        (data_set_1(m2, seed), -friction, false),
        (data_set_2(m2, seed), -friction, false),
        (data_set_3(m2, seed), friction, false),
        (data_set_4(m2, seed), friction, false),
        (levelling_1(m2, seed), 0.0, true),
        (levelling_2(m2, seed), 0.0, true),
        (road_1(m2, seed), -friction, false),
        (road_2(m2, seed)?, friction, false),
    ];
    let mut runs = Vec::with_capacity(plan.len());
    for (i, (scenario, f, levels)) in plan.into_iter().enumerate() {
        progress(&format!("simulating {}", scenario.description));
        let run_seed = seed.wrapping_add(i as u64);
        runs.push(if levels {
            levelling_run(truck, scenario, run_seed)?
        } else {
            run_experiment(truck, &scenario, f, run_seed)?
        });
    }
    Ok(runs)
}

/// A levelling run: the truck's ECU (the deadband controller at its default settings, reading
/// the sensors every 100 ms) holds the start height through the scenario's load changes; the
/// valve commands it gave are then the scenario's valve column, and the run is simulated and
/// logged as every other ([`run_experiment`], wall unloaded as the closed loop starts).
pub fn levelling_run(
    truck: &VirtualTruck,
    mut scenario: Scenario,
    seed: u64,
) -> Result<GeneratedRun, TruckError> {
    let n = scenario.len();
    let level = LevelScenario {
        name: scenario.name.clone(),
        time_s: scenario.time_s.clone(),
        true_load_kg: scenario.true_load_kg.clone(),
        target_m: vec![START_SENSOR_HEIGHT_M; n],
        road_height_m: scenario.road_height_m.clone(),
        speed_m_s: vec![0.0; n],
        events_s: Vec::new(),
    };
    let plant = Plant::Truck(Box::new(TruckModel::new(truck.clone(), SupplyMode::Tank)));
    let mut ecu = DeadbandController::new(GuardSettings::default());
    let config = ClosedLoopConfig {
        supply_gauge_pa: START_SUPPLY_GAUGE_PA,
        seed: seed ^ 0xec00_0001,
        ..ClosedLoopConfig::default()
    };
    let closed = simulate_closed_loop(&plant, &mut ecu, &level, &config)?;
    scenario.valve = closed.valve;
    run_experiment(truck, &scenario, 0.0, seed)
}
