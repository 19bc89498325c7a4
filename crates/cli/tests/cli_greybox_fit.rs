//! `airsus greybox` and `airsus fit` on the virtual truck's study.

mod common;

use common::{airsus, generated, ok, path, printed_nrmse};

#[test]
fn greybox_improves_the_fit_and_writes_a_truck_file_that_loads_back() {
    let dir = generated();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let out = airsus(&[
        "greybox",
        "--model",
        "m2",
        "--free",
        "p0,p1,m2",
        "--bounds",
        "m2=300:900",
        "--truck",
        &p("truck.toml"),
        "--run",
        &p("ds1.csv"),
        "--run",
        &p("ds3.csv"),
        "--out",
        &p("est.toml"),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let text = json.to_string();
    assert!(text.contains("\"m2\""), "{text}");
    // Model 2 leaves the virtual truck's creep, heat and friction, slow misfit: allowing for
    // residuals correlated in time, its parameters are several times less certain (seen:
    // 12-21 times the white standard deviation).
    for p in json["parameters"].as_array().unwrap() {
        let (white, correlated) = (p["std"].as_f64(), p["std_correlated"].as_f64());
        if p["status"] == "estimated" {
            let (white, correlated) = (white.unwrap(), correlated.unwrap());
            assert!(correlated > 5.0 * white, "{p}");
        }
    }
    let est = airsus_data::read_truck(std::path::Path::new(&p("est.toml")))
        .unwrap()
        .parameters;
    assert!(
        (300.0..=900.0).contains(&est.mass.unsprung_kg),
        "bounds respected: {}",
        est.mass.unsprung_kg
    );
    assert_ne!(
        est.bellow.effective_area,
        airsus_data::TruckParameters::reference()
            .bellow
            .effective_area
    );

    // The estimated parameters simulate the estimation run better than the nominal ones.
    let nrmse = |truck: &str| {
        let sim = airsus(&[
            "simulate",
            "--model",
            "m2",
            "--truck",
            truck,
            "--run",
            &p("ds1.csv"),
            "--out",
            &p("s.csv"),
        ]);
        let stderr = String::from_utf8_lossy(&sim.stderr).into_owned();
        let line = stderr
            .lines()
            .find(|l| l.contains("NRMSE"))
            .unwrap_or_else(|| panic!("{stderr}"))
            .to_owned();
        let pressure = line
            .split("pressure ")
            .nth(1)
            .and_then(|s| s.trim_end_matches(" %").trim().parse::<f64>().ok());
        pressure.unwrap_or_else(|| panic!("{line}"))
    };
    assert!(nrmse(&p("est.toml")) > nrmse(&p("truck.toml")) + 10.0);
}

/// Issue #12: no estimation run and output explained worse than by the start values. Model
/// 3 from the reference truck file on the loading, valve, levelling and road runs: its pooled
/// estimate explained the levelling run's height and road 1's pressure worse than the file did;
/// the command refits with those weighted more, says so, and reports the file's fits and
/// values as the start.
#[test]
fn greybox_trades_no_estimation_run_for_the_others() {
    let dir = generated();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (truck, ds1, ds3, lev1, road1) = (
        p("truck.toml"),
        p("ds1.csv"),
        p("ds3.csv"),
        p("lev1.csv"),
        p("road1.csv"),
    );
    let mut m3 = vec![
        "greybox", "--model", "m3", "--truck", &truck, "--run", &ds1, "--run", &ds3, "--run",
        &lev1, "--run", &road1, "--json",
    ];
    let out = airsus(&m3);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("refitted with them weighted more")
            && stderr.contains(
                "it explains every estimation run and output at least as well as the start values"
            )
            // Each refit is announced while it runs.
            && stderr.contains("round 1 of at most 4"),
        "{stderr}"
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let fits = json["fits"].as_array().unwrap();
    assert_eq!(fits.len(), 4);
    for fit in fits {
        for output in ["height", "pressure"] {
            let start = fit[format!("{output}_nominal_percent")].as_f64().unwrap();
            let estimate = fit[format!("{output}_estimated_percent")].as_f64().unwrap();
            assert!(estimate >= start - 0.1, "{output}: {fit}");
        }
    }
    // The start is the file's: data-set 1's height as the file explains it (measured
    // -164.7 %), and the file's `a0`, not the pooled estimate's.
    assert!(fits[0]["height_nominal_percent"].as_f64().unwrap() < -100.0);
    let a0 = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "a0")
        .unwrap();
    let file = airsus_data::read_truck(std::path::Path::new(&truck)).unwrap();
    let model = airsus_model::build_model("m3", &file.parameters).unwrap();
    assert_eq!(
        a0["nominal"].as_f64().unwrap(),
        model.parameter("a0").unwrap()
    );
    // The loss the estimate reports is unweighted: below the start's.
    assert!(json["loss_estimated"].as_f64().unwrap() < json["loss_nominal"].as_f64().unwrap());
    // The note names what the pooled estimate traded, with the start values' scores.
    assert!(
        stderr.contains("the pooled estimate explained")
            && stderr.contains("lev1's height -")
            && stderr.contains("(start values "),
        "{stderr}"
    );

    // `--allow-trades` keeps the pooled estimate, as MATLAB's `greyest` would return it, and
    // names each trade: no refit runs.
    m3.push("--allow-trades");
    let out = airsus(&m3);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("kept as fitted (trades allowed)")
            && stderr.contains("lev1's height")
            && !stderr.contains("round 1 of at most 4"),
        "{stderr}"
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let traded = json["fits"].as_array().unwrap().iter().any(|fit| {
        ["height", "pressure"].iter().any(|output| {
            fit[format!("{output}_estimated_percent")].as_f64().unwrap()
                < fit[format!("{output}_nominal_percent")].as_f64().unwrap() - 0.1
        })
    });
    assert!(traded, "{json}");

    // An output the loss leaves out is fitted to nothing: it is not held to the start's fit
    // (no weight on it could bring it back). Model 2 fitted to the pressures alone explains
    // data-set 3's height worse than the file (measured 65.1 -> -20.6 %), and says nothing
    // of it.
    let out = airsus(&[
        "greybox",
        "--model",
        "m2",
        "--truck",
        &truck,
        "--run",
        &ds1,
        "--run",
        &ds3,
        "--height-weight",
        "0",
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ds3 = &json["fits"][1];
    assert!(
        ds3["height_estimated_percent"].as_f64().unwrap()
            < ds3["height_nominal_percent"].as_f64().unwrap() - 10.0,
        "{ds3}"
    );
    assert!(!stderr.contains("weighted more"), "{stderr}");
}

#[test]
fn fit_valve_from_the_study_reports_both_channels() {
    let dir = generated();
    let study = dir.path().join("study.toml");
    let out = airsus(&["fit", "valve", "--study", study.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The virtual truck's valve is an ISO 6358 orifice (truth/effects.toml: sonic conductances
    // c1 fill, c2 exhaust), so no "true" Poiseuille resistance exists; but a linear
    // resistance fitted to discharges through each channel must come out in the ratio of
    // the conductances, which the fits never see.
    let effects: toml::Table = std::fs::read_to_string(dir.path().join("truth/effects.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let c = |k: &str| effects["parameters"][k].as_float().unwrap();
    let resistance = |channel: &str| {
        let fit = &json[channel];
        let r = fit["resistance_pa_s_per_mol"]
            .as_f64()
            .unwrap_or_else(|| panic!("{channel}: {json}"));
        let std = fit["resistance_std"].as_f64().unwrap();
        assert!((1e5..1e8).contains(&r), "{channel}: {r}");
        assert!(std > 0.0 && std < 0.05 * r, "{channel}: std {std} of {r}");
        let discharges = fit["discharges"].as_array().unwrap();
        assert_eq!(
            discharges.len(),
            2,
            "{channel}: one estimation, one validation"
        );
        for d in discharges {
            let nrmse = d["nrmse_percent"].as_f64().unwrap();
            assert!(nrmse > 80.0, "{channel}: {d}");
        }
        r
    };
    let ratio = resistance("fill") / resistance("exhaust");
    let expected = c("c2") / c("c1");
    assert!(
        (ratio / expected - 1.0).abs() < 0.2,
        "R_fill/R_exhaust {ratio} vs c2/c1 {expected}"
    );
}

#[test]
fn greybox_names_an_unknown_parameter() {
    let dir = generated();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let out = airsus(&[
        "greybox",
        "--model",
        "m2",
        "--free",
        "p0,mass2",
        "--truck",
        &p("truck.toml"),
        "--run",
        &p("ds1.csv"),
        "--out",
        &p("est.toml"),
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("mass2"), "{stderr}");
    assert!(!dir.path().join("est.toml").exists());
}

#[test]
fn noise_level_weighting_lets_the_valve_run_count() {
    // Pooled spreads let the 1500-s loading run outweigh the valve run's small pressure
    // swings; weighting each run and output by its own noise does not. Judged on data-set 4,
    // a valve run neither fit saw. Seed 1: −48.5 → −45.2 %. (It was −143.6 → −83.7 % while a
    // fifth of the trial simulations failed on the damper table's corner; not on every seed,
    // which is why noise-level weighting is not the default yet.) Measured with equilibrium
    // starts: with starts fitted to each run's first 10 s (the default since) the order is
    // reversed, −23.9 → −37.5 %. The load as logged, as it was measured.
    let dir = generated();
    let p = |name: &str| path(&dir, name);
    let held_out_pressure = |normalisation: &str| -> f64 {
        let est = p(&format!("est_{normalisation}.toml"));
        let (truck, ds1, ds3) = (p("truck.toml"), p("ds1.csv"), p("ds3.csv"));
        ok(&[
            "greybox",
            "--model",
            "m2",
            "--truck",
            &truck,
            "--run",
            &ds1,
            "--run",
            &ds3,
            "--normalisation",
            normalisation,
            "--initial-state",
            "equilibrium",
            "--load-ramp",
            "logged",
            "--out",
            &est,
        ]);
        let sim = p(&format!("sim_{normalisation}.csv"));
        let (_, stderr) = ok(&[
            "simulate",
            "--model",
            "m2",
            "--truck",
            &est,
            "--run",
            &p("ds4.csv"),
            "--initial-state",
            "equilibrium",
            "--out",
            &sim,
        ]);
        printed_nrmse(&stderr, "pressure")
    };
    let (pooled, noise) = (
        held_out_pressure("pooled-spread"),
        held_out_pressure("noise-level"),
    );
    assert!(
        noise > pooled + 2.0,
        "data-set 4 pressure: pooled {pooled} %, noise-level {noise} %"
    );
}

#[test]
fn a_fit_whose_every_parameter_was_reset_is_not_called_converged() {
    // The tire stiffness does not show in a loading run's height and pressure at 10 Hz: the
    // identifiability screen resets it after the fit, so the result is the start. (With the
    // logged steps eased, the transitions' fit leaves Model 1 a trace of kw to fit: the load
    // as logged keeps this test about the screen.)
    let dir = generated();
    let (truck, ds1) = (path(&dir, "truck.toml"), path(&dir, "ds1.csv"));
    let (stdout, stderr) = ok(&[
        "greybox",
        "--model",
        "m1",
        "--free",
        "kw",
        "--truck",
        &truck,
        "--run",
        &ds1,
        "--load-ramp",
        "logged",
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(
        json["stop"]["kind"], "no_parameter_moved",
        "{}",
        json["stop"]
    );
    assert!(
        stderr.contains("no parameter moved from its start"),
        "{stderr}"
    );
    // And it says what data would determine the parameter.
    let frozen = &json["identifiability"]["not_identifiable"][0];
    assert_eq!(frozen["name"], "kw");
    assert!(
        frozen["determined_by"]
            .as_str()
            .is_some_and(|s| s.contains("road input")),
        "{frozen}"
    );
}

#[test]
fn model_2_on_the_valve_protocol_fails_no_trial_simulation() {
    // Data-sets 1 and 3 from the nominal file: before the damper table's corner at zero
    // velocity was rounded and the lever inertia floored above the mass matrix's singular
    // point, 178 of 1180 trial simulations failed here ("too many Newton failures" at rest,
    // a blow-up for I_g < m2² l1²/M), the failed columns read as "no sensitivity" and p1-p3
    // were fixed for it. Equilibrium starts, as measured then (with prefix starts p1 is fixed
    // for its correlation with the others, not for failures).
    let dir = generated();
    let p = |name: &str| path(&dir, name);
    let (stdout, _) = ok(&[
        "greybox",
        "--model",
        "m2",
        "--truck",
        &p("truck.toml"),
        "--run",
        &p("ds1.csv"),
        "--run",
        &p("ds3.csv"),
        "--initial-state",
        "equilibrium",
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(json["failed_simulations"], 0, "{}", json["stop"]);
    assert!(json["simulations"].as_u64().unwrap() > 500);
    let fixed: Vec<&str> = json["identifiability"]["not_identifiable"]
        .as_array()
        .map(|a| a.iter().filter_map(|n| n["name"].as_str()).collect())
        .unwrap_or_default();
    for shape in ["p1", "p2", "p3"] {
        assert!(!fixed.contains(&shape), "{shape} fixed: {fixed:?}");
    }
}

/// The virtual truck's loading run logs each load change as a step while the wheel takes it
/// over 3-8 s. By default `greybox` eases each change over its own time, estimated in turn
/// with the parameters, and says so; the estimate then explains the run better than one
/// fitted to the steps as logged (Model 2, 10 iterations: 81.6/86.8 → 85.9/91.1 %).
#[test]
fn greybox_eases_each_logged_load_change_over_its_own_time() {
    let dir = generated();
    let p = |name: &str| path(&dir, name);
    let fit = |load_ramp: &str| {
        let (stdout, stderr) = ok(&[
            "greybox",
            "--model",
            "m2",
            "--free",
            "p0,p1,m2",
            "--bounds",
            "m2=300:900",
            "--truck",
            &p("truck.toml"),
            "--run",
            &p("ds1.csv"),
            "--max-iterations",
            "10",
            "--load-ramp",
            load_ramp,
            "--json",
        ]);
        let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let ds1 = &json["fits"][0];
        (
            ds1["height_estimated_percent"].as_f64().unwrap(),
            ds1["pressure_estimated_percent"].as_f64().unwrap(),
            stderr,
        )
    };
    let (height_logged, pressure_logged, said_logged) = fit("logged");
    let (height, pressure, said) = fit("estimate");
    assert!(
        said.contains("logged load steps eased over")
            && said.contains("each logged load change's transition time"),
        "{said}"
    );
    assert!(!said_logged.contains("eased"), "{said_logged}");
    assert!(
        height > height_logged + 2.0 && pressure > pressure_logged + 2.0,
        "data-set 1 height {height_logged:.1} → {height:.1} %, pressure {pressure_logged:.1} → {pressure:.1} %"
    );
}

#[test]
fn greybox_takes_a_force_map_into_the_loss_and_refuses_a_bad_one() {
    let dir = generated();
    let p = |name: &str| path(&dir, name);
    let (truck, run) = (p("truck.toml"), p("ds3.csv"));
    let fit = |extra: &[&str]| {
        let mut args = vec![
            "greybox",
            "--model",
            "m2",
            "--free",
            "p0,p1,p2,p3,p4",
            "--truck",
            &truck,
            "--run",
            &run,
            "--initial-state",
            "equilibrium",
            "--load-ramp",
            "logged",
            "--max-iterations",
            "5",
        ];
        args.extend_from_slice(extra);
        airsus(&args)
    };
    let map = p("force_map.csv");
    let out = fit(&["--force-map", &map]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("force map: 182 points in the loss"),
        "{stderr}"
    );
    let out = fit(&["--force-map", &map, "--force-map-noise-n", "0"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("--force-map-noise-n 0"), "{stderr}");
    let missing = p("no_map.csv");
    let out = fit(&["--force-map", &missing]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("no_map.csv"), "{stderr}");
}

#[test]
fn fit_effective_area_writes_a_spline_and_refits_a_spline_file_as_one() {
    let dir = generated();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (printed, _) = ok(&[
        "fit",
        "effective-area",
        "--force-map",
        &p("force_map.csv"),
        "--law",
        "spline",
        "--out",
        &p("spline.toml"),
    ]);
    assert!(printed.contains("monotone spline"), "{printed}");
    assert!(printed.contains("s9"), "{printed}");
    let spline = airsus_data::read_truck(std::path::Path::new(&p("spline.toml")))
        .unwrap()
        .parameters;
    let knots = spline.bellow.effective_area.knots().expect("a spline law");
    // One knot per height of the lab's map (160-400 mm in 20 mm steps).
    assert_eq!(knots.knots_x().len(), 13);
    assert!((knots.knots_x()[0] - 0.16).abs() < 1e-9);
    // The virtual truck's areas: 0.05-0.056 m² over the stroke.
    assert!(knots.values().iter().all(|a| (0.045..0.06).contains(a)));

    // A spline file is refitted as a spline without --law; the quartic fit refuses to write
    // into it.
    let (again, _) = ok(&[
        "fit",
        "effective-area",
        "--truck",
        &p("spline.toml"),
        "--force-map",
        &p("force_map.csv"),
    ]);
    assert!(again.contains("monotone spline"), "{again}");
    let refused = airsus(&[
        "fit",
        "effective-area",
        "--truck",
        &p("spline.toml"),
        "--force-map",
        &p("force_map.csv"),
        "--law",
        "polynomial",
        "--out",
        &p("quartic.toml"),
    ]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert!(stderr.contains("law \"spline\""), "{stderr}");
    assert!(!dir.path().join("quartic.toml").exists());
}

#[test]
fn fit_effective_area_reads_the_growth_with_pressure_and_cross_section_the_settled_samples() {
    let dir = generated();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    // The reference truck's bellow grows 0.004 per 100 kPa; its map says 0.0038 ± 0.0003.
    let (printed, _) = ok(&[
        "fit",
        "effective-area",
        "--force-map",
        &p("force_map.csv"),
        "--fit-kap",
        "--out",
        &p("kap.toml"),
    ]);
    assert!(printed.contains("fitted to the map"), "{printed}");
    let truck = airsus_data::read_truck(std::path::Path::new(&p("kap.toml")))
        .unwrap()
        .parameters;
    let area = &truck.bellow.effective_area;
    assert_eq!(area.tag(), "polynomial_pressure");
    assert!(
        (area.growth_per_100kpa() - 0.004).abs() < 0.0004,
        "{}",
        area.growth_per_100kpa()
    );

    // The loading run's settled samples: 6 of its 7 holds last 120 s past their change.
    let (printed, _) = ok(&[
        "fit",
        "cross-section",
        "--run",
        &p("ds1.csv"),
        "--settled-after-s",
        "120",
    ]);
    assert!(
        printed.contains("in 6 load holds (120 s or more"),
        "{printed}"
    );
    let refused = airsus(&[
        "fit",
        "cross-section",
        "--run",
        &p("ds1.csv"),
        "--settled-after-s=-5",
    ]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(stderr.contains("--settled-after-s"), "{stderr}");
    // Holds too short for three settled loads: an error that says what to do.
    let refused = airsus(&[
        "fit",
        "cross-section",
        "--run",
        &p("ds1.csv"),
        "--settled-after-s",
        "400",
    ]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success());
    assert!(stderr.contains("three loads at least"), "{stderr}");
}

#[test]
fn fit_wall_friction_reads_the_maps_hysteresis_into_the_truck_file() {
    let dir = generated();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (printed, _) = ok(&[
        "fit",
        "wall-friction",
        "--force-map",
        &p("force_map.csv"),
        "--out",
        &p("walled.toml"),
    ]);
    assert!(printed.contains("91 up/down pairs"), "{printed}");
    let truck = airsus_data::read_truck(std::path::Path::new(&p("walled.toml")))
        .unwrap()
        .parameters;
    // The built-in virtual truck's wall slides at 120 N.
    let fc = truck.effects.friction_force_n.unwrap();
    assert!((fc - 120.0).abs() < 15.0, "{fc}");
}

#[test]
fn fit_valve_law_orifice_reads_the_conductances_from_the_discharges() {
    let dir = generated();
    let study = dir.path().join("study.toml");
    let study = study.to_str().unwrap();
    let (printed, _) = ok(&["fit", "valve", "--study", study, "--law", "orifice"]);
    assert!(printed.contains("ISO 6358"), "{printed}");
    // The built-in virtual truck's valve: c1 5e-9, c2 1.2e-8 m3/(s Pa), b 0.4.
    let value = |label: &str| -> f64 {
        let line = printed
            .lines()
            .find(|l| l.trim_start().starts_with(label))
            .unwrap_or_else(|| panic!("{printed}"));
        line.split('=')
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!((value("c1") / 5e-9 - 1.0).abs() < 0.01, "{printed}");
    assert!((value("c2") / 1.2e-8 - 1.0).abs() < 0.01, "{printed}");
    assert!((value("bcr") - 0.4).abs() < 0.01, "{printed}");
    // Into a truck file under the thesis' resistances it is not written.
    let out = dir.path().join("orifice.toml");
    let refused = airsus(&[
        "fit",
        "valve",
        "--study",
        study,
        "--law",
        "orifice",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert!(stderr.contains("linear_resistance"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn fit_valve_tells_the_law_by_the_residuals_of_both() {
    let dir = generated();
    let study = dir.path().join("study.toml");
    let study = study.to_str().unwrap();
    let residual = |printed: &str| -> f64 {
        let first = printed.lines().next().unwrap_or_default();
        first
            .rsplit("residual ")
            .next()
            .and_then(|r| r.trim_end_matches(" Pa").parse().ok())
            .unwrap_or_else(|| panic!("{printed}"))
    };
    let (orifice, _) = ok(&["fit", "valve", "--study", study, "--law", "orifice"]);
    let out = dir.path().join("linear_cooling.toml");
    let (linear, _) = ok(&[
        "fit",
        "valve",
        "--study",
        study,
        "--law",
        "linear-cooling",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(linear.contains("the tank's gas simulated"), "{linear}");
    // The built-in virtual truck's valve is an orifice: the sensor's 100 Pa under it,
    // measured 22 kPa under linear resistances.
    assert!(residual(&orifice) < 120.0, "{orifice}");
    assert!(residual(&linear) > 20.0 * residual(&orifice), "{linear}");
    // Written into the study's truck file, which follows the thesis' linear law.
    let written = std::fs::read_to_string(&out).unwrap();
    let truck = airsus_data::truck::parse_truck(&written, &out)
        .unwrap()
        .parameters;
    assert_eq!(truck.valve.tag(), "linear_resistance");
    let r1 = truck
        .valve
        .get(airsus_data::params::Field::FillResistance)
        .unwrap();
    assert!(linear.contains(&format!("{r1:.4e}")), "{r1} {linear}");
}
