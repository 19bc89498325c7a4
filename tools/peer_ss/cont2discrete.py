#!/usr/bin/env python3
"""Independent reference for airsus-ident's zero-order-hold c2d / d2c on multi-state systems.

For a few continuous-time multi-input, multi-output systems this computes the ZOH
discretisation with SciPy (``scipy.signal.cont2discrete(..., method="zoh")``, which uses
``scipy.linalg.expm``, Al-Mohy & Higham's scaling-and-squaring Padé) and, for the way back,
the principal matrix logarithm of the augmented matrix ``[Ad Bd; 0 I]`` with
``scipy.linalg.logm`` (SciPy has no d2c). It writes everything as one JSON fixture that
``crates/ident/tests/c2d_peer.rs`` checks airsus' ``StateSpace::c2d`` / ``StateSpace::d2c``
against.

Usage (from the workspace root):

    python3 -m venv /tmp/peer_venv
    /tmp/peer_venv/bin/pip install numpy scipy
    /tmp/peer_venv/bin/python tools/peer_ss/cont2discrete.py \
        --out crates/ident/tests/fixtures/peer_scipy_c2d.json

Matrices are stored row-major as lists of rows; numbers are written with Python's shortest
round-trip representation, so the fixture holds SciPy's doubles exactly.
"""

import argparse
import json
import platform
import re
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
from scipy.linalg import expm, logm
from scipy.signal import cont2discrete


def oscillator_3x2x2():
    """3 states, 2 inputs, 2 outputs; a lightly damped complex pair (about -0.3 +- 2.5j)
    coupled to a real pole, with a non-zero feedthrough. Ts = 0.1 s."""
    a = np.array(
        [
            [-0.3, 2.5, 0.0],
            [-2.5, -0.3, 0.4],
            [0.2, 0.0, -1.5],
        ]
    )
    b = np.array(
        [
            [1.0, 0.0],
            [0.0, 0.5],
            [0.3, -1.2],
        ]
    )
    c = np.array(
        [
            [1.0, 0.0, 0.5],
            [0.0, 2.0, -1.0],
        ]
    )
    d = np.array(
        [
            [0.0, 0.1],
            [0.05, 0.0],
        ]
    )
    return a, b, c, d, 0.1


def quarter_car_4x2x2():
    """Quarter car of a heavy truck's air-suspended axle: states (body position zs, body
    velocity, axle position zu, axle velocity); inputs (road height zr in m, actuator force
    in kN); outputs (suspension deflection zs - zu, tyre deflection zu - zr, which feeds the
    road input through D). Body mode about 1.2 Hz, wheel hop about 11 Hz: two complex pairs
    whose decay rates differ by a factor of ~8 and input columns whose scales differ by ~3000. Ts = 0.01 s (the thesis' sensors sample at 0.1 s; the control loop runs
    faster)."""
    ms, mu = 4500.0, 700.0  # sprung and unsprung mass per corner, kg
    ks, cs = 2.6e5, 2.0e4  # air spring stiffness N/m, damper N s/m
    kt = 3.2e6  # tyre stiffness N/m
    a = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-ks / ms, -cs / ms, ks / ms, cs / ms],
            [0.0, 0.0, 0.0, 1.0],
            [ks / mu, cs / mu, -(ks + kt) / mu, -cs / mu],
        ]
    )
    b = np.array(
        [
            [0.0, 0.0],
            [0.0, 1e3 / ms],
            [0.0, 0.0],
            [kt / mu, -1e3 / mu],
        ]
    )
    c = np.array(
        [
            [1.0, 0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )
    d = np.array(
        [
            [0.0, 0.0],
            [-1.0, 0.0],
        ]
    )
    return a, b, c, d, 0.01


def stiff_4x1x2():
    """4 states, 1 input, 2 outputs; real poles -0.05, -1, -8, -40 (stiffness ratio 800) made
    dense and non-normal by a fixed similarity transform. Ts = 0.05 s, so the fastest discrete
    pole is exp(-2) = 0.135 (positive: d2c is defined)."""
    lam = np.diag([-0.05, -1.0, -8.0, -40.0])
    # Upper coupling makes the block non-normal; T is a fixed, well-conditioned matrix.
    lam[0, 1], lam[1, 2], lam[2, 3] = 0.7, 3.0, 12.0
    t = np.array(
        [
            [1.0, 0.2, -0.3, 0.1],
            [0.0, 1.0, 0.4, -0.2],
            [0.5, -0.1, 1.0, 0.3],
            [0.2, 0.3, 0.0, 1.0],
        ]
    )
    a = t @ lam @ np.linalg.inv(t)
    b = np.array([[1.0], [-0.5], [2.0], [0.25]])
    c = np.array(
        [
            [1.0, 0.0, 0.0, 1.0],
            [0.0, 1.0, -1.0, 0.0],
        ]
    )
    d = np.array([[0.0], [0.2]])
    return a, b, c, d, 0.05


SYSTEMS = [
    ("oscillator_3x2x2", oscillator_3x2x2),
    ("quarter_car_4x2x2", quarter_car_4x2x2),
    ("stiff_4x1x2", stiff_4x1x2),
]


def rows(m):
    return [[float(v) for v in row] for row in np.atleast_2d(m)]


def rel_err(x, ref):
    return float(np.max(np.abs(x - ref)) / np.max(np.abs(ref)))


def entry(name, build):
    a, b, c, d, ts = build()
    n, m = b.shape
    ad, bd, cd, dd, dt = cont2discrete((a, b, c, d), ts, method="zoh")
    assert dt == ts
    # Cross-check SciPy's own result against expm of the augmented matrix (the definition).
    aug = np.zeros((n + m, n + m))
    aug[:n, :n], aug[:n, n:] = a * ts, b * ts
    e = expm(aug)
    check_c2d = max(rel_err(e[:n, :n], ad), rel_err(e[:n, n:], bd))
    # d2c reference: principal logarithm of [Ad Bd; 0 I], divided by Ts.
    disc = np.eye(n + m)
    disc[:n, :n], disc[:n, n:] = ad, bd
    lg = logm(disc)
    if np.iscomplexobj(lg):
        assert np.max(np.abs(lg.imag)) < 1e-12, "logm has an imaginary part"
        lg = lg.real
    lg = lg / ts
    a_back, b_back = lg[:n, :n], lg[:n, n:]
    poles_c = np.linalg.eigvals(a)
    poles_d = np.linalg.eigvals(ad)
    result = {
        "name": name,
        "doc": build.__doc__.strip().replace("\n    ", " ").replace("\n", " "),
        "ts_s": ts,
        "continuous": {"a": rows(a), "b": rows(b), "c": rows(c), "d": rows(d)},
        "discrete_scipy_zoh": {"a": rows(ad), "b": rows(bd), "c": rows(cd), "d": rows(dd)},
        "d2c_scipy_logm": {"a": rows(a_back), "b": rows(b_back)},
        "continuous_poles": [[float(p.real), float(p.imag)] for p in poles_c],
        "discrete_poles": [[float(p.real), float(p.imag)] for p in poles_d],
        "checks": {
            "cont2discrete_vs_expm_max_rel": check_c2d,
            "logm_round_trip_a_max_rel": rel_err(a_back, a),
            "logm_round_trip_b_max_rel": rel_err(b_back, b),
        },
    }
    print(
        f"{name}: n={n} m={m} p={c.shape[0]} Ts={ts}; |poles_d| = "
        f"{np.round(np.abs(poles_d), 6).tolist()}; checks {result['checks']}"
    )
    return result


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out", type=Path, default=Path("crates/ident/tests/fixtures/peer_scipy_c2d.json")
    )
    args = parser.parse_args()
    fixture = {
        "generated_by": "tools/peer_ss/cont2discrete.py",
        "peer": {
            "c2d": "scipy.signal.cont2discrete(method='zoh') (scipy.linalg.expm of [A B; 0 0] Ts)",
            "d2c": "scipy.linalg.logm([Ad Bd; 0 I]) / Ts",
            "scipy": metadata.version("scipy"),
            "numpy": np.__version__,
            "python": platform.python_version(),
        },
        "layout": "matrices row-major, as lists of rows",
        "systems": [entry(name, build) for name, build in SYSTEMS],
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(fixture, indent=2)
    # One matrix row (a list of plain numbers) per line.
    text = re.sub(
        r"\[\s+([-0-9.e+]+(?:,\s+[-0-9.e+]+)*)\s+\]",
        lambda mt: "[" + re.sub(r",\s+", ", ", mt.group(1)) + "]",
        text,
    )
    args.out.write_text(text + "\n")
    print(f"-> {args.out}")


if __name__ == "__main__":
    sys.exit(main())
