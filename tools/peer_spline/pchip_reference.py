"""Reference values of the monotone cubic (PCHIP) for `crates/data/tests/pchip_peer.rs`.

SciPy's `PchipInterpolator` (Fritsch–Butland slopes, shape-preserving one-sided end slopes)
is the independent implementation `airsus_data::laws::MonotoneSpline` is checked against:
its value, first derivative and integral from the first knot, at points inside the knots.

    python3 -m venv /tmp/peer && /tmp/peer/bin/pip install scipy
    /tmp/peer/bin/python tools/peer_spline/pchip_reference.py

writes `crates/data/tests/fixtures/pchip_knots.csv` and `pchip_scipy.csv`.
"""

import argparse
import csv
from pathlib import Path

import numpy as np
import scipy
from scipy.interpolate import PchipInterpolator

# Knot sets: a rolling-lobe effective area (m, m²), a step-like rise, a peak and a valley
# (local extrema among the knots), uneven spacing, and the fewest knots (2 and 3).
CASES = {
    "lobe": (
        [0.22, 0.24, 0.26, 0.28, 0.30, 0.32, 0.34, 0.36, 0.38, 0.40],
        [0.0561, 0.0558, 0.0553, 0.0546, 0.0538, 0.0522, 0.0502, 0.0483, 0.0463, 0.0444],
    ),
    "step": ([0.0, 1.0, 2.0, 3.0, 4.0, 5.0], [0.0, 0.0, 0.1, 1.9, 2.0, 2.0]),
    "peak": ([0.0, 0.3, 0.5, 1.2, 1.3, 2.0], [1.0, 2.5, 2.0, -1.0, 0.5, 0.4]),
    "uneven": ([0.1, 0.11, 0.2, 0.5, 0.52, 0.9], [3.0, 2.0, 1.5, 1.4, 0.2, 0.1]),
    "two": ([0.2, 0.4], [0.05, 0.06]),
    "three": ([0.2, 0.25, 0.4], [0.05, 0.06, 0.055]),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("crates/data/tests/fixtures"))
    out = parser.parse_args().out
    with open(out / "pchip_knots.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "x", "y"])
        for name, (xs, ys) in CASES.items():
            for x, y in zip(xs, ys, strict=True):
                w.writerow([name, repr(x), repr(y)])
    with open(out / "pchip_scipy.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "x", "value", "derivative", "integral_from_first_knot"])
        for name, (xs, ys) in CASES.items():
            p = PchipInterpolator(xs, ys)
            dp = p.derivative()
            for x in np.linspace(xs[0], xs[-1], 41)[1:-1]:
                integral = p.integrate(xs[0], x)
                w.writerow(
                    [
                        name,
                        repr(float(x)),
                        repr(float(p(x))),
                        repr(float(dp(x))),
                        repr(float(integral)),
                    ]
                )
    print(f"scipy {scipy.__version__}, numpy {np.__version__}: wrote {out}")


if __name__ == "__main__":
    main()
