//! `airsus._native`: the library behind the `airsus` Python package.
//!
//! This layer is thin on purpose. Every function calls the same library functions, with the
//! same defaults, in the same order, as the matching `airsus` command (crates/cli/src/commands),
//! so a Python result equals the command's to the last bit. It speaks plain Python values:
//! numbers, strings, lists, dicts and 1-D float64 numpy arrays (converted through slices, see
//! [`runs`]). pandas lives only in the Python package (`python/src/airsus/__init__.py`).
//!
//! Errors are [`AirsusError`] (a `ValueError`) carrying the text the command prints after
//! `error: ` (anyhow's `{:#}`: the context chain, with file, line and column for bad inputs).
//! Long calls release the GIL ([`Python::detach`]) and report progress to an optional Python
//! callable ([`progress::Progress`]).

use pyo3::prelude::*;

mod apps;
mod error;
mod fleet;
mod greybox;
mod ident;
mod progress;
mod runs;
mod simulate;
mod truck;

pub use error::AirsusError;

/// The native module; `airsus/__init__.py` wraps it in the documented API.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("AirsusError", py.get_type::<AirsusError>())?;
    m.add_class::<truck::NativeTruck>()?;
    m.add_class::<ident::NativeLinearModel>()?;
    m.add_function(wrap_pyfunction!(runs::read_run, m)?)?;
    m.add_function(wrap_pyfunction!(runs::write_run, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(greybox::greybox, m)?)?;
    m.add_function(wrap_pyfunction!(ident::ident, m)?)?;
    m.add_function(wrap_pyfunction!(apps::models, m)?)?;
    m.add_function(wrap_pyfunction!(apps::weigh, m)?)?;
    m.add_function(wrap_pyfunction!(apps::study, m)?)?;
    m.add_function(wrap_pyfunction!(apps::generate, m)?)?;
    m.add_function(wrap_pyfunction!(apps::nrmse, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::standstills, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::gas_amount_mol, m)?)?;
    Ok(())
}
