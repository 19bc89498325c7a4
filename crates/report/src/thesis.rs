//! The thesis' published numbers (Lartén 2016, ch. 5), to print beside ours.
//!
//! NRMSE in percent. The thesis estimated on data-set 1 and validated on data-sets 2–4; its
//! "Estimation 2" parameter sets are the ones validated in Tables 5.13–5.15.

/// Table 5.1: pressure model with the fitted cross-section, estimation / validation data.
pub const TABLE_5_1_CROSS_SECTION: (f64, f64) = (90.85, 92.19);

/// Table 5.3: air-flow submodel on validation discharges, fill / exhaust.
pub const TABLE_5_3_VALVE: (f64, f64) = (64.06, 62.77);

/// Tables 5.10–5.12, "Estimation 2" column, and their nominal column: (height, pressure).
pub struct GreyboxReference {
    pub model: &'static str,
    pub table: &'static str,
    pub free: &'static str,
    pub nominal: (f64, f64),
    pub estimated: (f64, f64),
}

pub const GREYBOX: &[GreyboxReference] = &[
    GreyboxReference {
        model: "m1",
        table: "5.10",
        free: "p0-p4, m2, kf",
        nominal: (-21.02, 6.646),
        estimated: (82.88, 88.01),
    },
    GreyboxReference {
        model: "m2",
        table: "5.11",
        free: "p0-p4, m2, ig",
        nominal: (65.18, 65.77),
        estimated: (88.19, 90.97),
    },
    GreyboxReference {
        model: "m2x",
        table: "5.12",
        free: "p0-p4, m2, ig, ksd",
        nominal: (66.89, 62.12),
        estimated: (87.35, 89.4),
    },
];

/// Tables 5.13–5.16: validation NRMSE per data-set 2, 3, 4: (height, pressure).
pub struct ValidationReference {
    pub model: &'static str,
    pub table: &'static str,
    pub data_sets: [(f64, f64); 3],
}

pub const VALIDATION: &[ValidationReference] = &[
    ValidationReference {
        model: "m1",
        table: "5.13",
        data_sets: [(85.88, 88.35), (24.97, 37.4), (-43.46, -255.1)],
    },
    ValidationReference {
        model: "m2",
        table: "5.14",
        data_sets: [(86.88, 89.74), (31.37, 35.7), (-36.18, -218.80)],
    },
    ValidationReference {
        model: "m2x",
        table: "5.15",
        data_sets: [(91.14, 89.63), (5.78, 50.6), (-34.61, -210.7)],
    },
    ValidationReference {
        model: "m3",
        table: "5.16",
        data_sets: [(74.45, 74.00), (-46.35, 61.51), (-28.68, -261.9)],
    },
];

/// The thesis' value for `model` on data-set `n` (2–4), if it published one.
pub fn validation(model: &str, data_set: usize) -> Option<(f64, f64)> {
    let row = VALIDATION.iter().find(|r| r.model == model)?;
    row.data_sets.get(data_set.checked_sub(2)?).copied()
}

#[cfg(test)]
mod tests {
    #[test]
    fn lookups_follow_the_tables() {
        assert_eq!(super::validation("m2", 2), Some((86.88, 89.74)));
        assert_eq!(super::validation("m3", 4), Some((-28.68, -261.9)));
        assert_eq!(super::validation("truck", 2), None);
        assert_eq!(super::validation("m1", 1), None);
    }
}
