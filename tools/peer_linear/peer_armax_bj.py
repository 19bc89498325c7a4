#!/usr/bin/env python3
"""Independent peer estimates of ARMAX and Box-Jenkins models, for airsus-ident's PEM.

Companion of ``peer_linear.py`` (ARX and OE); same data sets, splits and detrending (its
``DATASETS`` and ``load`` are reused). For each case it

1. estimates the model with SIPPY (``sippy_unipi.system_identification``, ``id_method``
   ``'ARMAX'`` with ``ARMAX_mod='OPT'`` and ``'BJ'``: prediction-error minimisation with
   CasADi + IPOPT);
2. scores SIPPY's model by airsus' own criterion, computed here independently with
   ``scipy.signal.lfilter``: the one-step prediction errors
   ``eps = D/C (A y - q^-nk B/F u)`` with zero initial conditions over all N samples,
   ``V = mean(eps^2)``, and the NRMSE fits (thesis eq 3.33) of the one-step prediction
   ``y - eps`` and of the simulation ``q^-nk B/(A F) u`` on estimation and validation data;
3. minimises that same criterion a second time with ``scipy.optimize.least_squares``
   (MINPACK ``lmdif``, finite-difference Jacobian) started at SIPPY's estimate, polished by
   Gauss-Newton steps with a central-difference Jacobian: the reference optimum of airsus'
   criterion, with parameter standard deviations ``sqrt(diag(lambda (J'J)^-1))``,
   ``lambda = N V / (N - d)`` (airsus' definitions);
4. records what a broken estimator would score on the same yardstick: the zero model, the
   ARX model of the same ``na nb nk`` (ARMAX) or the reference ``B/F`` with the noise model
   dropped (BJ), and a NumPy re-implementation of airsus' documented starting estimate
   (Hannan-Rissanen / "high-order ARX, then reduce", no iterations).

``crates/ident/tests/peer_armax_bj.rs`` compares airsus' ``armax``/``bj`` against these
numbers.

Usage (from the workspace root):

    python3 -m venv /tmp/peer_venv
    /tmp/peer_venv/bin/pip install sippy-unipi==1.0.1
    /tmp/peer_venv/bin/python tools/peer_linear/peer_armax_bj.py \
        --data crates/ident/tests/data --out crates/ident/tests/fixtures

Conventions (see README.md):

* Delay: SIPPY's ``theta`` is the delay beyond one sample; airsus' ``nk = theta + 1``.
* SIPPY's criterion differs from airsus' only in the start-up: it sets the first
  ``max(nb + theta, na, nc, nd, nf)`` predictions to the measured output (errors zero there)
  and it works on data scaled to unit standard deviation (its ``Vn`` is therefore in scaled
  units and is stored only for the record). All comparisons use airsus' criterion.
* Parameter vectors are in airsus' (MATLAB ``getpvec``) order: a, b, c, d, f.
"""

import argparse
import json
import platform
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter
from sippy_unipi import system_identification

from peer_linear import DATASETS, load, nrmse_fit

# (data set, structure, orders). ARMAX orders [na nb nc nk], BJ orders [nb nc nd nf nk]
# (MATLAB order). Chosen small and well posed: a 30-start random search of airsus' criterion
# (``--random-starts 30``: scipy least_squares from random stable polynomials) found a single
# minimum for each (BJ [2 2 2 2 3] on the dryer has two, 0.16 % apart, so it is not used).
CASES = [
    ("daisy_dryer", "armax", {"na": 2, "nb": 2, "nc": 2, "nk": 3}),
    ("daisy_dryer", "bj", {"nb": 2, "nc": 1, "nd": 1, "nf": 2, "nk": 3}),
    ("cascaded_tanks", "armax", {"na": 2, "nb": 2, "nc": 2, "nk": 1}),
    ("cascaded_tanks", "bj", {"nb": 2, "nc": 1, "nd": 1, "nf": 2, "nk": 1}),
]

MAX_ITERATIONS = 200

# Keys copied from a data set's spec into its fixture.
SPEC_KEYS = ("file", "format", "columns", "ts_s", "estimation", "validation", "detrend", "note")


# --- airsus' criterion, independently --------------------------------------------------


def full_orders(structure, o):
    """(na, nb, nc, nd, nf, nk) of the general structure."""
    if structure == "armax":
        return o["na"], o["nb"], o["nc"], 0, 0, o["nk"]
    return 0, o["nb"], o["nc"], o["nd"], o["nf"], o["nk"]


def names(na, nb, nc, nd, nf):
    return (
        [f"a{k}" for k in range(1, na + 1)]
        + [f"b{k}" for k in range(1, nb + 1)]
        + [f"c{k}" for k in range(1, nc + 1)]
        + [f"d{k}" for k in range(1, nd + 1)]
        + [f"f{k}" for k in range(1, nf + 1)]
    )


def unpack(x, na, nb, nc, nd, nf):
    """Polynomials (a, b, c, d, f) from theta in getpvec order; monic ones with leading 1."""
    x = np.asarray(x, dtype=float)
    i = 0
    a = np.r_[1.0, x[i : i + na]]
    i += na
    b = x[i : i + nb]
    i += nb
    c = np.r_[1.0, x[i : i + nc]]
    i += nc
    d = np.r_[1.0, x[i : i + nd]]
    i += nd
    f = np.r_[1.0, x[i : i + nf]]
    return a, b, c, d, f


def pack(a, b, c, d, f):
    return np.r_[a[1:], b, c[1:], d[1:], f[1:]]


def prediction_errors(y, u, a, b, nk, c, d, f):
    """airsus' one-step prediction errors eps = D/C (A y - q^-nk B/F u), zero initial
    conditions (PolyModel::residuals, the PEM residual vector)."""
    w = lfilter(np.r_[np.zeros(nk), b], f, u)
    v = lfilter(a, [1.0], y) - w
    return lfilter(d, c, v)


def simulation(u, a, b, nk, f):
    """Noise-free simulation q^-nk B/(A F) u, zero initial conditions (PolyModel::simulate)."""
    return lfilter(np.r_[np.zeros(nk), b], np.convolve(a, f), u)


def max_root(p):
    return float(np.max(np.abs(np.roots(p)))) if len(p) > 1 else 0.0


def score(theta, orders, ue, ye, uv, yv):
    """Everything the Rust test compares, for one parameter vector."""
    na, nb, nc, nd, nf, nk = orders
    a, b, c, d, f = unpack(theta, na, nb, nc, nd, nf)
    e_est = prediction_errors(ye, ue, a, b, nk, c, d, f)
    e_val = prediction_errors(yv, uv, a, b, nk, c, d, f)
    return {
        "theta": [float(v) for v in theta],
        "a": [float(v) for v in a],
        "b": [float(v) for v in b],
        "c": [float(v) for v in c],
        "d": [float(v) for v in d],
        "f": [float(v) for v in f],
        "max_root_radius": {"a": max_root(a), "c": max_root(c), "d": max_root(d), "f": max_root(f)},
        "loss": float(np.mean(e_est**2)),
        "fit_percent_estimation_1step": nrmse_fit(ye, ye - e_est),
        "fit_percent_estimation_simulation": nrmse_fit(ye, simulation(ue, a, b, nk, f)),
        "fit_percent_validation_1step": nrmse_fit(yv, yv - e_val),
        "fit_percent_validation_simulation": nrmse_fit(yv, simulation(uv, a, b, nk, f)),
    }


# --- SIPPY ------------------------------------------------------------------------------


def sippy_estimate(structure, o, ue, ye):
    """SIPPY's estimate as a getpvec-ordered theta, and its own (scaled) loss 2 Vn."""
    theta_s = o["nk"] - 1
    if structure == "armax":
        m = system_identification(
            ye,
            ue,
            "ARMAX",
            ARMAX_orders=[o["na"], o["nb"], o["nc"], theta_s],
            ARMAX_mod="OPT",
            max_iterations=MAX_ITERATIONS,
        )
    else:
        m = system_identification(
            ye,
            ue,
            "BJ",
            BJ_orders=[o["nb"], o["nc"], o["nd"], o["nf"], theta_s],
            max_iterations=MAX_ITERATIONS,
        )
    # SISO: [output][input][coefficients]; G = NUM/DEN = B/(A F), H = NUMH/DENH = C/(A D).
    num = np.asarray(m.NUMERATOR[0][0], dtype=float)
    den = np.asarray(m.DENOMINATOR[0][0], dtype=float)
    num_h = np.asarray(m.NUMERATOR_H[0][0], dtype=float)
    den_h = np.asarray(m.DENOMINATOR_H[0][0], dtype=float)
    na, nb, nc, nd, nf, nk = full_orders(structure, o)
    b = num[theta_s : theta_s + nb]
    c = num_h[: nc + 1]
    if structure == "armax":
        a, d, f = den[: na + 1], np.array([1.0]), np.array([1.0])
        # For ARMAX SIPPY's H denominator is A itself.
        assert np.allclose(den_h[: na + 1], a), (den_h, a)
    else:
        a, d, f = np.array([1.0]), den_h[: nd + 1], den[: nf + 1]
    # Nothing beyond the model orders (SIPPY pads with zeros).
    assert not np.any(num[:theta_s]) and not np.any(num[theta_s + nb :])
    assert not np.any(den[len(a) + len(f) - 1 :]) and not np.any(num_h[nc + 1 :])
    return pack(a, b, c, d, f), float(2.0 * m.Vn)


# --- the reference optimum of airsus' criterion --------------------------------------------


def central_jacobian(residuals, x):
    cols = []
    for i in range(len(x)):
        step = np.zeros(len(x))
        step[i] = 1e-6 * max(1.0, abs(x[i]))
        cols.append((residuals(x + step) - residuals(x - step)) / (2.0 * step[i]))
    return np.column_stack(cols)


def reference_optimum(theta0, orders, ue, ye):
    """Minimum of airsus' criterion near theta0: MINPACK Levenberg-Marquardt, then Gauss-Newton
    steps with a central-difference Jacobian while they lower the loss (lmdif's forward
    differences stop short by ~1e-3 std on the slowest case); standard deviations from that
    Jacobian."""
    na, nb, nc, nd, nf, nk = orders

    def residuals(x):
        a, b, c, d, f = unpack(x, na, nb, nc, nd, nf)
        return prediction_errors(ye, ue, a, b, nk, c, d, f)

    r = least_squares(
        residuals, theta0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=20000
    )
    x, rss = r.x, float(np.sum(r.fun**2))
    gauss_newton_steps = 0
    for _ in range(20):
        jac = central_jacobian(residuals, x)
        trial = x + np.linalg.lstsq(jac, -residuals(x), rcond=None)[0]
        trial_rss = float(np.sum(residuals(trial) ** 2))
        if not trial_rss < rss:
            break
        x, rss = trial, trial_rss
        gauss_newton_steps += 1
    a, b, c, d, f = unpack(x, na, nb, nc, nd, nf)
    assert all(max_root(p) < 1.0 for p in (a, c, d, f)), "reference optimum is not stable"
    jac = central_jacobian(residuals, x)
    n, dof = len(ye), len(x)
    cov = rss / (n - dof) * np.linalg.inv(jac.T @ jac)
    info = {
        "minpack_status": int(r.status),
        "minpack_nfev": int(r.nfev),
        "gauss_newton_steps": gauss_newton_steps,
        "gradient_norm": float(np.linalg.norm(jac.T @ residuals(x))),
    }
    return x, [float(s) for s in np.sqrt(np.diag(cov))], info


# --- what a broken estimator would score -----------------------------------------------------


def lagged_lstsq(columns, target, t0):
    """Least squares of target(t) on columns (signal, lag, sign) for t = t0 .. N-1."""
    n = len(target)
    phi = np.column_stack(
        [sign * np.r_[np.zeros(lag), sig[: n - lag]][t0:] for sig, lag, sign in columns]
    )
    theta, *_ = np.linalg.lstsq(phi, target[t0:], rcond=None)
    return theta


def reflect(p):
    """airsus' reflect_into_unit_circle: roots r with |r| > 1 -> 1/conj(r)."""
    if max_root(p) < 1.0:
        return np.asarray(p, dtype=float)
    r = np.roots(p)
    r = np.where(np.abs(r) > 1.0, 1.0 / np.conj(r), r)
    return np.real(np.poly(r)) * p[0]


def high_order(base, n, n_signals):
    """pem.rs high_order()."""
    cap = n // (10 * max(n_signals, 1))
    return min(min(max(2 * base + 4, max(base, 1)), max(20, base)), max(cap, max(base, 1)))


def high_order_arx(y, u, nk, base):
    p = high_order(base, len(y), 2)
    cols = [(y, k, -1.0) for k in range(1, p + 1)] + [(u, nk + j, 1.0) for j in range(p)]
    t0 = max(p, nk + p - 1)
    th = lagged_lstsq(cols, y, t0)
    return reflect(np.r_[1.0, th[:p]]), th[p:], t0


def airsus_like_start(structure, o, ue, ye):
    """NumPy re-implementation of airsus' documented starting estimate (pem.rs initial_armax /
    initial_bj): what armax/bj would return if the search did nothing."""
    na, nb, nc, nd, nf, nk = full_orders(structure, o)
    n = len(ye)
    if structure == "armax":
        max_lag = max(na, nc, nk + nb - 1)
        a_h, b_h, t0h = high_order_arx(ye, ue, nk, max_lag + nc)
        e_hat = lfilter(a_h, [1.0], ye) - lfilter(np.r_[np.zeros(nk), b_h], [1.0], ue)
        e_hat[: min(t0h, n)] = 0.0
        cols = (
            [(ye, k, -1.0) for k in range(1, na + 1)]
            + [(ue, nk + j, 1.0) for j in range(nb)]
            + [(e_hat, k, 1.0) for k in range(1, nc + 1)]
        )
        th = lagged_lstsq(cols, ye, max(max_lag, t0h + nc))
        a, b, c = reflect(np.r_[1.0, th[:na]]), th[na : na + nb], reflect(np.r_[1.0, th[na + nb :]])
        return pack(a, b, c, np.array([1.0]), np.array([1.0]))
    a_h, b_h, _ = high_order_arx(ye, ue, nk, nb + nf)
    w = lfilter(np.r_[np.zeros(nk), b_h], a_h, ue)
    cols = [(w, k, -1.0) for k in range(1, nf + 1)] + [(ue, nk + j, 1.0) for j in range(nb)]
    th = lagged_lstsq(cols, w, max(nf, nk + nb - 1))
    f, b = reflect(np.r_[1.0, th[:nf]]), th[nf:]
    v = ye - lfilter(np.r_[np.zeros(nk), b], f, ue)
    p = high_order(nc + nd, n, 1)
    ar = lagged_lstsq([(v, k, -1.0) for k in range(1, p + 1)], v, p)
    e_hat = lfilter(np.r_[1.0, ar], [1.0], v)
    e_hat[: min(p, n)] = 0.0
    th = lagged_lstsq(
        [(v, k, -1.0) for k in range(1, nd + 1)] + [(e_hat, k, 1.0) for k in range(1, nc + 1)],
        v,
        max(nd, p + nc),
    )
    d, c = reflect(np.r_[1.0, th[:nd]]), reflect(np.r_[1.0, th[nd:]])
    return pack(np.array([1.0]), b, c, d, f)


def baselines(structure, o, orders, ref_theta, ue, ye, uv, yv):
    na, nb, nc, nd, nf, nk = orders
    out = {"zero_model_loss": float(np.mean(ye**2))}
    if structure == "armax":
        cols = [(ye, k, -1.0) for k in range(1, na + 1)] + [(ue, nk + j, 1.0) for j in range(nb)]
        th = lagged_lstsq(cols, ye, max(na, nk + nb - 1))
        arx_theta = np.r_[th, np.zeros(nc)]
        out["arx_same_orders_loss"] = score(arx_theta, orders, ue, ye, uv, yv)["loss"]
    else:
        a, b, c, d, f = unpack(ref_theta, na, nb, nc, nd, nf)
        dropped = pack(a, b, np.r_[1.0, np.zeros(nc)], np.r_[1.0, np.zeros(nd)], f)
        out["noise_model_dropped_loss"] = score(dropped, orders, ue, ye, uv, yv)["loss"]
    start = airsus_like_start(structure, o, ue, ye)
    out["airsus_like_start"] = score(start, orders, ue, ye, uv, yv)
    return out


# --- optional: are there other minima? ---------------------------------------------------------


def random_start_search(orders, ue, ye, starts, seed=1):
    """Minimise airsus' criterion from `starts` random stable starting points; return the
    sorted distinct final losses (rounded to 7 significant digits) with their counts."""
    na, nb, nc, nd, nf, nk = orders
    rng = np.random.default_rng(seed)

    def residuals(x):
        a, b, c, d, f = unpack(x, na, nb, nc, nd, nf)
        if not all(max_root(p) < 1.0 for p in (a, c, d, f)):
            return np.full(len(ye), 1e3)
        return prediction_errors(ye, ue, a, b, nk, c, d, f)

    def monic_tail(n):
        return np.poly(rng.uniform(-0.9, 0.95, n))[1:] if n else np.zeros(0)

    counts = {}
    for _ in range(starts):
        x0 = np.r_[
            monic_tail(na),
            rng.normal(0.0, 0.05, nb),
            monic_tail(nc),
            monic_tail(nd),
            monic_tail(nf),
        ]
        r = least_squares(
            residuals, x0, method="trf", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=5000
        )
        v = float(f"{np.mean(residuals(r.x) ** 2):.7g}")
        counts[v] = counts.get(v, 0) + 1
    return sorted(counts.items())


# --- main ---------------------------------------------------------------------------------------


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--data", type=Path, default=Path("crates/ident/tests/data"))
    parser.add_argument("--out", type=Path, default=Path("crates/ident/tests/fixtures"))
    parser.add_argument("--only", help="comma-separated data set names")
    parser.add_argument(
        "--random-starts",
        type=int,
        default=0,
        metavar="K",
        help="also minimise from K random stable starts per case and print the "
        "distinct minima found (not stored; K=30 adds a few seconds)",
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    only = set(args.only.split(",")) if args.only else None
    specs = {s["name"]: s for s in DATASETS}
    peer = {
        "tool": "sippy-unipi",
        "version": metadata.version("sippy-unipi"),
        "numpy": np.__version__,
        "scipy": metadata.version("scipy"),
        "casadi": metadata.version("casadi"),
        "python": platform.python_version(),
        "armax_function": f"sippy_unipi.system_identification(y, u, 'ARMAX', ARMAX_orders=[na, nb, nc, nk-1], ARMAX_mod='OPT', max_iterations={MAX_ITERATIONS}) (CasADi + IPOPT)",
        "bj_function": f"sippy_unipi.system_identification(y, u, 'BJ', BJ_orders=[nb, nc, nd, nf, nk-1], max_iterations={MAX_ITERATIONS}) (CasADi + IPOPT)",
        "reference_function": "scipy.optimize.least_squares(method='lm', xtol=ftol=gtol=1e-15) of airsus' criterion from SIPPY's estimate, then Gauss-Newton steps with a central-difference Jacobian; std from that Jacobian",
    }
    fixtures = {}
    for name, structure, o in CASES:
        if only and name not in only:
            continue
        spec = specs[name]
        ue, ye, uv, yv = load(args.data, spec)
        orders = full_orders(structure, o)
        theta_sippy, sippy_loss_scaled = sippy_estimate(structure, o, ue, ye)
        sippy = score(theta_sippy, orders, ue, ye, uv, yv)
        sippy["loss_sippy_criterion_scaled_data"] = sippy_loss_scaled
        ref_theta, ref_std, info = reference_optimum(theta_sippy, orders, ue, ye)
        ref = score(ref_theta, orders, ue, ye, uv, yv)
        ref.update({"std": ref_std, **info})
        sippy["distance_to_reference_in_std"] = [
            float(abs(p - q) / s) for p, q, s in zip(theta_sippy, ref_theta, ref_std, strict=True)
        ]
        base = baselines(structure, o, orders, ref_theta, ue, ye, uv, yv)
        start = base["airsus_like_start"]
        start["distance_to_reference_in_std"] = [
            float(abs(p - q) / s)
            for p, q, s in zip(start["theta"], ref_theta, ref_std, strict=True)
        ]
        fx = fixtures.setdefault(
            name,
            {
                "generated_by": "tools/peer_linear/peer_armax_bj.py",
                "dataset": name,
                # the data set as the fixture's reader expects it
                **{key: spec[key] for key in SPEC_KEYS},
                "n_estimation": int(len(ye)),
                "n_validation": int(len(yv)),
                "peer": peer,
                "criterion": "airsus PEM loss V = (1/N) sum_t eps(t)^2 over all N estimation samples, eps = D/C (A y - q^-nk B/F u) with zero initial conditions; fits are NRMSE % (thesis eq 3.33) of y - eps (1-step) and of q^-nk B/(A F) u (simulation)",
            },
        )
        fx[structure] = {
            **o,
            "parameter_names": names(*orders[:5]),
            "sippy": sippy,
            "reference_optimum": ref,
            "baselines": base,
        }
        print(
            f"{name} {structure.upper()} {o}:\n"
            f"  SIPPY     theta={np.round(theta_sippy, 5).tolist()} V={sippy['loss']:.8g} "
            f"fit1={sippy['fit_percent_estimation_1step']:.4f} sim={sippy['fit_percent_estimation_simulation']:.4f} "
            f"val1={sippy['fit_percent_validation_1step']:.4f} valsim={sippy['fit_percent_validation_simulation']:.4f}\n"
            f"  reference theta={np.round(ref_theta, 5).tolist()} V={ref['loss']:.8g} "
            f"fit1={ref['fit_percent_estimation_1step']:.4f} sim={ref['fit_percent_estimation_simulation']:.4f} "
            f"val1={ref['fit_percent_validation_1step']:.4f} valsim={ref['fit_percent_validation_simulation']:.4f} "
            f"std={np.round(ref_std, 5).tolist()}\n"
            f"  SIPPY - reference in std: {np.round(sippy['distance_to_reference_in_std'], 3).tolist()}\n"
            f"  baselines: zero {base['zero_model_loss']:.6g}, "
            + (
                f"ARX {base['arx_same_orders_loss']:.6g}, "
                if structure == "armax"
                else f"noise model dropped {base['noise_model_dropped_loss']:.6g}, "
            )
            + f"airsus-like start {start['loss']:.8g} "
            f"({100 * (start['loss'] / ref['loss'] - 1):.3f} % above the optimum, up to "
            f"{max(start['distance_to_reference_in_std']):.2f} std away)"
        )
        if args.random_starts:
            minima = random_start_search(orders, ue, ye, args.random_starts)
            print(f"  {args.random_starts} random starts: (loss, count) {minima}")
    for name, fx in fixtures.items():
        path = args.out / f"peer_sippy_armax_bj_{name}.json"
        path.write_text(json.dumps(fx, indent=2) + "\n")
        print(f"-> {path}")


if __name__ == "__main__":
    sys.exit(main())
