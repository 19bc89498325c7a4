"""Fleet work per truck: weighing, calibration and leak detection on a truck's own logs.

Each task is one plain function ``pandas.DataFrame -> pandas.DataFrame`` with a fixed schema
(:data:`SCHEMAS`), given all rows of one truck (any number of days): the same function runs
in a local process pool (:func:`run_local`) and on Spark executors
(``python -m airsus.spark``, which groups by ``truck_id`` and applies it). A fleet is the
Parquet dataset ``airsus fleet generate`` writes (or a real fleet's, with the same columns)::

    DIR/truck.toml                          nominal truck file
    DIR/logs/truck_id=K/*.parquet           time_s, day, height_mm, pressure_kpa, valve,
                                            supply_kpa, speed_kmh, ambient_temp_c,
                                            reference_load_kg (null where unknown)

The tasks:

- ``weigh``: every standstill of every day (valve closed and settled, pressure steady, not
  rolling), weighed through the truck's static law from its mean height and pressure, and
  corrected by the truck's calibration when one is given.
- ``calibrate``: the truck's weighing calibration from the standstills where the load is
  known (weighbridge, loading list): ``load = gain * static + offset + hysteresis * z``, with
  ``z`` the wall-friction state (+1 after the bellow rose, -1 after it sank), by least
  squares, with standard deviations.
- ``leaks``: per day, the air in the circuit (``n = p V(h) / (R T)``, which temperature does
  not change) over the parked stretches; a leak is a decay beyond what the measurement
  explains.
"""

from __future__ import annotations

import json
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import pandas as pd

from . import Truck, _native

__all__ = [
    "LEAK_THRESHOLD_PERCENT_PER_H",
    "LOG_COLUMNS",
    "SCHEMAS",
    "TASKS",
    "calibrate_truck",
    "fleet_trucks",
    "leaks_truck",
    "read_truck_logs",
    "run_local",
    "run_task",
    "spark_ddl",
    "weigh_truck",
]

#: A day flags a leak when the circuit loses air faster than this, %/h (and by more than
#: four standard deviations of the estimate). A tight circuit measures within about
#: ±0.02 %/h on the virtual fleet; the virtual leaks start at 0 and grow by 0.05 %/h an hour.
LEAK_THRESHOLD_PERCENT_PER_H = 0.1
#: Parked stretches shorter than this (after dropping their first 10 minutes) are not used, s.
MIN_PARKED_S = 1800.0
#: The first part of a parked stretch is dropped (gas temperature, creep settling), s.
PARKED_SETTLE_S = 600.0

_FLOAT = "float64"
#: Column names and dtypes of each task's result, in order.
SCHEMAS: Dict[str, List[Tuple[str, str]]] = {
    "weigh": [
        ("truck_id", "int64"),
        ("day", "int32"),
        ("start_s", _FLOAT),
        ("end_s", _FLOAT),
        ("samples", "int64"),
        ("height_mm", _FLOAT),
        ("pressure_kpa", _FLOAT),
        ("friction_state", _FLOAT),
        ("static_load_kg", _FLOAT),
        ("wheel_load_kg", _FLOAT),
        ("wheel_load_std_kg", _FLOAT),
        ("reference_load_kg", _FLOAT),
        ("calibrated", "bool"),
    ],
    "calibrate": [
        ("truck_id", "int64"),
        ("method", "string"),
        ("gain", _FLOAT),
        ("gain_std", _FLOAT),
        ("offset_kg", _FLOAT),
        ("offset_std_kg", _FLOAT),
        ("hysteresis_kg", _FLOAT),
        ("hysteresis_std_kg", _FLOAT),
        ("height_kg_per_mm", _FLOAT),
        ("height_std_kg_per_mm", _FLOAT),
        ("sigma_kg", _FLOAT),
        ("residual_rms_kg", _FLOAT),
        ("references", "int64"),
        ("cov_json", "string"),
    ],
    "leaks": [
        ("truck_id", "int64"),
        ("day", "int32"),
        ("leak", "bool"),
        ("decay_percent_per_h", _FLOAT),
        ("decay_std_percent_per_h", _FLOAT),
        ("pressure_decay_percent_per_h", _FLOAT),
        ("temperature_percent_per_h", _FLOAT),
        ("parked_h", _FLOAT),
        ("stretches", "int64"),
        ("evidence", "string"),
    ],
}
TASKS: Tuple[str, ...] = tuple(SCHEMAS)

_SPARK_TYPES = {
    "int64": "bigint",
    "int32": "int",
    _FLOAT: "double",
    "bool": "boolean",
    "string": "string",
}


def spark_ddl(task: str) -> str:
    """The task's result schema as a Spark DDL string (``"truck_id bigint, day int, ..."``)."""
    return ", ".join(f"{name} {_SPARK_TYPES[dtype]}" for name, dtype in _schema(task))


def _schema(task: str) -> List[Tuple[str, str]]:
    if task not in SCHEMAS:
        raise ValueError(f"unknown task {task!r}; the tasks are: {', '.join(TASKS)}")
    return SCHEMAS[task]


def _frame(task: str, rows: Mapping[str, Sequence[Any]]) -> pd.DataFrame:
    """A result frame with exactly the task's columns and dtypes."""
    return pd.DataFrame(
        {name: pd.Series(rows.get(name, []), dtype=dtype) for name, dtype in _schema(task)}
    )


def _truck_id(pdf: pd.DataFrame) -> int:
    if "truck_id" not in pdf.columns or pdf.empty:
        raise ValueError("a truck's rows need a truck_id column (the dataset's partition)")
    ids = pd.unique(pdf["truck_id"])
    if len(ids) != 1:
        raise ValueError(f"the rows hold {len(ids)} trucks; a task takes one truck at a time")
    return int(ids[0])


_REQUIRED = ("time_s", "day", "height_mm", "pressure_kpa", "valve")
#: Every log column a task reads (the rest, e.g. ``supply_kpa``, is not needed).
LOG_COLUMNS = _REQUIRED + ("speed_kmh", "ambient_temp_c", "reference_load_kg")


def _days(pdf: pd.DataFrame) -> List[Tuple[int, pd.DataFrame]]:
    missing = [c for c in _REQUIRED if c not in pdf.columns]
    if missing:
        raise ValueError(
            f"the log lacks column(s) {', '.join(missing)}; a fleet log has "
            "time_s, day, height_mm, pressure_kpa, valve (and speed_kmh, ambient_temp_c, "
            "reference_load_kg)"
        )
    return [
        (int(day), rows.sort_values("time_s", kind="stable"))
        for day, rows in pdf.groupby("day", sort=True)
    ]


def _as_truck(truck: Any) -> Truck:
    if isinstance(truck, Truck):
        return truck
    if isinstance(truck, str) and "\n" in truck:
        return Truck.from_toml(truck)
    return Truck.load(truck)


def _f64(values: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(values, dtype=np.float64))


def _calibration_of(calibration: Any, truck_id: int) -> Optional[Mapping[str, Any]]:
    """The calibration row of `truck_id` from a calibrate result (frame or dict by id)."""
    if calibration is None:
        return None
    if isinstance(calibration, pd.DataFrame):
        rows = calibration[calibration["truck_id"] == truck_id]
        return None if rows.empty else rows.iloc[0].to_dict()
    return calibration.get(truck_id)


def _calibrated(
    static: Any, friction: Any, height_mm: Any, cal: Mapping[str, Any]
) -> Tuple[np.ndarray, np.ndarray]:
    """Calibrated loads and their predictive standard deviation (the coefficients' covariance
    and the residual spread)."""
    x = _design(static, friction, height_mm)
    beta = np.array([cal["gain"], cal["offset_kg"], cal["hysteresis_kg"], cal["height_kg_per_mm"]])
    cov = np.array(json.loads(cal["cov_json"]), dtype=np.float64)
    prediction_var = np.einsum("ij,jk,ik->i", x, cov, x)
    return x @ beta, np.sqrt(prediction_var + float(cal["sigma_kg"]) ** 2)


def weigh_truck(
    pdf: pd.DataFrame, truck: Any, calibration: Any = None, *, settle_s: float = 120.0
) -> pd.DataFrame:
    """Weigh every standstill in one truck's logs (schema ``SCHEMAS["weigh"]``).

    Args:
        pdf: all rows of one truck (a ``truck_id`` column, any number of days).
        truck: a :class:`~airsus.Truck`, a truck file path or truck-file text.
        calibration: the ``calibrate`` result (a frame with this truck's row, or a dict by
            truck id); without one, the static law's load and uncertainty are reported.
        settle_s: how long the valve must have been closed before a sample counts.
    """
    truck_id = _truck_id(pdf)
    law = _as_truck(truck)
    cal = _calibration_of(calibration, truck_id)
    parts: Dict[str, List[Any]] = {name: [] for name, _ in _schema("weigh")}
    for day, rows in _days(pdf):
        speed = rows["speed_kmh"] if "speed_kmh" in rows.columns else None
        known = _f64(rows["reference_load_kg"]) if "reference_load_kg" in rows.columns else None
        # Where a known load starts or ends, a standstill ends: the known part is weighed alone.
        segment = None if known is None else _f64(np.isfinite(known))
        found = _native.standstills(
            law._native,
            _f64(rows["time_s"]),
            _f64(rows["height_mm"]),
            _f64(rows["pressure_kpa"]),
            _f64(rows["valve"]),
            None if speed is None else _f64(speed),
            segment,
            settle_s=float(settle_s),
        )
        count = len(found["start_s"])
        first = found["first"].astype(np.int64)
        last = found["last"].astype(np.int64)
        if known is not None and count:
            reference = np.array(
                [_known_load(known[a : b + 1]) for a, b in zip(first, last)], dtype=np.float64
            )
        else:
            reference = np.full(count, np.nan)
        static = found["static_load_kg"]
        if cal is not None:
            load, cal_std = _calibrated(static, found["friction_state"], found["height_mm"], cal)
            std = np.hypot(found["measurement_std_kg"], cal_std)
        else:
            load = static
            std = np.hypot(found["measurement_std_kg"], found["parameter_std_kg"])
        parts["truck_id"] += [truck_id] * count
        parts["day"] += [day] * count
        for name in ("start_s", "end_s", "height_mm", "pressure_kpa", "friction_state"):
            parts[name] += list(found[name])
        parts["samples"] += list(last - first + 1)
        parts["static_load_kg"] += list(static)
        parts["wheel_load_kg"] += list(load)
        parts["wheel_load_std_kg"] += list(std)
        parts["reference_load_kg"] += list(reference)
        parts["calibrated"] += [cal is not None] * count
    return _frame("weigh", parts)


def _known_load(known: np.ndarray) -> float:
    """The known load over a standstill: the mean where at least 30 % of it is known."""
    present = known[np.isfinite(known)]
    if len(present) < 0.3 * len(known) or len(present) == 0:
        return float("nan")
    return float(present.mean())


#: The calibration's prior: what is known of each coefficient before any reference load.
#: Gain and offset: the nominal static law is right within 20 % and 300 kg; hysteresis: the
#: wall friction shifts a reading by up to about 60 kg; height: the effective area's slope
#: over height is uncertain by about 5 kg per mm of ride height. The references decide what
#: they can; the rest stays at the prior, with its uncertainty in every prediction.
CALIBRATION_PRIOR_MEAN = np.array([1.0, 0.0, 0.0, 0.0])
CALIBRATION_PRIOR_STD = np.array([0.2, 300.0, 60.0, 5.0])
#: Ride height the height coefficient is counted from, mm.
CALIBRATION_HEIGHT_REF_MM = 235.0
#: The residual standard deviation is never taken below this, kg: a handful of references
#: can fit closer than the sensors and the friction allow.
CALIBRATION_MIN_SIGMA_KG = 1.0


def _design(static: Any, friction: Any, height_mm: Any) -> np.ndarray:
    static = np.asarray(static, dtype=np.float64)
    return np.column_stack(
        [
            static,
            np.ones_like(static),
            np.asarray(friction, dtype=np.float64),
            np.asarray(height_mm, dtype=np.float64) - CALIBRATION_HEIGHT_REF_MM,
        ]
    )


def calibrate_truck(pdf: pd.DataFrame, truck: Any, *, settle_s: float = 120.0) -> pd.DataFrame:
    """One truck's weighing calibration from its standstills with a known load (schema
    ``SCHEMAS["calibrate"]``)::

        load = gain * static + offset + hysteresis * z + height * (h - 235 mm)

    ``static`` is the static law's load with the truck file's parameters, ``z`` the wall
    friction state (+1 after the bellow rose, -1 after it sank) and ``h`` the ride height. It
    is Bayesian linear regression: the prior :data:`CALIBRATION_PRIOR_STD` around the nominal
    law (gain 1, nothing else), the residual standard deviation estimated from the references
    (at least :data:`CALIBRATION_MIN_SIGMA_KG`), the posterior's standard deviations and
    covariance reported. ``method`` is ``references`` when the truck had known loads, ``prior``
    when it had none (the nominal law, with the prior's uncertainty)."""
    truck_id = _truck_id(pdf)
    standstills = weigh_truck(pdf, _as_truck(truck), settle_s=settle_s)
    known = standstills[np.isfinite(standstills["reference_load_kg"])]
    y = known["reference_load_kg"].to_numpy()
    x = _design(known["static_load_kg"], known["friction_state"], known["height_mm"])
    prior_precision = np.diag(1.0 / CALIBRATION_PRIOR_STD**2)
    sigma = CALIBRATION_MIN_SIGMA_KG
    beta = CALIBRATION_PRIOR_MEAN.copy()
    cov = np.linalg.inv(prior_precision)
    for _ in range(20):  # the residual variance and the coefficients, to a fixed point
        if len(y) == 0:
            break
        precision = x.T @ x / sigma**2 + prior_precision
        cov = np.linalg.inv(precision)
        beta = cov @ (x.T @ y / sigma**2 + prior_precision @ CALIBRATION_PRIOR_MEAN)
        residual = y - x @ beta
        # Degrees of freedom: the references less what the data (not the prior) determined.
        used = float(np.trace(x.T @ x / sigma**2 @ cov))
        new_sigma = max(
            float(np.sqrt(residual @ residual / max(len(y) - used, 1.0))),
            CALIBRATION_MIN_SIGMA_KG,
        )
        if abs(new_sigma - sigma) < 1e-6 * sigma:
            break
        sigma = new_sigma
    rms = float(np.sqrt(np.mean((y - x @ beta) ** 2))) if len(y) else 0.0
    std = np.sqrt(np.diag(cov))
    row = {
        "truck_id": [truck_id],
        "method": ["references" if len(y) else "prior"],
        "gain": [beta[0]],
        "gain_std": [std[0]],
        "offset_kg": [beta[1]],
        "offset_std_kg": [std[1]],
        "hysteresis_kg": [beta[2]],
        "hysteresis_std_kg": [std[2]],
        "height_kg_per_mm": [beta[3]],
        "height_std_kg_per_mm": [std[3]],
        "sigma_kg": [sigma],
        "residual_rms_kg": [rms],
        "references": [len(y)],
        "cov_json": [json.dumps(cov.tolist())],
    }
    return _frame("calibrate", row)


def _minute_means(minute: np.ndarray, span: slice, values: np.ndarray) -> np.ndarray:
    """Means of ``values[span]`` per minute index (minutes without samples left out)."""
    count = np.bincount(minute)
    keep = count > 0
    return _f64(np.bincount(minute, weights=values[span])[keep] / count[keep])


def _stretches(closed: np.ndarray, still: np.ndarray) -> List[Tuple[int, int]]:
    """Maximal runs [a, b) of samples where the valve is closed and the truck stands."""
    ok = (closed & still).astype(np.int8)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok, [0]])))
    return list(zip(edges[0::2], edges[1::2]))


def leaks_truck(pdf: pd.DataFrame, truck: Any) -> pd.DataFrame:
    """Per day, whether one truck's air circuit leaks (schema ``SCHEMAS["leaks"]``).

    Over each parked stretch (valve closed, not rolling, at least 30 min after its first
    10 min), the air in the circuit ``n = p_abs V(h_b) / (R T)`` is computed from one-minute
    means of height, pressure and ambient temperature, and ``ln n`` fitted by a line in time.
    A tight circuit keeps ``n``: a colder night lowers the pressure and the height, not the
    air. A day leaks when a stretch's decay exceeds :data:`LEAK_THRESHOLD_PERCENT_PER_H` and
    four of its standard deviations; the reported decay is the stretch with the strongest
    evidence, and ``evidence`` lists every stretch.
    ``pressure_decay_percent_per_h`` is the same fit without the temperature (``p V``), and
    ``temperature_percent_per_h`` what the temperature alone changed, so the evidence shows
    what the temperature explains."""
    truck_id = _truck_id(pdf)
    law = _as_truck(truck)
    out: Dict[str, List[Any]] = {name: [] for name, _ in _schema("leaks")}
    for day, rows in _days(pdf):
        t = _f64(rows["time_s"])
        closed = rows["valve"].to_numpy() == 0
        still = (
            np.abs(_f64(rows["speed_kmh"])) <= 0.5
            if "speed_kmh" in rows.columns
            else np.ones(len(rows), dtype=bool)
        )
        temp_k = (
            _f64(rows["ambient_temp_c"]) + 273.15
            if "ambient_temp_c" in rows.columns
            else np.full(len(rows), np.nan)
        )
        stretches = []  # (decay, std, pressure decay, temperature part, hours), %/h
        for a, b in _stretches(closed, still):
            start = np.searchsorted(t[a:b], t[a] + PARKED_SETTLE_S) + a
            if b <= start or t[b - 1] - t[start] < MIN_PARKED_S:
                continue
            minute = ((t[start:b] - t[start]) // 60.0).astype(np.int64)
            means = partial(_minute_means, minute, slice(start, b))
            tm, h, p = means(t), means(_f64(rows["height_mm"])), means(_f64(rows["pressure_kpa"]))
            temp = means(temp_k)
            if not np.all(np.isfinite(temp)):
                temp = np.full_like(h, 293.15)
            n = _native.gas_amount_mol(law._native, h, p, temp)
            ok = np.isfinite(n) & (n > 0)
            if ok.sum() < 10:
                continue
            hours_x = (tm[ok] - tm[ok].mean()) / 3600.0
            slope, var = _slope(hours_x, np.log(n[ok]))
            pv_slope = _slope(hours_x, np.log(n[ok] * temp[ok]))[0]  # p V: no temperature
            t_slope = _slope(hours_x, np.log(temp[ok]))[0]
            span_h = (tm[ok][-1] - tm[ok][0]) / 3600.0
            stretches.append(
                (-100 * slope, 100 * np.sqrt(var), -100 * pv_slope, 100 * t_slope, span_h)
            )
        if stretches:
            # A leak grows: the day is judged by its strongest evidence, any stretch.
            decay, decay_std, p_decay, t_part, _ = max(stretches, key=lambda s: s[0] / s[1])
            leak = any(s[0] > LEAK_THRESHOLD_PERCENT_PER_H and s[0] > 4.0 * s[1] for s in stretches)
            hours = float(sum(s[4] for s in stretches))
            evidence = "; ".join(
                f"parked {s[4]:.1f} h: air falls {s[0]:.3f} ± {s[1]:.3f} %/h (p·V falls "
                f"{s[2]:.3f} %/h, the temperature explains {-s[3]:.3f})"
                for s in stretches
            )
        else:
            decay = decay_std = p_decay = t_part = float("nan")
            leak, hours = False, 0.0
            evidence = "no parked stretch of 40 min or more with the valve closed"
        out["truck_id"].append(truck_id)
        out["day"].append(day)
        out["leak"].append(bool(leak))
        out["decay_percent_per_h"].append(decay)
        out["decay_std_percent_per_h"].append(decay_std)
        out["pressure_decay_percent_per_h"].append(p_decay)
        out["temperature_percent_per_h"].append(t_part)
        out["parked_h"].append(hours)
        out["stretches"].append(len(stretches))
        out["evidence"].append(evidence)
    return _frame("leaks", out)


def _slope(x: np.ndarray, y: np.ndarray) -> Tuple[float, float]:
    """Least-squares slope of y on centred x, and its variance from the residuals. One-minute
    means are not independent (drift, slow temperature lag): the variance is inflated by the
    residuals' lag-1 autocorrelation (effective sample size)."""
    sxx = float(x @ x)
    slope = float(x @ (y - y.mean())) / sxx
    residual = y - y.mean() - slope * x
    n = len(x)
    s2 = float(residual @ residual) / max(n - 2, 1)
    r1 = 0.0
    if n > 3 and residual.std() > 0:
        r1 = float(np.corrcoef(residual[:-1], residual[1:])[0, 1])
    inflation = (1 + max(r1, 0.0)) / (1 - min(max(r1, 0.0), 0.95))
    return slope, s2 / sxx * inflation


def run_task(task: str, pdf: pd.DataFrame, truck: Any, calibration: Any = None) -> pd.DataFrame:
    """One truck's rows through a task's function: the one place that knows which task takes
    what (``weigh`` alone takes the calibration). The process pool and Spark both call it."""
    _schema(task)
    if task == "weigh":
        return weigh_truck(pdf, truck, calibration)
    if task == "calibrate":
        return calibrate_truck(pdf, truck)
    return leaks_truck(pdf, truck)


def fleet_trucks(fleet: str) -> List[Tuple[int, str]]:
    """``(truck_id, folder)`` of every truck in a fleet's ``logs/``, by id."""
    logs = os.path.join(fleet, "logs")
    if not os.path.isdir(logs):
        raise ValueError(f"{fleet} holds no fleet: {logs} is not a folder")
    trucks = []
    for name in os.listdir(logs):
        if name.startswith("truck_id="):
            try:
                trucks.append((int(name.split("=", 1)[1]), os.path.join(logs, name)))
            except ValueError:
                raise ValueError(f"{os.path.join(logs, name)}: truck_id is not a number") from None
    if not trucks:
        raise ValueError(f"{logs} has no truck_id=K folders")
    return sorted(trucks)


def read_truck_logs(folder: str, truck_id: int) -> pd.DataFrame:
    """All days of one truck's logs as one frame, with its ``truck_id``."""
    files = sorted(f for f in os.listdir(folder) if f.endswith(".parquet"))
    if not files:
        raise ValueError(f"{folder} holds no .parquet files")
    frame = pd.concat([pd.read_parquet(os.path.join(folder, f)) for f in files], ignore_index=True)
    frame["truck_id"] = np.int64(truck_id)
    return frame


def read_fleet_truck(fleet: str) -> str:
    """The fleet's nominal truck-file text (``DIR/truck.toml``)."""
    path = os.path.join(fleet, "truck.toml")
    if not os.path.isfile(path):
        raise ValueError(f"{fleet} has no truck.toml (the nominal truck file)")
    with open(path, encoding="utf-8") as f:
        return f.read()


def _one_truck(task: str, truck_text: str, calibration: Any, item: Tuple[int, str]) -> pd.DataFrame:
    truck_id, folder = item
    return run_task(task, read_truck_logs(folder, truck_id), truck_text, calibration)


def fleet_inputs(fleet: str, calibration: Any = None) -> List[Any]:
    """What a task reads: the fleet's logs and truck file, and a calibration path if any
    (results may go beside them, e.g. ``FLEET/results``, never into or over them)."""
    return [os.path.join(fleet, "logs"), os.path.join(fleet, "truck.toml"), calibration]


def refuse_output_over_inputs(target: str, inputs: Sequence[Any]) -> None:
    """Refuses an output that is, holds or lies inside an input folder or file (the fleet,
    a calibration): writing there would overwrite it or add files its next read would take
    for logs. Remote paths (``scheme://``) are compared as written."""

    def norm(p: str) -> str:
        return p.rstrip("/") if "://" in p else os.path.realpath(p)

    out = norm(target)
    for item in inputs:
        if not isinstance(item, str):
            continue
        source = norm(item)
        try:
            shared = os.path.commonpath([out, source])
        except ValueError:  # different drives or a mix of absolute and relative paths
            continue
        if shared in (out, source):
            raise ValueError(
                f"the output {target} overlaps the input {item}; choose an output folder "
                "outside the fleet and the calibration"
            )


def write_result(frame: pd.DataFrame, path: str) -> None:
    """Writes a result as one Parquet file, atomically (a temporary file, then a rename)."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".parquet.tmp")
    os.close(fd)
    try:
        frame.to_parquet(tmp, index=False)
        # mkstemp makes the file private (0600): give it the permissions of a new file.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def run_local(
    task: str,
    fleet: str,
    out: Optional[str] = None,
    *,
    processes: Optional[int] = None,
    calibration: Any = None,
) -> pd.DataFrame:
    """Runs a task over every truck of a fleet in a local process pool (no Spark).

    Returns the result (all trucks, sorted) and, with ``out``, writes it as
    ``out/<task>.parquet``. ``calibration``: a calibrate result (frame or Parquet path) for
    ``weigh``. ``processes=1`` runs in this process."""
    _schema(task)
    if out is not None:
        refuse_output_over_inputs(
            os.path.join(out, f"{task}.parquet"), fleet_inputs(fleet, calibration)
        )
    trucks = fleet_trucks(fleet)
    truck_text = read_fleet_truck(fleet)
    if isinstance(calibration, str):
        calibration = pd.read_parquet(calibration)
    work = partial(_one_truck, task, truck_text, calibration)
    if processes == 1:
        parts = [work(item) for item in trucks]
    else:
        with ProcessPoolExecutor(max_workers=processes) as pool:
            parts = list(pool.map(work, trucks))
    result = sort_result(task, pd.concat(parts, ignore_index=True))
    if out is not None:
        write_result(result, os.path.join(out, f"{task}.parquet"))
    return result


def sort_result(task: str, frame: pd.DataFrame) -> pd.DataFrame:
    """A result in its canonical order (by truck, then day and time), with the schema's
    dtypes: what the local pool and Spark both return."""
    keys = [k for k in ("truck_id", "day", "start_s") if k in frame.columns]
    frame = frame.sort_values(keys, kind="stable").reset_index(drop=True)
    return _frame(task, {name: frame[name].tolist() for name, _ in _schema(task)})
