//! `airsus.ident`: crates/cli/src/commands/ident.rs on a file or a frame, and the estimated
//! polynomial model as an object with `simulate` and `predict`.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, anyhow, bail};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;

use airsus_data::time_axis::check_time_axis;
use airsus_ident::linear::{
    ArmaxOrders, ArxOrders, BjOrders, Estimate, IdData, IdentError, OeOrders, Offsets, PemOptions,
    PolyModel, armax, arx, bj, fit_percent, oe_with,
};

use crate::error::OrPy;
use crate::runs::{RunSource, RunSpec};

/// Model structure (the command's `--structure`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
enum Structure {
    Arx,
    Armax,
    Oe,
    Bj,
}

impl Structure {
    fn parse(name: &str) -> anyhow::Result<Self> {
        Ok(match name.to_ascii_lowercase().as_str() {
            "arx" => Self::Arx,
            "armax" => Self::Armax,
            "oe" => Self::Oe,
            "bj" => Self::Bj,
            _ => bail!("unknown structure `{name}`; the structures are: arx, armax, oe, bj"),
        })
    }

    fn label(self) -> &'static str {
        match self {
            Self::Arx => "ARX",
            Self::Armax => "ARMAX",
            Self::Oe => "OE",
            Self::Bj => "BJ",
        }
    }
}

/// The orders as given (`None` where not given).
struct Orders {
    na: Option<usize>,
    nb: Vec<usize>,
    nc: Option<usize>,
    nd: Option<usize>,
    nf: Vec<usize>,
    nk: Vec<usize>,
}

/// What `airsus ident --json` prints.
#[derive(Debug, Serialize)]
struct IdentReport<'a> {
    run: &'a Path,
    structure: Structure,
    output: &'a str,
    inputs: &'a [String],
    samples: usize,
    ts_s: f64,
    offsets: Option<Offsets>,
    /// The runs estimated together with `run` (`merge`), as the command's `--merge`.
    merged: Vec<MergedRun>,
    estimate: &'a Estimate,
}

/// One merged run in the report.
#[derive(Debug, Serialize)]
struct MergedRun {
    run: String,
    samples: usize,
    offsets: Option<Offsets>,
}

fn per_input(name: &str, values: &[usize], n_inputs: usize) -> anyhow::Result<Vec<usize>> {
    match values.len() {
        0 => bail!("{name} is required for this structure"),
        1 => Ok(vec![values[0]; n_inputs]),
        n if n == n_inputs => Ok(values.to_vec()),
        n => bail!(
            "{name} has {n} values but there are {n_inputs} inputs; give one value for all inputs or one per input"
        ),
    }
}

fn required(name: &str, value: Option<usize>) -> anyhow::Result<usize> {
    value.with_context(|| format!("{name} is required for this structure"))
}

fn reject_unused(s: Structure, o: &Orders) -> anyhow::Result<()> {
    let uses = |name: &str| match name {
        "na" => matches!(s, Structure::Arx | Structure::Armax),
        "nc" => matches!(s, Structure::Armax | Structure::Bj),
        "nd" => matches!(s, Structure::Bj),
        "nf" => matches!(s, Structure::Oe | Structure::Bj),
        _ => true,
    };
    let given = [
        ("na", o.na.is_some()),
        ("nc", o.nc.is_some()),
        ("nd", o.nd.is_some()),
        ("nf", !o.nf.is_empty()),
    ];
    for (name, present) in given {
        if present && !uses(name) {
            bail!(
                "{name} does not apply to {} models (ARX: na nb nk; ARMAX: na nb nc nk; OE: nb nf nk; BJ: nb nc nd nf nk)",
                s.label()
            );
        }
    }
    Ok(())
}

/// The requested columns and the sample time, as the command reads them: the sample time
/// from a `time_s` column when there is one (checked for uniform sampling), else `ts_s`.
fn read_data(
    source: &RunSource,
    inputs: &[String],
    output: &str,
    ts_flag: Option<f64>,
) -> anyhow::Result<(IdData, usize)> {
    if inputs.iter().any(|n| n.trim().is_empty()) {
        bail!("inputs contains an empty column name");
    }
    for (i, name) in inputs.iter().enumerate() {
        if inputs[..i].contains(name) {
            bail!("input column `{name}` is listed twice");
        }
        if name == output {
            bail!("column `{name}` is both an input and the output");
        }
    }
    let mut names: Vec<&str> = inputs.iter().map(String::as_str).collect();
    names.push(output);
    let path = source.path();
    let mut table = source.table(&names)?;
    let ts_s = if table.header.iter().any(|h| h == "time_s") {
        names.push("time_s");
        table = source.table(&names)?;
        let ts = check_time_axis(&table, names.len() - 1, &path, 2)?;
        if let Some(flag) = ts_flag
            && (flag - ts).abs() > 1e-9 * ts
        {
            bail!(
                "ts_s {flag} contradicts the sample time {ts} s of the time_s column in {}",
                source.label()
            );
        }
        ts
    } else {
        ts_flag.with_context(|| {
            format!(
                "{} has no time_s column: pass the sample time with ts_s",
                source.label()
            )
        })?
    };
    let n_inputs = inputs.len();
    let mut columns = table.columns.into_iter();
    let u: Vec<Vec<f64>> = columns.by_ref().take(n_inputs).collect();
    let y = columns
        .next()
        .context("output column missing from the table")?;
    let rows = y.len();
    let data = IdData::new(y, u, ts_s)
        .with_context(|| format!("invalid identification data in {}", source.label()))?;
    Ok((data, rows))
}

struct Identified {
    json: String,
    text: String,
    simulation_fit: Option<f64>,
    model: PolyModel,
}

#[allow(clippy::too_many_arguments)]
fn run_ident(
    source: &RunSource,
    merge: &[RunSource],
    structure: Structure,
    inputs: &[String],
    output: &str,
    orders: &Orders,
    ts_s: Option<f64>,
    detrend: bool,
) -> anyhow::Result<Identified> {
    reject_unused(structure, orders)?;
    if !merge.is_empty() && structure != Structure::Oe {
        bail!(
            "merge estimates OE models only so far; {} models take one run",
            structure.label()
        );
    }
    // Each run detrended by its own means, as MATLAB's `detrend` does a merged data set.
    let prepare = |raw: IdData| {
        if detrend {
            let (d, o) = raw.detrend();
            (d, Some(o))
        } else {
            (raw, None)
        }
    };
    let (raw, rows) = read_data(source, inputs, output, ts_s)?;
    let m = raw.n_inputs();
    let (data, offsets) = prepare(raw);
    let mut merged_data = Vec::with_capacity(merge.len());
    let mut merged = Vec::with_capacity(merge.len());
    for other in merge {
        let (raw, samples) = read_data(other, inputs, output, ts_s)?;
        let (d, offsets) = prepare(raw);
        merged_data.push(d);
        merged.push(MergedRun {
            run: other.label(),
            samples,
            offsets,
        });
    }
    let nb = per_input("nb", &orders.nb, m)?;
    let nk = per_input("nk", &orders.nk, m)?;
    let options = PemOptions::default();
    let context = || format!("{} estimation on {}", structure.label(), source.label());
    let estimate = match structure {
        Structure::Arx => arx(
            &data,
            &ArxOrders {
                na: required("na", orders.na)?,
                nb,
                nk,
            },
        ),
        Structure::Armax => armax(
            &data,
            &ArmaxOrders {
                na: required("na", orders.na)?,
                nb,
                nc: required("nc", orders.nc)?,
                nk,
            },
            &options,
        ),
        Structure::Oe => {
            let orders = OeOrders {
                nb,
                nf: per_input("nf", &orders.nf, m)?,
                nk,
            };
            oe_with(&data, merged_data, &orders, &options)
        }
        Structure::Bj => bj(
            &data,
            &BjOrders {
                nb,
                nc: required("nc", orders.nc)?,
                nd: required("nd", orders.nd)?,
                nf: per_input("nf", &orders.nf, m)?,
                nk,
            },
            &options,
        ),
    }
    .map_err(|e| match e {
        // Name the column rather than its position.
        IdentError::ConstantInput { input, value } => anyhow!(
            "input column `{}` is constant ({value}) in {}{}: a constant input carries no information about the dynamics",
            inputs.get(input).map_or("?", String::as_str),
            source.label(),
            if merge.is_empty() {
                ""
            } else {
                " and in every merged run"
            }
        ),
        other => anyhow::Error::new(other).context(context()),
    })?;

    let label = source.label();
    let report = IdentReport {
        run: Path::new(&label),
        structure,
        output,
        inputs,
        samples: rows,
        ts_s: data.ts_s(),
        offsets: offsets.clone(),
        merged,
        estimate: &estimate,
    };
    let json = serde_json::to_string(&report)?;

    // The command's printout.
    let mut text = String::new();
    writeln!(
        text,
        "{} ← {} ({}, {rows} samples)",
        output,
        inputs.join(", "),
        label
    )?;
    for run in &report.merged {
        writeln!(
            text,
            "merged with {} ({} samples): one model, each run's filters from its own first sample",
            run.run, run.samples
        )?;
    }
    if m > 1 {
        let map: Vec<String> = inputs
            .iter()
            .enumerate()
            .map(|(i, n)| format!("u{} = {n}", i + 1))
            .collect();
        writeln!(text, "Inputs: {}", map.join(", "))?;
    }
    if let Some(o) = &offsets {
        let means: Vec<String> = inputs
            .iter()
            .zip(&o.u)
            .map(|(n, v)| format!("{n} {v}"))
            .collect();
        writeln!(
            text,
            "Detrended: removed means {} {}, {}",
            output,
            o.y,
            means.join(", ")
        )?;
    }
    writeln!(text)?;
    write!(text, "{estimate}")?;
    let simulation_fit = match estimate.simulation_fit_percent {
        Some(f) => Some(f),
        None => {
            // ARX reports the one-step prediction fit; the command adds the simulation fit.
            let sim = estimate.model.simulate(data.u())?;
            let fit = fit_percent(data.y(), &sim);
            match fit {
                Some(f) => writeln!(text, "Simulation fit to estimation data: {f:.2}%")?,
                None => writeln!(
                    text,
                    "Simulation fit to estimation data: diverges (unstable A)"
                )?,
            }
            fit
        }
    };
    Ok(Identified {
        json,
        text,
        simulation_fit,
        model: estimate.model,
    })
}

/// A linear black-box model (`airsus_ident::linear::PolyModel`), on the data's scale (the
/// Python `LinearModel` adds and removes the detrending offsets around it).
#[pyclass(module = "airsus._native", name = "NativeLinearModel", frozen)]
pub struct NativeLinearModel {
    model: PolyModel,
}

fn signals(u: &[PyReadonlyArray1<'_, f64>]) -> PyResult<Vec<Vec<f64>>> {
    u.iter().map(|a| Ok(a.as_slice()?.to_vec())).collect()
}

#[pymethods]
impl NativeLinearModel {
    /// Noise-free simulation from zero initial conditions (MATLAB `sim`); one array per input.
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        u: Vec<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let u = signals(&u)?;
        let y = py.detach(|| self.model.simulate(&u)).or_py()?;
        Ok(y.into_pyarray(py))
    }

    /// `k`-step-ahead prediction (MATLAB `predict(sys, data, k)`), zero initial conditions.
    fn predict<'py>(
        &self,
        py: Python<'py>,
        y: PyReadonlyArray1<'py, f64>,
        u: Vec<PyReadonlyArray1<'py, f64>>,
        k: usize,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = y.as_slice()?.to_vec();
        let u = signals(&u)?;
        let yhat = py.detach(|| self.model.predict(&y, &u, k)).or_py()?;
        Ok(yhat.into_pyarray(py))
    }

    /// Number of inputs.
    fn n_inputs(&self) -> usize {
        self.model.n_inputs()
    }
}

/// Estimates a linear black-box model of `output` from `inputs` as `airsus ident` does.
///
/// Returns `{"report": JSON text of `--json`, "text": the command's printout,
/// "simulation_fit": percent or None, "model": NativeLinearModel}`.
#[pyfunction]
#[pyo3(signature = (data, structure, inputs, output, na=None, nb=None, nc=None, nd=None, nf=None, nk=None, ts_s=None, detrend=false, merge=None))]
#[allow(clippy::too_many_arguments)]
pub fn ident<'py>(
    py: Python<'py>,
    data: RunSpec<'py>,
    structure: String,
    inputs: Vec<String>,
    output: String,
    na: Option<usize>,
    nb: Option<Vec<usize>>,
    nc: Option<usize>,
    nd: Option<usize>,
    nf: Option<Vec<usize>>,
    nk: Option<Vec<usize>>,
    ts_s: Option<f64>,
    detrend: bool,
    merge: Option<Vec<RunSpec<'py>>>,
) -> PyResult<Bound<'py, PyDict>> {
    let source = RunSource::from_spec(data)?;
    let merge = merge
        .unwrap_or_default()
        .into_iter()
        .map(RunSource::from_spec)
        .collect::<PyResult<Vec<_>>>()?;
    let structure = Structure::parse(&structure).or_py()?;
    let orders = Orders {
        na,
        nb: nb.unwrap_or_default(),
        nc,
        nd,
        nf: nf.unwrap_or_default(),
        nk: nk.unwrap_or_default(),
    };
    let identified = py
        .detach(|| {
            run_ident(
                &source, &merge, structure, &inputs, &output, &orders, ts_s, detrend,
            )
        })
        .or_py()?;
    let out = PyDict::new(py);
    out.set_item("report", identified.json)?;
    out.set_item("text", identified.text)?;
    out.set_item("simulation_fit", identified.simulation_fit)?;
    out.set_item(
        "model",
        NativeLinearModel {
            model: identified.model,
        },
    )?;
    Ok(out)
}
