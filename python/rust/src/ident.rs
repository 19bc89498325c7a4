//! `airsus.ident`: `airsus ident` on a file or a frame (both read their columns and hand
//! them to `airsus_ident::linear::request`, which checks, estimates and prints), and the
//! estimated polynomial model as an object with `simulate` and `predict`.

use anyhow::{Context, bail};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_data::time_axis::check_time_axis;
use airsus_ident::linear::{
    IdData, Identified, LabelledData, PemOptions, PolyModel, Request, RequestedOrders, Structure,
};

use crate::error::OrPy;
use crate::runs::{RunSource, RunSpec};

/// The requested columns and the sample time, as the command reads them: the sample time
/// from a `time_s` column when there is one (checked for uniform sampling), else `ts_s`.
fn read_data(
    source: &RunSource,
    inputs: &[String],
    output: &str,
    ts_flag: Option<f64>,
) -> anyhow::Result<LabelledData> {
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
    Ok(LabelledData {
        label: source.label(),
        data,
        rows,
    })
}

#[allow(clippy::too_many_arguments)]
fn run_ident(
    source: &RunSource,
    merge: &[RunSource],
    structure: Structure,
    inputs: &[String],
    output: &str,
    orders: &RequestedOrders,
    ts_s: Option<f64>,
    detrend: bool,
) -> anyhow::Result<Identified> {
    let request = Request {
        structure,
        orders,
        inputs,
        output,
        detrend,
        flag_prefix: "",
    };
    request.check()?;
    request.check_columns()?;
    let run = read_data(source, inputs, output, ts_s)?;
    let merged = merge
        .iter()
        .map(|other| read_data(other, inputs, output, ts_s))
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(request.estimate(run, merged, &PemOptions::default())?)
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
    let orders = RequestedOrders {
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
    out.set_item("report", serde_json::to_string(&identified.report).or_py()?)?;
    out.set_item("text", identified.text)?;
    out.set_item("simulation_fit", identified.simulation_fit_percent)?;
    out.set_item(
        "model",
        NativeLinearModel {
            model: identified.report.estimate.model,
        },
    )?;
    Ok(out)
}
