//! Model orders (structural parameters `na, nb, nc, nd, nf, nk`, thesis eq 3.22/3.24) and the
//! parameter layout shared by all estimators.

use serde::Serialize;

use super::data::{IdData, check_input_varies};
use super::error::IdentError;
use super::estimate::parameter_names;
use super::model::{PolyModel, Structure};

/// ARX orders: `A(q)y(t) = Σᵢ Bᵢ(q)uᵢ(t − nkᵢ) + e(t)`. `nb` and `nk` have one entry per
/// input; `nbᵢ = 0` leaves input `i` out; `na = 0` gives a FIR model.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ArxOrders {
    /// Order of `A`.
    pub na: usize,
    /// Number of `Bᵢ` coefficients per input.
    pub nb: Vec<usize>,
    /// Delay of each input, in samples.
    pub nk: Vec<usize>,
}

/// ARMAX orders: `A(q)y(t) = Σᵢ Bᵢ(q)uᵢ(t − nkᵢ) + C(q)e(t)`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ArmaxOrders {
    /// Order of `A`.
    pub na: usize,
    /// Number of `Bᵢ` coefficients per input.
    pub nb: Vec<usize>,
    /// Order of `C`.
    pub nc: usize,
    /// Delay of each input, in samples.
    pub nk: Vec<usize>,
}

/// Output-error orders: `y(t) = Σᵢ Bᵢ(q)/Fᵢ(q) uᵢ(t − nkᵢ) + e(t)`; `nbᵢ ≥ 1`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct OeOrders {
    /// Number of `Bᵢ` coefficients per input.
    pub nb: Vec<usize>,
    /// Order of `Fᵢ` per input.
    pub nf: Vec<usize>,
    /// Delay of each input, in samples.
    pub nk: Vec<usize>,
}

/// Box–Jenkins orders: `y(t) = Σᵢ Bᵢ/Fᵢ uᵢ(t − nkᵢ) + C(q)/D(q) e(t)`; `nbᵢ ≥ 1`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct BjOrders {
    /// Number of `Bᵢ` coefficients per input.
    pub nb: Vec<usize>,
    /// Order of `C`.
    pub nc: usize,
    /// Order of `D`.
    pub nd: usize,
    /// Order of `Fᵢ` per input.
    pub nf: Vec<usize>,
    /// Delay of each input, in samples.
    pub nk: Vec<usize>,
}

impl ArxOrders {
    /// Single-input orders `[na nb nk]`.
    pub fn siso(na: usize, nb: usize, nk: usize) -> Self {
        Self {
            na,
            nb: vec![nb],
            nk: vec![nk],
        }
    }
}

impl ArmaxOrders {
    /// Single-input orders `[na nb nc nk]`.
    pub fn siso(na: usize, nb: usize, nc: usize, nk: usize) -> Self {
        Self {
            na,
            nb: vec![nb],
            nc,
            nk: vec![nk],
        }
    }
}

impl OeOrders {
    /// Single-input orders `[nb nf nk]`.
    pub fn siso(nb: usize, nf: usize, nk: usize) -> Self {
        Self {
            nb: vec![nb],
            nf: vec![nf],
            nk: vec![nk],
        }
    }
}

impl BjOrders {
    /// Single-input orders `[nb nc nd nf nk]`.
    pub fn siso(nb: usize, nc: usize, nd: usize, nf: usize, nk: usize) -> Self {
        Self {
            nb: vec![nb],
            nc,
            nd,
            nf: vec![nf],
            nk: vec![nk],
        }
    }
}

/// All orders of the general structure, the parameter vector layout
/// `θ = [a₁…a_na, b⁽¹⁾…, b⁽ᵐ⁾…, c₁…c_nc, d₁…d_nd, f⁽¹⁾…, f⁽ᵐ⁾…]` (MATLAB `getpvec` order).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Layout {
    pub structure: Structure,
    pub na: usize,
    pub nb: Vec<usize>,
    pub nc: usize,
    pub nd: usize,
    pub nf: Vec<usize>,
    pub nk: Vec<usize>,
}

impl Layout {
    pub fn arx(o: &ArxOrders) -> Self {
        Self {
            structure: Structure::Arx,
            na: o.na,
            nb: o.nb.clone(),
            nc: 0,
            nd: 0,
            nf: vec![0; o.nb.len()],
            nk: o.nk.clone(),
        }
    }

    pub fn armax(o: &ArmaxOrders) -> Self {
        Self {
            structure: Structure::Armax,
            na: o.na,
            nb: o.nb.clone(),
            nc: o.nc,
            nd: 0,
            nf: vec![0; o.nb.len()],
            nk: o.nk.clone(),
        }
    }

    pub fn oe(o: &OeOrders) -> Self {
        Self {
            structure: Structure::Oe,
            na: 0,
            nb: o.nb.clone(),
            nc: 0,
            nd: 0,
            nf: o.nf.clone(),
            nk: o.nk.clone(),
        }
    }

    pub fn bj(o: &BjOrders) -> Self {
        Self {
            structure: Structure::Bj,
            na: 0,
            nb: o.nb.clone(),
            nc: o.nc,
            nd: o.nd,
            nf: o.nf.clone(),
            nk: o.nk.clone(),
        }
    }

    /// Layout of an existing model (for refinement).
    pub fn of_model(m: &PolyModel) -> Self {
        Self {
            structure: m.structure,
            na: m.a.len().saturating_sub(1),
            nb: m.b.iter().map(Vec::len).collect(),
            nc: m.c.len().saturating_sub(1),
            nd: m.d.len().saturating_sub(1),
            nf: m.f.iter().map(|f| f.len().saturating_sub(1)).collect(),
            nk: m.nk.clone(),
        }
    }

    pub fn n_inputs(&self) -> usize {
        self.nb.len()
    }

    pub fn n_params(&self) -> usize {
        self.na + self.nb.iter().sum::<usize>() + self.nc + self.nd + self.nf.iter().sum::<usize>()
    }

    pub fn names(&self) -> Vec<String> {
        parameter_names(self.na, &self.nb, self.nc, self.nd, &self.nf)
    }

    /// Longest look-back of any regressor: samples before this index have incomplete
    /// regressors.
    pub fn max_lag(&self) -> usize {
        let input_lag = self
            .nb
            .iter()
            .zip(&self.nk)
            .filter(|&(&nb, _)| nb > 0)
            .map(|(&nb, &nk)| nk + nb - 1)
            .max()
            .unwrap_or(0);
        let nf = self.nf.iter().copied().max().unwrap_or(0);
        self.na.max(self.nc).max(self.nd).max(nf).max(input_lag)
    }

    /// Checks the orders against the data and the structure's rules.
    pub fn validate(&self, data: &IdData) -> Result<(), IdentError> {
        let m = self.n_inputs();
        if self.nk.len() != m || self.nf.len() != m {
            return Err(IdentError::InvalidOrder(format!(
                "nb has {m} entries but nk has {} and nf {}; give one per input",
                self.nk.len(),
                self.nf.len()
            )));
        }
        if m != data.n_inputs() {
            return Err(IdentError::InputCountMismatch {
                orders: m,
                data: data.n_inputs(),
            });
        }
        if matches!(self.structure, Structure::Oe | Structure::Bj)
            && let Some(i) = self.nb.iter().position(|&nb| nb == 0)
        {
            return Err(IdentError::InvalidOrder(format!(
                "nb for input {} is 0; {} needs at least one B coefficient per input",
                i + 1,
                self.structure.label()
            )));
        }
        let d = self.n_params();
        if d == 0 {
            return Err(IdentError::InvalidOrder(
                "all orders are zero: the model has no free parameter".to_owned(),
            ));
        }
        for (input, ui) in data.u().iter().enumerate() {
            if self.nb[input] > 0 {
                check_input_varies(input, ui)?;
            }
        }
        let available = data.len().saturating_sub(self.max_lag());
        if available < d + 1 {
            return Err(IdentError::TooFewSamples {
                available,
                parameters: d,
                required: d + 1,
            });
        }
        Ok(())
    }

    /// Polynomials from a parameter vector.
    pub fn model(&self, theta: &[f64], ts_s: f64) -> PolyModel {
        let mut it = theta.iter().copied();
        let mut monic = |n: usize| {
            let mut p = Vec::with_capacity(n + 1);
            p.push(1.0);
            p.extend(it.by_ref().take(n));
            p
        };
        let a = monic(self.na);
        let b: Vec<Vec<f64>> = self
            .nb
            .iter()
            .map(|&n| {
                let mut p = monic(n);
                p.remove(0);
                p
            })
            .collect();
        let c = monic(self.nc);
        let d = monic(self.nd);
        let f = self.nf.iter().map(|&n| monic(n)).collect();
        PolyModel {
            structure: self.structure,
            a,
            b,
            c,
            d,
            f,
            nk: self.nk.clone(),
            ts_s,
        }
    }

    /// Parameter vector of a model with these orders.
    pub fn theta(&self, m: &PolyModel) -> Vec<f64> {
        let mut theta = Vec::with_capacity(self.n_params());
        theta.extend_from_slice(&m.a[1..]);
        for b in &m.b {
            theta.extend_from_slice(b);
        }
        theta.extend_from_slice(&m.c[1..]);
        theta.extend_from_slice(&m.d[1..]);
        for f in &m.f {
            theta.extend_from_slice(&f[1..]);
        }
        theta
    }
}
