//! Estimation protocols: which runs the grey-box fits use.

use airsus_data::Role;
use airsus_truck::experiments::{REFERENCE_RUNS, ReferenceRun};

use crate::input::StudyInput;

#[derive(Debug, Clone, PartialEq)]
pub struct Protocol {
    /// Short name used in file names and tables.
    pub name: String,
    pub description: String,
    /// Names of the estimation runs.
    pub estimation: Vec<String>,
}

impl Protocol {
    /// The study file's own protocol: its runs marked `estimation`.
    pub fn from_roles(input: &StudyInput) -> Self {
        Self {
            name: "study".to_owned(),
            description: "estimation on the runs the study file marks `estimation`".to_owned(),
            estimation: input.runs_with(Role::Estimation),
        }
    }

    /// The built-in study's two protocols side by side: the thesis' (data-set 1 only) and
    /// ours (a loading run, the short valve pulses of data-set 3, a levelling run and a road
    /// run: `airsus_truck::experiments::REFERENCE_RUNS`), so the report shows what valve,
    /// levelling and road data buy on the other runs.
    pub fn builtin_pair() -> Vec<Self> {
        let runs = |estimated: fn(&ReferenceRun) -> bool| {
            REFERENCE_RUNS
                .iter()
                .filter(|r| estimated(r))
                .map(|r| r.study_name.to_owned())
                .collect::<Vec<_>>()
        };
        vec![
            Self {
                name: "thesis".to_owned(),
                description: "the thesis' protocol: estimation on data-set 1 (load steps, valve closed) only".to_owned(),
                estimation: runs(|r| r.thesis_estimation),
            },
            Self {
                name: "valve".to_owned(),
                description: "ours: estimation on data-set 1, the short valve pulses of data-set 3 (which make the flow parameters identifiable), a levelling run and a road run".to_owned(),
                estimation: runs(|r| r.our_estimation),
            },
        ]
    }
}
