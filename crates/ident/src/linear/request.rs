//! One estimate as a user asks for it: a structure by name, orders given once for every input
//! or once per input, a run and the runs merged with it, named columns, optionally detrended;
//! and the report it gives, as JSON and as the toolbox-style printout.
//!
//! `airsus ident` and Python's `airsus.ident` read their data differently (a file or a log; a
//! file or a frame) and both hand it here, so that what is checked, estimated and printed is
//! one code path: the command's options and the Python keywords name the same orders, and a
//! message names them the way the caller's user writes them ([`Request::flag_prefix`]).

use std::fmt::Write as _;

use serde::Serialize;

use super::{
    ArmaxOrders, ArxOrders, BjOrders, Estimate, IdData, IdentError, OeOrders, Offsets, PemOptions,
    Structure, armax, armax_merged, arx, arx_merged, bj, bj_merged, fit_percent, oe, oe_merged,
};

impl Structure {
    /// The structure a user names, case-insensitively (`arx`, `armax`, `oe`, `bj`).
    pub fn parse(name: &str) -> Result<Self, RequestError> {
        Ok(match name.to_ascii_lowercase().as_str() {
            "arx" => Self::Arx,
            "armax" => Self::Armax,
            "oe" => Self::Oe,
            "bj" => Self::Bj,
            _ => {
                return Err(RequestError::Orders(format!(
                    "unknown structure `{name}`; the structures are: arx, armax, oe, bj"
                )));
            }
        })
    }

    /// Whether the structure has the polynomial of order `name` (`na`, `nc`, `nd`, `nf`;
    /// every structure has `nb` and `nk`).
    fn has_order(self, name: &str) -> bool {
        match name {
            "na" => matches!(self, Self::Arx | Self::Armax),
            "nc" => matches!(self, Self::Armax | Self::Bj),
            "nd" => matches!(self, Self::Bj),
            "nf" => matches!(self, Self::Oe | Self::Bj),
            _ => true,
        }
    }
}

/// The orders as the user gave them: `None` or empty where not given; a per-input order with
/// one value applies to every input.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RequestedOrders {
    pub na: Option<usize>,
    pub nb: Vec<usize>,
    pub nc: Option<usize>,
    pub nd: Option<usize>,
    pub nf: Vec<usize>,
    pub nk: Vec<usize>,
}

/// What to estimate, from which columns.
#[derive(Debug, Clone)]
pub struct Request<'a> {
    pub structure: Structure,
    pub orders: &'a RequestedOrders,
    /// The input columns' names, in the data's input order.
    pub inputs: &'a [String],
    pub output: &'a str,
    /// Each run's means removed (MATLAB `detrend(z, 0)`), each run by its own.
    pub detrend: bool,
    /// How an order is named in messages: `"--"` for the command's options (`--nb`), `""`
    /// for keywords (`nb`).
    pub flag_prefix: &'a str,
}

/// One run's data with what the report says of it.
#[derive(Debug, Clone)]
pub struct LabelledData {
    /// The run as the user named it (a path, or a frame's description).
    pub label: String,
    pub data: IdData,
    /// Rows read from the run.
    pub rows: usize,
}

/// What `airsus ident --json` prints and Python's `ident` returns as `report`.
#[derive(Debug, Clone, Serialize)]
pub struct IdentReport {
    pub run: String,
    pub structure: Structure,
    pub output: String,
    pub inputs: Vec<String>,
    pub samples: usize,
    pub ts_s: f64,
    /// Means removed before estimation (detrended), else null.
    pub offsets: Option<Offsets>,
    /// The runs estimated together with `run`, each with its samples and, detrended, its own
    /// means.
    pub merged: Vec<MergedRun>,
    pub estimate: Estimate,
}

/// One merged run in the report.
#[derive(Debug, Clone, Serialize)]
pub struct MergedRun {
    pub run: String,
    pub samples: usize,
    pub offsets: Option<Offsets>,
}

/// An estimate as asked for: the report, the printout and the simulation fit on the
/// estimation data.
#[derive(Debug, Clone)]
pub struct Identified {
    pub report: IdentReport,
    /// The printout: the columns and runs, the detrending, the model as the toolbox prints
    /// an `idpoly`, and for ARX the simulation fit as well.
    pub text: String,
    /// The pure simulation's fit on the estimation data, percent; `None` when it diverges.
    pub simulation_fit_percent: Option<f64>,
}

/// Why a request was not estimated.
#[derive(Debug, thiserror::Error)]
pub enum RequestError {
    /// The request itself is wrong (an order missing, given twice over, or foreign to the
    /// structure; a structure unknown).
    #[error("{0}")]
    Orders(String),
    /// An input column does not move: it carries nothing about the dynamics.
    #[error(
        "input column `{column}` is constant ({value}) in {run}{}: a constant input carries no information about the dynamics",
        if *.merged { " and in every merged run" } else { "" }
    )]
    ConstantInput {
        column: String,
        value: f64,
        run: String,
        merged: bool,
    },
    /// The runs do not go together: a run's columns are not the ones named, or runs merged
    /// with it have other inputs or another sample time.
    #[error("{0}")]
    Runs(String),
    /// The estimator failed.
    #[error("{structure} estimation on {run}")]
    Estimation {
        structure: &'static str,
        run: String,
        #[source]
        source: IdentError,
    },
}

impl Request<'_> {
    /// The checks that need no data: orders the structure does not have are refused rather
    /// than ignored (a typo would otherwise pass).
    pub fn check(&self) -> Result<(), RequestError> {
        let o = self.orders;
        let given = [
            ("na", o.na.is_some()),
            ("nc", o.nc.is_some()),
            ("nd", o.nd.is_some()),
            ("nf", !o.nf.is_empty()),
        ];
        for (name, present) in given {
            if present && !self.structure.has_order(name) {
                return Err(RequestError::Orders(format!(
                    "{}{name} does not apply to {} models (ARX: na nb nk; ARMAX: na nb nc nk; OE: nb nf nk; BJ: nb nc nd nf nk)",
                    self.flag_prefix,
                    self.structure.label()
                )));
            }
        }
        Ok(())
    }

    /// The column names are usable: none empty, none twice, the output not an input.
    pub fn check_columns(&self) -> Result<(), RequestError> {
        if self.inputs.iter().any(|n| n.trim().is_empty()) {
            return Err(RequestError::Orders(format!(
                "{}inputs contains an empty column name",
                self.flag_prefix
            )));
        }
        for (i, name) in self.inputs.iter().enumerate() {
            if self.inputs[..i].contains(name) {
                return Err(RequestError::Orders(format!(
                    "input column `{name}` is listed twice"
                )));
            }
            if name == self.output {
                return Err(RequestError::Orders(format!(
                    "column `{name}` is both an input and the output"
                )));
            }
        }
        Ok(())
    }

    fn per_input(
        &self,
        name: &str,
        values: &[usize],
        n_inputs: usize,
    ) -> Result<Vec<usize>, RequestError> {
        let flag = self.flag_prefix;
        match values.len() {
            0 => Err(RequestError::Orders(format!(
                "{flag}{name} is required for this structure"
            ))),
            1 => Ok(vec![values[0]; n_inputs]),
            n if n == n_inputs => Ok(values.to_vec()),
            n => Err(RequestError::Orders(format!(
                "{flag}{name} has {n} values but there are {n_inputs} inputs; give one value for all inputs or one per input"
            ))),
        }
    }

    fn required(&self, name: &str, value: Option<usize>) -> Result<usize, RequestError> {
        value.ok_or_else(|| {
            RequestError::Orders(format!(
                "{}{name} is required for this structure",
                self.flag_prefix
            ))
        })
    }

    /// Estimates the requested model on `run` and the runs `merged` with it (one model, each
    /// run's filters started at its own first sample: [`arx_merged`], [`oe_merged`], …),
    /// each run detrended by its own means when asked.
    pub fn estimate(
        &self,
        run: LabelledData,
        merged: Vec<LabelledData>,
        options: &PemOptions,
    ) -> Result<Identified, RequestError> {
        self.check()?;
        let prepare = |raw: IdData| {
            if self.detrend {
                let (d, o) = raw.detrend();
                (d, Some(o))
            } else {
                (raw, None)
            }
        };
        let m = run.data.n_inputs();
        if m != self.inputs.len() {
            return Err(RequestError::Runs(format!(
                "{} has {m} input columns, the request names {}: {}",
                run.label,
                self.inputs.len(),
                if self.inputs.is_empty() {
                    "none".to_string()
                } else {
                    self.inputs.join(", ")
                }
            )));
        }
        // Named here, where the runs have their labels (the estimators can only count).
        let ts_s = run.data.ts_s();
        for other in &merged {
            if other.data.n_inputs() != m {
                return Err(RequestError::Runs(format!(
                    "{} has {} input columns, {} has {m}: merged runs share their inputs",
                    other.label,
                    other.data.n_inputs(),
                    run.label
                )));
            }
            if !super::pem::same_sample_time(other.data.ts_s(), ts_s) {
                return Err(RequestError::Runs(format!(
                    "{} is sampled every {} s, {} every {ts_s} s: merged runs share one sample time (resample one of them)",
                    other.label,
                    other.data.ts_s(),
                    run.label
                )));
            }
        }
        // The estimation data: the run first, then the runs merged with it.
        let (data, offsets) = prepare(run.data);
        let mut experiments = Vec::with_capacity(1 + merged.len());
        experiments.push(data);
        let mut merged_runs = Vec::with_capacity(merged.len());
        for other in merged {
            let (d, offsets) = prepare(other.data);
            experiments.push(d);
            merged_runs.push(MergedRun {
                run: other.label,
                samples: other.rows,
                offsets,
            });
        }
        let o = self.orders;
        let nb = self.per_input("nb", &o.nb, m)?;
        let nk = self.per_input("nk", &o.nk, m)?;
        let (single, data) = (experiments.len() == 1, &experiments[0]);
        let estimate = match self.structure {
            Structure::Arx => {
                let orders = ArxOrders {
                    na: self.required("na", o.na)?,
                    nb,
                    nk,
                };
                if single {
                    arx(data, &orders)
                } else {
                    arx_merged(&experiments, &orders)
                }
            }
            Structure::Armax => {
                let orders = ArmaxOrders {
                    na: self.required("na", o.na)?,
                    nb,
                    nc: self.required("nc", o.nc)?,
                    nk,
                };
                if single {
                    armax(data, &orders, options)
                } else {
                    armax_merged(&experiments, &orders, options)
                }
            }
            Structure::Oe => {
                let orders = OeOrders {
                    nb,
                    nf: self.per_input("nf", &o.nf, m)?,
                    nk,
                };
                if single {
                    oe(data, &orders, options)
                } else {
                    oe_merged(&experiments, &orders, options)
                }
            }
            Structure::Bj => {
                let orders = BjOrders {
                    nb,
                    nc: self.required("nc", o.nc)?,
                    nd: self.required("nd", o.nd)?,
                    nf: self.per_input("nf", &o.nf, m)?,
                    nk,
                };
                if single {
                    bj(data, &orders, options)
                } else {
                    bj_merged(&experiments, &orders, options)
                }
            }
        }
        .map_err(|e| match e {
            // Name the column rather than its position.
            IdentError::ConstantInput { input, value } => RequestError::ConstantInput {
                column: self
                    .inputs
                    .get(input)
                    .cloned()
                    .unwrap_or_else(|| "?".into()),
                value,
                run: run.label.clone(),
                merged: !merged_runs.is_empty(),
            },
            source => RequestError::Estimation {
                structure: self.structure.label(),
                run: run.label.clone(),
                source,
            },
        })?;
        let (text, simulation_fit_percent) = self.printout(
            &run.label,
            run.rows,
            &experiments,
            offsets.as_ref(),
            &merged_runs,
            &estimate,
        )?;
        Ok(Identified {
            report: IdentReport {
                run: run.label,
                structure: self.structure,
                output: self.output.to_string(),
                inputs: self.inputs.to_vec(),
                samples: run.rows,
                ts_s: experiments[0].ts_s(),
                offsets,
                merged: merged_runs,
                estimate,
            },
            text,
            simulation_fit_percent,
        })
    }

    /// The printout and the simulation fit on the estimation data (`estimated_on`: the run,
    /// or the run and the runs merged with it, each simulated from rest at its own start).
    fn printout(
        &self,
        label: &str,
        rows: usize,
        estimated_on: &[IdData],
        offsets: Option<&Offsets>,
        merged: &[MergedRun],
        estimate: &Estimate,
    ) -> Result<(String, Option<f64>), RequestError> {
        // Writing to a String cannot fail.
        let mut text = String::new();
        let _ = writeln!(
            text,
            "{} ← {} ({label}, {rows} samples)",
            self.output,
            self.inputs.join(", "),
        );
        for run in merged {
            let _ = writeln!(
                text,
                "merged with {} ({} samples): one model, each run's filters from its own first sample",
                run.run, run.samples
            );
        }
        if self.inputs.len() > 1 {
            let map: Vec<String> = self
                .inputs
                .iter()
                .enumerate()
                .map(|(i, n)| format!("u{} = {n}", i + 1))
                .collect();
            let _ = writeln!(text, "Inputs: {}", map.join(", "));
        }
        if let Some(o) = offsets {
            let means: Vec<String> = self
                .inputs
                .iter()
                .zip(&o.u)
                .map(|(n, v)| format!("{n} {v}"))
                .collect();
            let _ = writeln!(
                text,
                "Detrended: removed means {} {}, {}",
                self.output,
                o.y,
                means.join(", ")
            );
        }
        let _ = writeln!(text);
        let _ = write!(text, "{estimate}");
        let simulation_fit = match estimate.simulation_fit_percent {
            Some(f) => Some(f),
            None => {
                // ARX reports the one-step prediction fit; the simulation fit is added, as it
                // is what the thesis' models are judged by.
                let simulated = estimated_on
                    .iter()
                    .map(|d| estimate.model.simulate(d.u()))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|source| RequestError::Estimation {
                        structure: self.structure.label(),
                        run: label.to_string(),
                        source,
                    })?;
                let measured: Vec<f64> = estimated_on
                    .iter()
                    .flat_map(|d| d.y().iter().copied())
                    .collect();
                let fit = fit_percent(&measured, &simulated.concat());
                let _ = match fit {
                    Some(f) => writeln!(text, "Simulation fit to estimation data: {f:.2}%"),
                    None => writeln!(
                        text,
                        "Simulation fit to estimation data: diverges (unstable A)"
                    ),
                };
                fit
            }
        };
        Ok((text, simulation_fit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request<'a>(
        structure: Structure,
        orders: &'a RequestedOrders,
        inputs: &'a [String],
        flag_prefix: &'a str,
    ) -> Request<'a> {
        Request {
            structure,
            orders,
            inputs,
            output: "y",
            detrend: false,
            flag_prefix,
        }
    }

    /// `y(t) = 0.8 y(t−1) + 0.5 u1(t−1) − 0.2 u2(t−1)`, two inputs; `u2` constant when asked.
    fn run(label: &str, constant_u2: bool) -> LabelledData {
        let n = 300;
        let u1: Vec<f64> = (0..n).map(|k| ((k * 7919) % 13) as f64 - 6.0).collect();
        let u2: Vec<f64> = (0..n)
            .map(|k| {
                if constant_u2 {
                    1.0
                } else {
                    ((k * 104_729) % 7) as f64 - 3.0
                }
            })
            .collect();
        let mut y = vec![0.0; n];
        for t in 1..n {
            y[t] = 0.8 * y[t - 1] + 0.5 * u1[t - 1] - 0.2 * u2[t - 1];
        }
        LabelledData {
            label: label.into(),
            data: IdData::new(y, vec![u1, u2], 0.1).unwrap(),
            rows: n,
        }
    }

    fn two_inputs() -> [String; 2] {
        ["u1".to_string(), "u2".to_string()]
    }

    /// `na = nb = nk = 1`, the orders of [`run`]'s system.
    fn first_order_arx() -> RequestedOrders {
        RequestedOrders {
            na: Some(1),
            nb: vec![1],
            nk: vec![1],
            ..Default::default()
        }
    }

    #[test]
    fn runs_that_do_not_go_together_are_named() {
        let (inputs, orders) = (two_inputs(), first_order_arx());
        let arx = request(Structure::Arx, &orders, &inputs, "--");
        let options = PemOptions::default();
        // One column named for two inputs.
        let one = ["u1".to_string()];
        let e = request(Structure::Arx, &orders, &one, "--")
            .estimate(run("r.csv", false), Vec::new(), &options)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "r.csv has 2 input columns, the request names 1: u1"
        );
        // A merged run at another sample time, or with another number of inputs.
        let mut slow = run("slow.csv", false);
        slow.data = IdData::new(slow.data.y().to_vec(), slow.data.u().to_vec(), 0.2).unwrap();
        let e = arx
            .estimate(run("r.csv", false), vec![slow], &options)
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("slow.csv is sampled every 0.2 s, r.csv every 0.1 s"),
            "{e}"
        );
        let mut narrow = run("narrow.csv", false);
        narrow.data =
            IdData::new(narrow.data.y().to_vec(), narrow.data.u()[..1].to_vec(), 0.1).unwrap();
        for structure in [Structure::Arx, Structure::Oe] {
            let e = request(structure, &orders_for(structure), &inputs, "--")
                .estimate(run("r.csv", false), vec![narrow.clone()], &options)
                .unwrap_err();
            assert!(
                e.to_string()
                    .starts_with("narrow.csv has 1 input columns, r.csv has 2"),
                "{e}"
            );
        }
    }

    /// First-order orders of `structure` for [`run`]'s two inputs.
    fn orders_for(structure: Structure) -> RequestedOrders {
        match structure {
            Structure::Oe => RequestedOrders {
                nb: vec![1],
                nf: vec![1],
                nk: vec![1],
                ..Default::default()
            },
            _ => first_order_arx(),
        }
    }

    #[test]
    fn orders_are_named_as_the_caller_writes_them() {
        let (inputs, orders) = (two_inputs(), first_order_arx());
        let e = request(Structure::Oe, &orders, &inputs, "--")
            .check()
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--na does not apply to OE models"),
            "{e}"
        );
        let three = RequestedOrders {
            nb: vec![1, 1, 1],
            ..orders.clone()
        };
        let e = request(Structure::Arx, &three, &inputs, "--")
            .estimate(run("r.csv", false), Vec::new(), &PemOptions::default())
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--nb has 3 values but there are 2 inputs"),
            "{e}"
        );
        let twice = ["u1".to_string(), "u1".to_string()];
        let e = request(Structure::Arx, &orders, &twice, "")
            .check_columns()
            .unwrap_err();
        assert_eq!(e.to_string(), "input column `u1` is listed twice");
    }

    #[test]
    fn an_order_given_once_serves_every_input_and_the_report_says_what_was_done() {
        let (inputs, orders) = (two_inputs(), first_order_arx());
        let done = request(Structure::Arx, &orders, &inputs, "--")
            .estimate(run("r.csv", false), Vec::new(), &PemOptions::default())
            .unwrap();
        let model = &done.report.estimate.model;
        assert!((model.a[1] + 0.8).abs() < 1e-9, "{model:?}");
        assert!((model.b[0][0] - 0.5).abs() < 1e-9 && (model.b[1][0] + 0.2).abs() < 1e-9);
        // ARX gives the one-step fit; the simulation fit is added, and it is exact here.
        assert!(done.simulation_fit_percent.unwrap() > 99.99);
        assert!(
            done.text.starts_with("y ← u1, u2 (r.csv, 300 samples)"),
            "{}",
            done.text
        );
        assert!(done.text.contains("Inputs: u1 = u1, u2 = u2"));
        assert!(
            done.text
                .contains("Simulation fit to estimation data: 100.00%")
        );
        let json = serde_json::to_value(&done.report).unwrap();
        assert_eq!(json["structure"], "arx");
        assert_eq!(json["run"], "r.csv");
        assert_eq!(json["samples"], 300);
    }

    #[test]
    fn a_constant_input_is_named_by_its_column() {
        let inputs = ["u1".to_string(), "load".to_string()];
        let orders = RequestedOrders {
            nb: vec![1],
            nf: vec![1],
            nk: vec![1],
            ..Default::default()
        };
        let e = request(Structure::Oe, &orders, &inputs, "--")
            .estimate(
                run("a.csv", true),
                vec![run("b.csv", true)],
                &PemOptions::default(),
            )
            .unwrap_err();
        assert!(
            e.to_string().starts_with(
                "input column `load` is constant (1) in a.csv and in every merged run"
            ),
            "{e}"
        );
    }
}
