//! `airsus models`: the one registry every command reads, and `greybox` fitting every model
//! the study fits (the `truck` structure included).

use std::process::Command;

fn airsus(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(args)
        .output()
        .expect("the airsus binary runs")
}

fn ok(out: &std::process::Output) -> (String, String) {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    (String::from_utf8_lossy(&out.stdout).into_owned(), stderr)
}

#[test]
fn models_json_lists_every_model_with_parameters_and_states() {
    let (stdout, _) = ok(&airsus(&["models", "--json"]));
    let models: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let models = models.as_array().unwrap();
    let names: Vec<&str> = models.iter().map(|m| m["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["m1", "m2", "m2x", "m2xh", "m3", "truck"]);
    // What the study refits on the road runs alone, after the joint estimate.
    assert_eq!(
        models[5]["road_refit"],
        serde_json::json!(["dscl", "kw", "ig", "kf"])
    );
    assert_eq!(models[1]["road_refit"], serde_json::json!([]));
    for model in models {
        let name = model["name"].as_str().unwrap();
        assert!(!model["description"].as_str().unwrap().is_empty());
        for p in model["parameters"].as_array().unwrap() {
            let (min, max, default) = (
                p["min"].as_f64().unwrap(),
                p["max"].as_f64().unwrap(),
                p["default"].as_f64().unwrap(),
            );
            assert!(min < max && (min..=max).contains(&default), "{name}: {p}");
            assert!(!p["unit"].as_str().unwrap().is_empty(), "{name}: {p}");
            assert!(
                !p["description"].as_str().unwrap().is_empty(),
                "{name}: {p}"
            );
            // Every parameter says what data determine it (the identifiability message).
            assert!(!p["needs"].as_str().unwrap().is_empty(), "{name}: {p}");
        }
        let params: Vec<&str> = model["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["name"].as_str().unwrap())
            .collect();
        for free in model["default_free"].as_array().unwrap() {
            assert!(params.contains(&free.as_str().unwrap()), "{name}: {free}");
        }
        let roles: Vec<(&str, &str)> = model["states"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| (s["name"].as_str().unwrap(), s["role"].as_str().unwrap()))
            .collect();
        assert!(
            roles.contains(&("n_mol", "bellow_air")),
            "{name}: {roles:?}"
        );
    }
    let truck = &models[5];
    let states = truck["states"].as_array().unwrap();
    let gas = states.iter().find(|s| s["name"] == "gas_t_k").unwrap();
    assert_eq!(
        (gas["unit"].as_str(), gas["role"].as_str()),
        (Some("K"), Some("gas_temperature"))
    );
    // The reference m2 as the SPEC gives it.
    let m2 = models[1]["parameters"].as_array().unwrap();
    let unsprung = m2.iter().find(|p| p["name"] == "m2").unwrap();
    assert_eq!(unsprung["default"].as_f64(), Some(520.0));
    assert_eq!(unsprung["unit"].as_str(), Some("kg"));

    let (text, _) = ok(&airsus(&["models"]));
    for name in names {
        assert!(
            text.contains(&format!("{name} ")),
            "{name} missing from:\n{text}"
        );
    }
}

#[test]
fn greybox_fits_the_truck_structure_and_its_truck_file_keeps_every_parameter() {
    let dir = tempfile::tempdir().unwrap();
    ok(&airsus(&[
        "generate",
        "--out",
        dir.path().to_str().unwrap(),
    ]));
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();

    // Without --free: the registry's default set, with the valve conductances on valve data.
    let (_, stderr) = ok(&airsus(&[
        "greybox",
        "--model",
        "truck",
        "--truck",
        &p("truck.toml"),
        "--run",
        &p("ds3.csv"),
        "--max-iterations",
        "1",
        "--json",
    ]));
    assert!(
        stderr.contains("freeing truck's default set with what valve action determines")
            && stderr.contains("p0,p1,p2,p3,p4,m2,ig,kc,tc,kdahl,c1,c2,a0,tth"),
        "{stderr}"
    );

    // The creep element's stiffness has no truck-file key: the estimate is printed and the
    // user is told it is not in the written file.
    let (stdout, stderr) = ok(&airsus(&[
        "greybox",
        "--model",
        "truck",
        "--free",
        "kc",
        "--truck",
        &p("truck.toml"),
        "--run",
        &p("ds1.csv"),
        "--max-iterations",
        "3",
        "--out",
        &p("est.toml"),
        "--json",
    ]));
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(json.to_string().contains("\"kc\""), "{json}");
    // Every parameter of the structure has a truck-file home now: the fitted kc goes to
    // `[effects]`, the structure's laws go along as tagged tables, and nothing is lost.
    assert!(!stderr.contains("no truck-file key"), "{stderr}");
    let est = airsus_data::read_truck(std::path::Path::new(&p("est.toml"))).unwrap();
    let fitted_kc = est.parameters.effects.creep_stiffness_n_per_m.unwrap();
    assert_eq!(est.parameters.valve.tag(), "orifice");
    assert_eq!(
        est.parameters.bellow.effective_area.tag(),
        "polynomial_pressure"
    );
    let rebuilt = airsus_truck::models::build_any_model("truck", &est.parameters).unwrap();
    assert_eq!(rebuilt.parameter("kc").unwrap(), fitted_kc);
}
