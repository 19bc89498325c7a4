//! Estimation protocols: which runs the grey-box fits use.

use airsus_data::Role;

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
    /// ours (data-set 1 plus the short valve pulses of data-set 3), so the report shows what
    /// valve-action data buys on the other runs.
    pub fn builtin_pair() -> Vec<Self> {
        vec![
            Self {
                name: "thesis".to_owned(),
                description: "the thesis' protocol: estimation on data-set 1 (load steps, valve closed) only".to_owned(),
                estimation: vec!["data-set 1".to_owned()],
            },
            Self {
                name: "valve".to_owned(),
                description: "ours: estimation on data-set 1 plus the short valve pulses of data-set 3, which make the flow parameters identifiable".to_owned(),
                estimation: vec!["data-set 1".to_owned(), "data-set 3".to_owned()],
            },
        ]
    }
}
