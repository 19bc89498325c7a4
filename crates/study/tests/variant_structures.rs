//! Issues #12/#13: the `truck` structure on virtual trucks it was not built from. Variant 1
//! draws every value anew (valve, wall, creep, the gas's thermal time 35.6 s against the
//! structure's built-in 20 s, masses, damping, the gas volume's shape); variant 2's
//! effective area bends at the bottom of the stroke and grows faster with pressure; variant 3 also
//! flows through linear resistances where the structure's own valve is an orifice. The
//! study starts from the nominal truck file and what the lab's force map and tank
//! discharges tell, and is scored against each run's noise-free truth.

use airsus_study::{Protocol, StudyOptions, load_study, run_study};

/// The `truck` structure estimated on variant `k` under our protocol: each run's
/// (name, height %, pressure %, height ceiling %, pressure ceiling %), the ceiling of the
/// load as logged where the log hides a change; and the model's notes.
type Scores = Vec<(String, f64, f64, f64, f64)>;

fn study_variant(k: u32) -> (Scores, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let generated = airsus_truck::experiments::generate_variant(&data, 1, k, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    let options = StudyOptions {
        models: vec!["truck".to_owned()],
        ..StudyOptions::new(vec![Protocol::from_roles(&input)])
    };
    let outcome = run_study(&input, &options, &dir.path().join("out"), &|_| {}).unwrap();
    let r = &outcome.results;
    let truck = &r.protocols[0].models[0];
    assert!(truck.error.is_none(), "variant {k}: {:?}", truck.error);
    let scores = r
        .runs
        .iter()
        .map(|info| {
            let ceiling = info.ceiling.clone().expect("a generated run has its truth");
            let (h, p) = match ceiling.logged_input {
                Some(logged) => (logged.height_percent, logged.pressure_percent),
                None => (ceiling.height_percent, ceiling.pressure_percent),
            };
            let fit = truck
                .run(&info.name)
                .and_then(|f| f.estimated)
                .expect(&info.name);
            (
                info.name.clone(),
                fit.height_percent,
                fit.pressure_percent,
                h,
                p,
            )
        })
        .collect();
    (scores, truck.notes.clone())
}

/// Every run within `margin` points of its ceiling (#13 asks 3 on the validation runs), both
/// outputs, the held-out levelling run too: each of its logged load changes is eased over its
/// own transition time, fitted with the parameters fixed (with the common ramp of the
/// estimation runs it was 6-7 points short of its height ceiling on every variant: the truth
/// itself scores 90.1 % so on the reference).
fn assert_near_ceiling(k: u32, scores: &Scores, notes: &[String], margin: f64) {
    for (run, h, p, h_ceiling, p_ceiling) in scores {
        assert!(
            *h > h_ceiling - margin && *p > p_ceiling - margin,
            "variant {k}, {run}: {h:.1}/{p:.1} % against the ceiling {h_ceiling:.1}/{p_ceiling:.1} %; notes {notes:?}"
        );
    }
}

/// One of the model's notes says `needle`.
fn assert_noted(notes: &[String], needle: &str) {
    assert!(
        notes.iter().any(|n| n.contains(needle)),
        "{needle}: {notes:?}"
    );
}

#[test]
fn the_structure_reaches_the_ceiling_of_a_truck_drawn_anew() {
    // Measured: every run within 0.3 points of its ceiling; held out data-set 4 99.2/96.9 %
    // against 99.3/97.2 %, road 2 97.1/98.6 against 97.1/98.6 (96.5/98.6 before the study
    // refitted the tire and the lever's inertia on road 1 alone), levelling 2 95.1/99.1
    // against 95.2/99.1 (89.5/96.4 with the estimation runs' common ramp). With the gas's thermal
    // time held at the built-in 20 s: data-set 4's pressure 79.0 %, levelling 1's height
    // 83.8 % (an estimation run).
    let (scores, notes) = study_variant(1);
    assert_near_ceiling(1, &scores, &notes, 0.5);
}

#[test]
fn the_structure_takes_the_linear_valve_the_lab_calls_for() {
    // Measured: every run within 0.4 points of its ceiling (data-set 2's height 92.1 against
    // 92.5 %; road 2 96.7/98.3 against 97.0/98.6, 96.3/97.2 before the study refitted the
    // tire's stiffness and the lever's inertia on road 1 alone: the joint fit kept the file's
    // 1.8 MN/m for tires of 2.05 and took the inertia 12 % low to make up); data-set 3 (estimation) 95.3/87.4 % against 95.3/87.4 %, held out data-set 4
    // 99.1/94.4 against 99.3/94.7, levelling 2 95.3/99.0 against 95.5/99.1. Under the
    // structure's orifice with the lab's fit of one (b at its bound): data-set 3 75.5 %,
    // data-set 4 75.6 %, levelling 2 81.0 %.
    let (scores, notes) = study_variant(3);
    assert_noted(&notes, "under law `linear_resistance`");
    assert_noted(&notes, "refitted dscl, kw, ig on road 1 alone");
    assert_near_ceiling(3, &scores, &notes, 1.0);
}

#[test]
fn the_structure_reads_the_lab_right_on_a_truck_whose_area_bends() {
    // Variant 2: its area bends down below 220 mm and grows 0.0048 per 100 kPa (the
    // structure's built-in growth is 0.004), its wall slides late (pre-sliding stiffness
    // 14.8 kN/m against the built-in 20), and its gas volume's shape (A1/A0) is 12 % steeper
    // than the closed-valve fit reads. Measured: every run within 0.65 points of its ceiling,
    // the held-out data-set 4 (the bellow down to 195 mm) 99.4/97.3 % against 99.5/97.9 %.
    // Before, 91.6 % pressure there: with the friction of the map's sweeps left in its
    // readings the force-map prior let the area bend 1.2 % at 160 mm; with the wall's
    // stiffness held, 5 points; with the valve freed against the lab, c1, c2 and a0 sat 20 %
    // low together on the ridge that scales them (the first estimate, before the refit with
    // the lab's valve: 94.1 %).
    let (scores, notes) = study_variant(2);
    assert_noted(
        &notes,
        "the valve held at the lab's values (c1, c2) and a1, rline freed",
    );
    assert_near_ceiling(2, &scores, &notes, 1.0);
}
