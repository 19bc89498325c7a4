"""airsus: model, identify and validate truck air suspensions, from Python.

The whole airsus library with numpy and pandas: plain functions, data first, like the
``airsus`` command and its data contract. Every function calls the same Rust library
functions, with the same defaults, as the matching command, so results are identical to the
command's for the same inputs.

Runs are pandas DataFrames (or dicts of arrays) with the contract's columns in the file's
units (``time_s, wheel_load_kg, valve, supply_kpa, road_mm, height_mm, pressure_kpa``), or
paths of run files. Trucks are :class:`Truck` objects or paths of truck files. Anything airsus
rejects raises :class:`AirsusError` (a ``ValueError``) with the command's message, which names
file, line and column for malformed inputs.

Quick start::

    import airsus
    ref = airsus.generate("ref", seed=1)                  # the virtual truck's experiments
    ds1 = airsus.read_run("ref/ds1.csv")                  # a pandas DataFrame
    truck = airsus.Truck.load("ref/truck.toml")
    sim = airsus.simulate("m2", truck, ds1)               # time_s, height_mm, pressure_kpa
    print(airsus.nrmse(ds1["height_mm"], sim["height_mm"]))
    fit = airsus.greybox("m2", truck, [ds1], free=["p0", "p1", "m2"])
    print(fit.estimates)
"""

from __future__ import annotations

import json
import os
from typing import (
    Any,
    Callable,
    Dict,
    Iterator,
    List,
    Mapping,
    Optional,
    Sequence,
    Tuple,
    Union,
)

import numpy as np
import pandas as pd

from . import _native
from ._native import AirsusError

__version__: str = _native.__version__

__all__ = [
    "AirsusError",
    "GreyboxResult",
    "LinearModel",
    "RUN_COLUMNS",
    "Truck",
    "generate",
    "greybox",
    "ident",
    "models",
    "nrmse",
    "read_run",
    "simulate",
    "study",
    "weigh",
    "write_run",
]

#: The run columns of the data contract, in the order files are written.
RUN_COLUMNS: Tuple[str, ...] = (
    "time_s",
    "wheel_load_kg",
    "valve",
    "supply_kpa",
    "road_mm",
    "height_mm",
    "pressure_kpa",
)

PathLike = Union[str, "os.PathLike[str]"]
RunLike = Union[PathLike, pd.DataFrame, Mapping[str, Any]]
TruckLike = Union["Truck", PathLike]
Progress = Optional[Callable[[Dict[str, Any]], Any]]


# --------------------------------------------------------------------------------------------
# Conversions between Python values and the native module
# --------------------------------------------------------------------------------------------


def _is_path(value: Any) -> bool:
    return isinstance(value, (str, bytes, os.PathLike))


def _float_array(values: Any, name: str) -> np.ndarray:
    """A contiguous 1-D float64 array (what the native module reads through a slice)."""
    if isinstance(values, pd.Series):
        array = values.to_numpy(dtype=np.float64, na_value=np.nan)
    else:
        array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise AirsusError(f"column `{name}` must be one-dimensional, got shape {array.shape}")
    return np.ascontiguousarray(array)


def _frame_columns(data: Union[pd.DataFrame, Mapping[str, Any]]) -> List[Tuple[str, Any]]:
    """Every column of a DataFrame or dict that converts to float64, in order."""
    if isinstance(data, pd.DataFrame):
        frame = data
        if "time_s" not in frame.columns and frame.index.name == "time_s":
            frame = frame.reset_index()
        items = [(str(name), frame[name]) for name in frame.columns]
    else:
        items = [(str(name), values) for name, values in data.items()]
    columns = []
    for name, values in items:
        try:
            columns.append((name, _float_array(values, name)))
        except (TypeError, ValueError):
            # Text or object columns are not part of the contract: like extra columns in a
            # file, they are ignored.
            continue
    return columns


def _run_columns(data: Union[pd.DataFrame, Mapping[str, Any]]) -> List[Tuple[str, Any]]:
    """The contract's run columns of a frame (extra columns are ignored, as in a file)."""
    present = _frame_columns(data)
    return [(name, values) for name, values in present if name in RUN_COLUMNS]


def _frame_name(data: Any, default: str) -> str:
    attrs = getattr(data, "attrs", None)
    if isinstance(attrs, Mapping) and attrs.get("name"):
        return str(attrs["name"])
    return default


def _run_spec(run: RunLike, default_name: str = "run") -> Tuple[Any, Any, Any]:
    """A run as the native module takes it: (path, None, None) or (None, name, columns)."""
    if isinstance(run, (str, bytes, os.PathLike)):
        return (os.fsdecode(run), None, None)
    if isinstance(run, (pd.DataFrame, Mapping)):
        return (None, _frame_name(run, default_name), _run_columns(run))
    raise TypeError(
        f"a run is a path, a pandas DataFrame or a dict of arrays, not {type(run).__name__}"
    )


def _data_spec(data: RunLike, default_name: str = "data") -> Tuple[Any, Any, Any]:
    """Like `_run_spec`, keeping every numeric column (for `ident`)."""
    if isinstance(data, (str, bytes, os.PathLike)):
        return (os.fsdecode(data), None, None)
    if isinstance(data, (pd.DataFrame, Mapping)):
        return (None, _frame_name(data, default_name), _frame_columns(data))
    raise TypeError(
        f"data is a path, a pandas DataFrame or a dict of arrays, not {type(data).__name__}"
    )


def _as_truck(truck: TruckLike) -> "Truck":
    if isinstance(truck, Truck):
        return truck
    if _is_path(truck):
        return Truck.load(truck)
    raise TypeError(f"a truck is a Truck or the path of a truck file, not {type(truck).__name__}")


def _names(value: Union[str, Sequence[str]]) -> List[str]:
    """`"a,b"` or `["a", "b"]` → `["a", "b"]` (the command's comma-separated lists)."""
    if isinstance(value, str):
        return [part.strip() for part in value.split(",") if part.strip()]
    return [str(v) for v in value]


def _orders(value: Union[None, int, Sequence[int]]) -> Optional[List[int]]:
    if value is None:
        return None
    if isinstance(value, (int, np.integer)):
        return [int(value)]
    return [int(v) for v in value]


# --------------------------------------------------------------------------------------------
# Runs
# --------------------------------------------------------------------------------------------


def read_run(
    path: PathLike,
    columns: Optional[Mapping[str, Union[str, Tuple[str, str]]]] = None,
    resample: Optional[str] = None,
    sample_s: Optional[float] = None,
    dbc: Optional[PathLike] = None,
) -> pd.DataFrame:
    """Read a run file into a DataFrame: the contract's CSV, or a log (ASAM MDF4, Parquet,
    a candump CAN log), told apart by content.

    The columns are the contract's run columns in the file's units: ``time_s`` (s),
    ``wheel_load_kg`` (kg), ``valve`` (0 closed, 1 fill, 2 exhaust, as integers),
    ``supply_kpa`` (kPa gauge), ``road_mm`` (mm; 0 when the file has no such column), and
    ``height_mm`` (mm) and ``pressure_kpa`` (kPa gauge) when the file has measured outputs.
    A contract CSV gives its values exactly as the file has them; extra columns are ignored.

    A log's channels are found by the contract's names unless ``columns`` maps them:
    ``{"height_mm": "AxleHeight", "pressure_kpa": ("BellowP", "bar")}`` (a unit after the
    channel name is used where the log gives none, and must agree where it does). Units the
    log gives are converted (bar, Pa, m, ...). Channels on different time bases are refused
    unless ``resample`` (``"zoh"`` or ``"linear"``; the valve is always held) and
    ``sample_s`` ask for one uniform base. ``dbc`` names the DBC file that decodes CAN frames
    (SAE J1939 messages matched on their PGN when the DBC declares J1939).

    The file gets every check of the contract (uniform sampling, valve codes, signs, finite
    numbers); a fault raises :class:`AirsusError` naming file, line and column (a log: its
    channel and sample), e.g. ``ds1.csv:57:3 (column `valve`): expected valve state 0
    (closed), 1 (fill) or 2 (exhaust), found `3```.

    ``df.attrs`` holds ``name`` (the file's stem, which names the run in results),
    ``sample_time_s``, ``source`` (the path), ``format`` (``CSV``, ``MDF4``, ``Parquet``,
    ``CAN log``) and ``notes`` (what reading a log assumed or did, e.g. resampling).
    """
    mapped = []
    for column, channel in (columns or {}).items():
        if isinstance(channel, str):
            mapped.append((column, channel, None))
        else:
            name, unit = channel
            mapped.append((column, name, unit))
    raw = _native.read_run(
        os.fsdecode(path),
        mapped,
        resample,
        None if sample_s is None else float(sample_s),
        None if dbc is None else os.fsdecode(dbc),
    )
    frame = pd.DataFrame(dict(raw["columns"]))
    frame["valve"] = frame["valve"].astype(np.int64)
    frame.attrs["name"] = raw["name"]
    frame.attrs["sample_time_s"] = raw["sample_time_s"]
    frame.attrs["source"] = os.fsdecode(path)
    frame.attrs["format"] = raw["format"]
    frame.attrs["notes"] = list(raw["notes"])
    return frame


def write_run(run: Union[pd.DataFrame, Mapping[str, Any]], path: PathLike) -> None:
    """Write a run (a DataFrame or dict of arrays in the file's units) as a run file: CSV, or
    Parquet (snappy, the contract's columns, their units in the ``units`` metadata) when
    ``path`` ends in ``.parquet``.

    The run is checked as :func:`read_run` checks a file (a fault raises
    :class:`AirsusError` naming ``DataFrame `NAME`:LINE:COLUMN``, with LINE the row position
    + 2, the line the row takes in the written file), then written atomically (a temporary
    file renamed over the target) with the contract's columns in their usual order and every
    value in its shortest round-trip form, so reading it back gives the same numbers.
    """
    _native.write_run(_run_spec(run), os.fsdecode(path))


# --------------------------------------------------------------------------------------------
# Trucks
# --------------------------------------------------------------------------------------------


class Truck:
    """A truck parameter file in memory.

    Parameters are read and set by the SPEC's fixed short names, in SI units::

        truck = airsus.Truck.load("truck.toml")
        truck["m2"]            # 520.0 (kg)
        truck["m2"] = 600.0    # range-checked: AirsusError outside 10 to 3000 kg
        truck.parameters()     # DataFrame: name, unit, value, min, max, description

    The names are ``p0``..``p4`` (effective area), ``a0``, ``a1`` (gas-volume
    cross-section), ``m2``, ``ig``, ``kf``, ``kw``, ``kscl``, ``rflow1``, ``rflow2``,
    ``ksd`` (slow-force scale of Model 2 extended; NaN when the file has none), ``vd`` (dead
    volume of the ``area_integral`` volume law), ``dscl`` (the damper table's scale) and
    ``cw`` (the tire's damping, N s/m; 0 when the file has none, the thesis' tire). A
    name of a law the truck does not have (``a0`` under the area integral, ``vd`` under the
    thesis' law) reads as an error, and as NaN in :meth:`parameters`. Every other key of the
    file is kept as loaded and written back by :meth:`save`.
    """

    __slots__ = ("_native",)

    def __init__(self, native: Optional[Any] = None) -> None:
        """The reference truck, or a wrapper of a native truck (internal)."""
        self._native = native if native is not None else _native.NativeTruck.builtin()

    @classmethod
    def load(cls, path: PathLike) -> "Truck":
        """Read and check a truck file (TOML). Keys marked *est* in the SPEC may be omitted:
        they take the reference truck's values, listed in :attr:`defaulted`."""
        return cls(_native.NativeTruck.load(os.fsdecode(path)))

    @classmethod
    def builtin(cls) -> "Truck":
        """The SPEC's reference truck (what ``airsus params --builtin`` prints)."""
        return cls(_native.NativeTruck.builtin())

    @classmethod
    def from_toml(cls, text: str, name: str = "truck.toml") -> "Truck":
        """Parse truck-file text; ``name`` names the source in error messages."""
        return cls(_native.NativeTruck.from_toml(text, name))

    def save(self, path: PathLike) -> None:
        """Write the truck file atomically, every value resolved (loads back identically)."""
        self._native.save(os.fsdecode(path))

    def to_toml(self) -> str:
        """The truck file's text, as :meth:`save` writes it."""
        return str(self._native.to_toml())

    @property
    def defaulted(self) -> List[Tuple[str, str]]:
        """Keys the loaded file left out, with the values used: ``[(key, value), ...]``."""
        return [(str(k), str(v)) for k, v in self._native.defaulted()]

    def __getitem__(self, name: str) -> float:
        """A parameter's value by short name, SI units."""
        return float(self._native.get(name))

    def __setitem__(self, name: str, value: float) -> None:
        """Set a parameter by short name (SI units); values outside the parameter's
        admissible range raise :class:`AirsusError`."""
        self._native.set(name, float(value))

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in _native.NativeTruck.names()

    def keys(self) -> List[str]:
        """The short names, in SPEC order."""
        return [str(n) for n in _native.NativeTruck.names()]

    def __iter__(self) -> Iterator[str]:
        return iter(self.keys())

    def __len__(self) -> int:
        return len(self.keys())

    def parameters(self) -> pd.DataFrame:
        """One row per short name: ``name, unit, value, min, max, description`` (SI units;
        ``min`` and ``max`` are the admissible range, the grey-box estimator's default
        bounds)."""
        rows = self._native.table()
        return pd.DataFrame(
            {
                "name": [r[0] for r in rows],
                "unit": [r[1] for r in rows],
                "value": np.array([r[3] for r in rows], dtype=np.float64),
                "min": np.array([r[4] for r in rows], dtype=np.float64),
                "max": np.array([r[5] for r in rows], dtype=np.float64),
                "description": [r[2] for r in rows],
            }
        )

    def copy(self) -> "Truck":
        """An independent copy."""
        return Truck(self._native.copy())

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Truck):
            return NotImplemented
        return bool(self._native.equals(other._native))

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __repr__(self) -> str:
        # The volume's scale under the truck's law: `a0` (thesis) or `vd` (area integral).
        shown = self.parameters().set_index("name")["value"]
        values = ", ".join(
            f"{name}={shown[name]:.6g}"
            for name in ("m2", "kw", "p1", "a0", "vd")
            if not np.isnan(shown[name])
        )
        return f"Truck({values}, ...)"


# --------------------------------------------------------------------------------------------
# Models and simulation
# --------------------------------------------------------------------------------------------


def models() -> pd.DataFrame:
    """The model registry: one row per model airsus builds by name.

    Columns ``name`` (``m1``, ``m2``, ``m2x``, ``m2xh``, ``m3``, ``truck``),
    ``description``, ``parameters`` (the short names grey-box estimation can free),
    ``units`` (of those parameters), ``states`` (state names with SI units, in
    state-vector order), ``roles`` (each state's role: ``position``, ``angle``, ``velocity``,
    ``bellow_air``, ``supply_air``, ``gas_temperature``, ``force``, ``filter``,
    ``reference``), ``default_free`` (what a grey-box fit frees by default), ``valve_free``
    (freed as well when a run has valve action), ``road_free`` (when a run has road
    input) and ``road_refit`` (what the study refits on the road runs alone after the joint
    estimate). The same registry as ``airsus models --json``.
    """
    return pd.DataFrame(_native.models())


def simulate(
    model: str,
    truck: TruckLike,
    run: RunLike,
    initial_state: Union[None, str, Mapping[str, float], Sequence[float], np.ndarray] = None,
    states: bool = False,
    *,
    rtol: float = 1e-6,
    method: str = "auto",
    load_ramp_s: Optional[float] = None,
    load_transitions_s: Optional[Sequence[float]] = None,
) -> pd.DataFrame:
    """Simulate a model over a run's inputs, as ``airsus simulate`` does.

    Args:
        model: ``m1``, ``m2``, ``m2x``, ``m2xh``, ``m3`` or ``truck`` (see :func:`models`).
        truck: a :class:`Truck` or the path of a truck file.
        run: a run file path, a DataFrame or a dict of arrays (file units); only the inputs
            are used, the measured outputs (if any) fix the start.
        initial_state: where the state starts. ``None`` or ``"prefix"``: static equilibrium
            with the states that carry the run's history (friction, creep, gas temperature,
            air amount, the height it is anchored at) fitted to the run's first 10 s (the
            command's default; an inputs-only run then needs a height, pressure or state).
            ``"equilibrium"``: static equilibrium at the run's first measured sensor height
            (``--initial-state equilibrium``).
            ``{"height_mm": h}`` or ``{"pressure_kpa": p}``: static equilibrium at that sensor
            height or bellow gauge pressure (the command's
            ``--initial-height-mm``/``--initial-pressure-kpa``). A sequence of floats: the
            state vector itself (SI units, the model's state order, see :func:`models`).
        states: also return the model's states (SI units) as columns.
        rtol: relative tolerance of the adaptive solver (the command's ``--rtol``).
        method: ``auto`` (BDF, and the explicit Tsitouras 5(4) where the road moves: a rough
            road 3-5 times faster), ``bdf``, ``tr-bdf2``, ``esdirk34`` or
            ``tsit45`` (``--method``).
        load_ramp_s: ease every change of the logged load over this many seconds, as the
            wheel takes a load over seconds while a log steps (``--load-ramp-s``; a study's
            ``load_ramp_s`` per model is the fitted value).
        load_transitions_s: ease each change of the logged load over its own time, one per
            change in time order (``--load-transitions-s``; what :func:`greybox` reports in
            ``load_transitions_s`` for an estimation run).

    Returns:
        A DataFrame with ``time_s``, ``height_mm``, ``pressure_kpa`` (the same numbers, to the
        last bit, as the command writes in its output file), then the states if asked.
        ``df.attrs`` holds ``model``, ``initial`` (what fixed the start), ``statistics``
        (solver counts) and ``nrmse`` (height and pressure against the run's measurements,
        percent, None without measurements).
    """
    kind: Optional[str] = None
    value: Optional[float] = None
    vector: Optional[np.ndarray] = None
    if initial_state is None:
        pass
    elif isinstance(initial_state, str):
        if initial_state == "joint":
            raise AirsusError(
                "initial_state 'joint' estimates each run's start together with parameters "
                "(greybox, study); a simulation fits none: give 'prefix' or 'equilibrium'"
            )
        if initial_state not in ("prefix", "equilibrium"):
            raise AirsusError(
                f"initial_state: unknown start `{initial_state}`; give 'prefix', "
                "'equilibrium', {'height_mm': ...}, {'pressure_kpa': ...} or a state vector"
            )
        kind = initial_state
    elif isinstance(initial_state, Mapping):
        if len(initial_state) != 1:
            raise AirsusError(
                "initial_state: give one of {'height_mm': ...} or {'pressure_kpa': ...}"
            )
        ((kind, raw_value),) = initial_state.items()
        value = float(raw_value)
    else:
        kind = "state"
        vector = _float_array(initial_state, "initial_state")
    result = _native.simulate(
        model,
        _as_truck(truck)._native,
        _run_spec(run),
        initial_kind=kind,
        initial_value=value,
        initial_state=vector,
        rtol=float(rtol),
        method=method,
        states=bool(states),
        load_ramp_s=None if load_ramp_s is None else float(load_ramp_s),
        load_transitions_s=(
            None if load_transitions_s is None else [float(t) for t in load_transitions_s]
        ),
    )
    frame = pd.DataFrame(
        {
            "time_s": result["time_s"],
            "height_mm": result["height_mm"],
            "pressure_kpa": result["pressure_kpa"],
        }
    )
    for name, values in result["states"].items():
        frame[name] = values
    frame.attrs["model"] = result["model"]
    frame.attrs["initial"] = result["initial"]
    frame.attrs["statistics"] = dict(result["statistics"])
    frame.attrs["nrmse"] = {
        "height_mm": result["nrmse_height"],
        "pressure_kpa": result["nrmse_pressure"],
    }
    return frame


# --------------------------------------------------------------------------------------------
# Grey-box estimation
# --------------------------------------------------------------------------------------------


class GreyboxResult:
    """What :func:`greybox` returns.

    Attributes:
        truck: the truck with the estimates written back (what ``--out`` writes).
        estimates: DataFrame indexed by parameter: ``unit, nominal, estimate, std,
            std_correlated, min, max, status, identifiable`` (``std`` as if the residuals
            were white, ``std_correlated`` allowing for residuals correlated in time, the
            honest one where a model's misfit is slow; both NaN where fixed, at a bound or
            undetermined).
        stop_reason: why the solver stopped, as the command prints it.
        converged: whether that is a (local) minimum.
        start: how the runs started, in words (for prefix starts, the joint estimate's
            rounds; first, where the starts fitted under the start values were not used for
            the first fit, why).
        load: what easing the logged load did, in words ("" when the runs have no load
            changes or ``load_ramp="logged"``).
        load_transitions_s: per run (in the order given), each logged load change's own
            transition time in s; an empty list where none was estimated.
        load_ramp_s: the one transition time other runs' logged load is eased over (fitted
            to these runs under the estimate); None: the load as logged. Pass it to
            :func:`simulate` as ``load_ramp_s`` to validate on another run.
        trades: where the pooled estimate explained a run and output worse than the start
            values did (by more than 0.1 NRMSE point), what was done, in words: the refit with
            that run and output weighted more that trades nothing (or least) is kept, else the
            pooled estimate (kept as fitted with ``allow_trades``); the pooled estimate's score
            of each traded run and output is named. None where nothing was traded.
        nrmse: DataFrame indexed by run: ``samples, height_nominal, height_estimated,
            pressure_nominal, pressure_estimated`` (percent, thesis eq 3.33).
        report: the full result, as ``airsus greybox --json`` prints it (a dict).
        text: the command's printout (also ``str(result)``).
    """

    def __init__(self, native: Mapping[str, Any]) -> None:
        self.report: Dict[str, Any] = json.loads(native["report"])
        self.text: str = native["text"]
        self.stop_reason: str = native["stop_reason"]
        self.converged: bool = bool(native["converged"])
        self.start: str = native["start"]
        self.load: str = native["load"]
        self.load_transitions_s: List[List[float]] = [
            [float(t) for t in run] for run in native["load_transitions_s"]
        ]
        self.load_ramp_s: Optional[float] = native["load_ramp_s"]
        self.trades: Optional[str] = native["trades"]
        self.truck: Truck = Truck(native["truck"])
        parameters = self.report.get("parameters", [])
        self.estimates: pd.DataFrame = pd.DataFrame(
            {
                "unit": [p["unit"] for p in parameters],
                "nominal": [_num(p["nominal"]) for p in parameters],
                "estimate": [_num(p["estimate"]) for p in parameters],
                "std": [_num(p["std"]) for p in parameters],
                "std_correlated": [_num(p.get("std_correlated")) for p in parameters],
                "min": [_num(p["lower"]) for p in parameters],
                "max": [_num(p["upper"]) for p in parameters],
                "status": [p["status"] for p in parameters],
                "identifiable": [
                    p["status"] not in ("fixed_not_identifiable", "not_identifiable")
                    for p in parameters
                ],
            },
            index=pd.Index([p["name"] for p in parameters], name="parameter"),
        )
        fits = self.report.get("fits", [])
        self.nrmse: pd.DataFrame = pd.DataFrame(
            {
                "samples": [f["samples"] for f in fits],
                "height_nominal": [_num(f["height_nominal_percent"]) for f in fits],
                "height_estimated": [_num(f["height_estimated_percent"]) for f in fits],
                "pressure_nominal": [_num(f["pressure_nominal_percent"]) for f in fits],
                "pressure_estimated": [_num(f["pressure_estimated_percent"]) for f in fits],
            },
            index=pd.Index([f["run"] for f in fits], name="run"),
        )

    def __str__(self) -> str:
        return self.text

    def __repr__(self) -> str:
        return (
            f"GreyboxResult(model={self.report.get('model')!r}, "
            f"stop_reason={self.stop_reason!r}, "
            f"parameters={list(self.estimates.index)})"
        )


def _num(value: Any) -> float:
    """JSON null (undefined) → NaN."""
    return float("nan") if value is None else float(value)


def greybox(
    model: str,
    truck: TruckLike,
    runs: Union[RunLike, Sequence[RunLike]],
    free: Union[None, str, Sequence[str]] = None,
    bounds: Optional[Mapping[str, Tuple[float, float]]] = None,
    *,
    max_iterations: Optional[int] = None,
    tolerance: Optional[float] = None,
    initial: str = "height",
    height_weight: float = 1.0,
    pressure_weight: float = 1.0,
    max_relative_std: float = 0.5,
    keep_unidentifiable: bool = False,
    normalisation: str = "pooled-spread",
    progress: Progress = None,
    initial_state: Optional[str] = None,
    load_ramp: str = "estimate",
    force_map: Optional[PathLike] = None,
    force_map_noise_n: Optional[float] = None,
    allow_trades: bool = False,
) -> GreyboxResult:
    """Estimate named physical parameters of a model from one or more runs at once, as
    ``airsus greybox`` does (thesis 5.2.6; MATLAB ``nlgreyest`` with simulation focus).

    The loss is the simulation error of height and pressure, each normalised by its spread
    pooled over all runs (or, with ``normalisation="noise-level"``, each run and output by
    its own measurement noise, every run weighing the same). Each run starts from its first
    10 s: the states that carry its history are fitted to them and refitted with the
    parameters in turn (``initial_state="joint"``, the default), or fitted once under the
    start values and held (``initial_state="prefix"``); or in static equilibrium at its
    first measured height (``initial_state="equilibrium"``) or pressure
    (``initial="pressure"``, which implies it). A log that records a load change as a step
    while the wheel takes it over seconds is eased: each logged change over its own
    transition time, estimated in turn with the parameters (``load_ramp="estimate"``, the
    default; ``"logged"`` keeps the steps).
    Freed parameters the runs cannot determine are kept at their nominal values and reported
    (unless ``keep_unidentifiable``). Where the pooled loss traded a run and output for the
    others (the estimate explains it worse than the start values did, by more than 0.1 NRMSE
    point), the parameters are refitted with it weighted more, as ``airsus greybox`` does
    (``GreyboxResult.trades`` says what was done), unless ``allow_trades``.

    Args:
        model: any model of :func:`models` (``m1``, ``m2``, ``m2x``, ``m2xh``, ``m3``,
            ``truck``).
        truck: the nominal (start) parameters: a :class:`Truck` or a truck file path.
        runs: one run or a list of runs (paths, DataFrames or dicts) with measured height and
            pressure. A DataFrame's run is named by ``df.attrs["name"]`` (set by
            :func:`read_run`), else ``run1``, ``run2``, ...
        free: the short names to estimate, a list or a comma-separated string (``p0``..``p4``,
            ``a0``, ``a1``, ``m2``, ``ig``, ``kf``, ``kw``, ``kscl``, ``rflow1``, ``rflow2``,
            ``ksd``; ``tsd`` for ``m2xh``; ``dscl``, the damper table's scale; ``cw``, the
            tire's damping). ``None``: the
            model's default set (the ``default_free`` column of :func:`models`), plus the flow
            parameters and the gas volume's scale ``a0`` (``valve_free``) when a run has valve
            action, and ``road_free`` (the damper table's scale) when a run has road input.
        bounds: ``{name: (lower, upper)}`` narrowing a freed parameter's admissible range.
        max_iterations: Levenberg-Marquardt iterations per fit round (default 100).
        tolerance: relative tolerance on loss decrease and scaled step (default 1e-8); the
            rounds that refit the starts with the parameters stop at a 0.1 % loss decrease
            where this is tighter.
        initial: ``"height"`` or ``"pressure"``: what fixes each run's initial equilibrium.
        height_weight, pressure_weight: weights of the two outputs (0 leaves one out).
        max_relative_std: relative standard deviation above which a parameter counts as not
            determined by the runs.
        keep_unidentifiable: estimate parameters found not identifiable anyway.
        normalisation: ``"pooled-spread"`` or ``"noise-level"`` (see above).
        initial_state: ``"joint"``, ``"prefix"`` or ``"equilibrium"`` (see above), as
            ``--initial-state``; ``None``: joint, or equilibrium with ``initial="pressure"``.
        load_ramp: ``"estimate"`` or ``"logged"`` (see above), as ``--load-ramp``.
        force_map: a bellow force map file (``bellow_height_mm, pressure_kpa, force_n``) that
            enters the loss as a prior on the effective-area law, as ``--force-map``: the runs
            pin the area only at the heights they visit, the map holds it elsewhere.
        force_map_noise_n: the map's force error, N (default: the misfit of the truck's
            effective-area law to the map), as ``--force-map-noise-n``.
        allow_trades: keep the pooled estimate where it explains a run and output worse than
            the start values did (a fit as MATLAB's ``greyest`` gives it); ``trades`` names
            each such run and output. As ``--allow-trades``.
        progress: called with a dict per event while the fit runs (the GIL is released):
            ``{"event": "stage", "message": ...}`` or ``{"event": "iteration", "round",
            "iteration", "loss", "simulations", "failed_simulations"}``.
    """
    if _is_path(runs) or isinstance(runs, (pd.DataFrame, Mapping)):
        run_list: List[RunLike] = [runs]  # type: ignore[list-item]
    else:
        run_list = list(runs)  # type: ignore[arg-type]
    specs = [_run_spec(run, f"run{i + 1}") for i, run in enumerate(run_list)]
    bound_list = (
        [(str(name), float(lo), float(hi)) for name, (lo, hi) in bounds.items()] if bounds else None
    )
    native = _native.greybox(
        model,
        _as_truck(truck)._native,
        specs,
        _names(free) if free is not None else [],
        bounds=bound_list,
        max_iterations=max_iterations,
        tolerance=tolerance,
        initial=initial,
        height_weight=float(height_weight),
        pressure_weight=float(pressure_weight),
        max_relative_std=float(max_relative_std),
        keep_unidentifiable=bool(keep_unidentifiable),
        progress=progress,
        normalisation=normalisation,
        initial_state=initial_state,
        load_ramp=load_ramp,
        force_map=os.fsdecode(force_map) if force_map is not None else None,
        force_map_noise_n=None if force_map_noise_n is None else float(force_map_noise_n),
        allow_trades=bool(allow_trades),
    )
    return GreyboxResult(native)


# --------------------------------------------------------------------------------------------
# Linear black-box identification
# --------------------------------------------------------------------------------------------


class LinearModel:
    """A linear black-box model estimated by :func:`ident` (an ``idpoly`` with its report).

    Attributes:
        structure: ``arx``, ``armax``, ``oe`` or ``bj``.
        inputs, output: the column names it was estimated from.
        ts_s: sample time.
        offsets: the means removed before estimation (``detrend=True``):
            ``{"y": ..., "u": [...]}``, else None. :meth:`simulate` and :meth:`predict` take
            and return signals on the original scale, removing and adding these offsets.
        parameters: Series of the free coefficients (``a1``, ``b1``, ``f1``, ...; with several
            inputs ``b1(u2)``), MATLAB ``getpvec`` order.
        std: Series of their standard deviations.
        fit: NRMSE fit of the one-step prediction on the estimation data, percent (MATLAB
            ``Report.Fit.FitPercent``).
        simulation_fit: NRMSE fit of the pure simulation on the estimation data, percent
            (None when the simulation diverges).
        polynomials: ``{"a", "b", "c", "d", "f", "nk"}`` as estimated.
        report: the full result, as ``airsus ident --json`` prints it (a dict).
        text: the command's printout (also ``str(model)``).
    """

    def __init__(self, native: Mapping[str, Any]) -> None:
        self._native = native["model"]
        self.report: Dict[str, Any] = json.loads(native["report"])
        self.text: str = native["text"]
        estimate = self.report["estimate"]
        self.structure: str = self.report["structure"]
        self.inputs: List[str] = list(self.report["inputs"])
        self.output: str = self.report["output"]
        self.ts_s: float = float(self.report["ts_s"])
        self.offsets: Optional[Dict[str, Any]] = self.report.get("offsets")
        names = [p["name"] for p in estimate["parameters"]]
        self.parameters: pd.Series = pd.Series(
            [_num(p["value"]) for p in estimate["parameters"]], index=names, name="value"
        )
        self.std: pd.Series = pd.Series(
            [_num(p["std"]) for p in estimate["parameters"]], index=names, name="std"
        )
        self.fit: float = _num(estimate["fit_percent"])
        sim_fit = native["simulation_fit"]
        self.simulation_fit: Optional[float] = None if sim_fit is None else float(sim_fit)
        self.loss: float = _num(estimate["loss"])
        self.fpe: float = _num(estimate["fpe"])
        self.aic: float = _num(estimate["aic"])
        self.polynomials: Dict[str, Any] = {
            key: estimate["model"][key] for key in ("a", "b", "c", "d", "f", "nk")
        }

    def _inputs(self, u: Any) -> List[np.ndarray]:
        m = len(self.inputs)
        if isinstance(u, (pd.DataFrame, Mapping)):
            missing = [name for name in self.inputs if name not in u]
            if missing:
                raise AirsusError(
                    f"the inputs {', '.join(missing)} are missing; the model needs "
                    f"{', '.join(self.inputs)}"
                )
            signals = [_float_array(u[name], name) for name in self.inputs]
        else:
            array = np.asarray(u, dtype=np.float64)
            if array.ndim == 1 and m == 1:
                signals = [np.ascontiguousarray(array)]
            elif array.ndim == 2 and array.shape[1] == m:
                signals = [np.ascontiguousarray(array[:, i]) for i in range(m)]
            elif array.ndim == 2 and array.shape[0] == m:
                signals = [np.ascontiguousarray(array[i]) for i in range(m)]
            else:
                raise AirsusError(
                    f"expected {m} input signal(s) ({', '.join(self.inputs)}), "
                    f"got an array of shape {array.shape}"
                )
        if self.offsets is not None:
            signals = [s - float(o) for s, o in zip(signals, self.offsets["u"])]
        return [np.ascontiguousarray(s, dtype=np.float64) for s in signals]

    def simulate(self, u: Any) -> np.ndarray:
        """Noise-free simulation from zero initial conditions (MATLAB ``sim``).

        ``u``: a DataFrame or dict with the input columns, an array of shape ``(n, m)`` or
        ``(m, n)``, or a 1-D array for a single-input model. Returns the output on the
        original scale (the detrending offsets removed from the inputs and added back).
        """
        y = np.asarray(self._native.simulate(self._inputs(u)))
        if self.offsets is not None:
            y = y + float(self.offsets["y"])
        return y

    def predict(self, data: Union[pd.DataFrame, Mapping[str, Any]], k: int = 1) -> np.ndarray:
        """``k``-step-ahead prediction (MATLAB ``predict(sys, data, k)``) from a DataFrame or
        dict with the input and output columns; zero initial conditions."""
        if self.output not in data:
            raise AirsusError(f"the output column `{self.output}` is missing")
        y = _float_array(data[self.output], self.output)
        if self.offsets is not None:
            y = y - float(self.offsets["y"])
        yhat = np.asarray(self._native.predict(np.ascontiguousarray(y), self._inputs(data), int(k)))
        if self.offsets is not None:
            yhat = yhat + float(self.offsets["y"])
        return yhat

    def __str__(self) -> str:
        return self.text

    def __repr__(self) -> str:
        return (
            f"LinearModel({self.structure}, {self.output} <- {', '.join(self.inputs)}, "
            f"fit {self.fit:.2f} %)"
        )


def ident(
    data: RunLike,
    structure: str,
    inputs: Union[str, Sequence[str]],
    output: str,
    *,
    na: Optional[int] = None,
    nb: Union[None, int, Sequence[int]] = None,
    nc: Optional[int] = None,
    nd: Optional[int] = None,
    nf: Union[None, int, Sequence[int]] = None,
    nk: Union[None, int, Sequence[int]] = None,
    ts_s: Optional[float] = None,
    detrend: bool = False,
    merge: Union[None, RunLike, Sequence[RunLike]] = None,
) -> LinearModel:
    """Estimate a linear black-box model (ARX, ARMAX, OE, BJ) of one output from one or more
    input columns, as ``airsus ident`` does (MATLAB ``arx``/``armax``/``oe``/``bj``).

    Args:
        data: a CSV file path, a DataFrame or a dict of arrays. The sample time comes from a
            ``time_s`` column when there is one (checked for uniform sampling), else from
            ``ts_s``.
        structure: ``arx`` (least squares; na, nb, nk), ``armax`` (na, nb, nc, nk), ``oe``
            (nb, nf, nk) or ``bj`` (nb, nc, nd, nf, nk).
        inputs: input column names, a list or a comma-separated string.
        output: the output column name.
        na, nc, nd: orders of A, C, D.
        nb, nf, nk: one value for every input, or one per input. Orders the structure does
            not have are rejected rather than ignored.
        ts_s: sample time, s, when the data have no ``time_s`` column.
        detrend: remove the means of output and inputs first (MATLAB ``detrend(z, 0)``);
            each run's own means when runs are merged.
        merge: other runs of the same system (same columns and sample time) estimated
            together with ``data`` (MATLAB ``merge``; ``--merge``): one model, each run's
            filters started at its own first sample, for what no run determines alone (every
            structure). The model's ``offsets`` are ``data``'s.
    """
    if merge is None:
        merged = None
    elif isinstance(merge, (list, tuple)):
        if not merge:
            raise ValueError("merge is an empty list: give a run, or None")
        merged = [_data_spec(m) for m in merge]
    else:
        merged = [_data_spec(merge)]
    native = _native.ident(
        _data_spec(data),
        structure,
        _names(inputs),
        output,
        na=na,
        nb=_orders(nb),
        nc=nc,
        nd=nd,
        nf=_orders(nf),
        nk=_orders(nk),
        ts_s=None if ts_s is None else float(ts_s),
        detrend=bool(detrend),
        merge=merged,
    )
    return LinearModel(native)


# --------------------------------------------------------------------------------------------
# Applications, the study, the virtual truck
# --------------------------------------------------------------------------------------------


def weigh(
    truck: TruckLike,
    run: RunLike,
    method: str = "static",
    *,
    model: str = "m2",
    window_s: float = 2.0,
    calibration_run: Union[None, RunLike, Sequence[RunLike]] = None,
    start_hysteresis: str = "unknown",
    calibration_start: Union[None, str, Sequence[str]] = None,
    loading_shift_kpa: float = 3.0,
    loading_window_s: float = 2.0,
    loading_hold_s: float = 10.0,
) -> pd.DataFrame:
    """Estimate the wheel load over a run from its measured pressure and height (the logged
    load is not used), as ``airsus weigh`` does.

    Args:
        truck: the parameters (nominal or identified): a :class:`Truck` or a truck file path.
        run: a run with ``height_mm`` and ``pressure_kpa``.
        method: ``static`` (the static force balance inverted, averaged over ``window_s``;
            with a ``truck``-structure file, one whose ``[effects]`` name ``kc``, ``tc``,
            ``fc`` and ``kdahl``, the bellow wall's creep and friction are followed over the
            run's heights) or ``ekf`` (an
            extended Kalman filter on ``model`` with the load as a random walk).
        calibration_run: a run whose logged load is trusted at standstill (weighbridge), or
            a list of them: the interval is sized on their standstills, and a gain and offset
            are fitted on them and applied, with the wall friction's hysteresis and a height
            term when the runs determine them (a loading run and a run at one load with the
            valve moving the height do; a loading run alone cannot tell the height from the
            load), except to an estimator with the wall (the EKF on ``truck``, the static
            method with a ``truck``-structure file), which carries all four and is not
            corrected.
        start_hysteresis: how the truck came to the run's first reading, for an estimator
            with wall friction (the EKF on ``truck``, the static method with a
            ``truck``-structure file): ``unknown`` (its interval holds the
            friction's whole range until the bellow moves; for the EKF, where the valve
            moved it first, the load read after that movement is taken back to the start,
            and ``df.attrs["notes"]`` says so), ``lowered`` (a load set down, an exhaust)
            or ``raised`` (a fill, a load taken off).
        calibration_start: how each calibration run starts (as ``start_hysteresis``), one
            per run in the same order; ``None``: every one ``unknown``.
        loading_shift_kpa, loading_window_s, loading_hold_s: a sample is flagged
            ``loading`` when the mean pressure over the window after it differs from the mean
            over the window before it by more than the shift (valve closed, road still), and
            for the hold after the last such sample, carried on while a valve opened within
            it works (a levelling controller); as ``--loading-shift-kpa`` etc. The
            defaults suit 100-300 kg steps on a truck axle (about 30 kPa).

    Returns:
        A DataFrame ``time_s, wheel_load_kg, wheel_load_std_kg, quality`` at full precision
        (the command's CSV rounds to 3 decimals). ``quality`` says how far a sample can be
        trusted, from the run alone: ``standstill`` (read the scale here), ``settling``,
        ``valve`` or ``loading`` (a load arriving or leaving, the pressure's level shifting
        with the valve closed, and 10 s after, or after the valve a levelling controller
        opened meanwhile closes). ``df.attrs["notes"]`` lists what the
        estimator says about the run (the EKF on ``truck`` with an unknown start: until when
        the friction held its interval up). ``df.attrs["calibration"]`` holds the fitted
        ``gain, offset_kg, hysteresis_kg, height_kg_per_mm, reference_height_mm, samples,
        residual_rms_kg, residual_q95_kg, settling_q95_kg, valve_q95_kg, standstill_std_kg,
        settling_std_kg, valve_std_kg, own_std_scale, settling_own_scale, valve_own_scale,
        late_settling_std_kg, late_settling_own_scale, late_settling_after_s,
        load_settling_std_kg, load_settling_own_scale, loading_q95_kg, loading_std_kg,
        loading_own_scale, height_range_mm`` and ``dropped``
        (the terms the runs did not determine, with why) when ``calibration_run`` is given:
        ``load = gain·estimate + offset + hysteresis·z + height·(h − reference)``, with ``z``
        the wall-friction state from the heights (a fill reads high, ``hysteresis_kg < 0``
        takes it out). The standard deviation then comes from the calibration's residuals,
        per quality class: ``√((s·own)² + σ_c²)`` with ``own`` the estimate's own noise part,
        ``s`` (``own_std_scale``, ``settling_own_scale``, ``valve_own_scale``,
        ``loading_own_scale``, at most 1) the
        smallest scale at which the own part alone held 95 % of the average calibration
        run's known loads (the EKF's covariance is wider than its errors at standstill), and
        ``σ_c`` (``standstill_std_kg``, ``settling_std_kg``, ``valve_std_kg``,
        ``loading_std_kg``; the loading class sized on every arriving sample against where
        the bellow pressure says the load was, the others at a steady load) the smallest
        part beside it that held 95 % of each calibration run's known loads (the
        ``*_q95_kg``: what the residuals' 95th percentile was; None with too few such
        samples). A ``settling`` sample at least ``late_settling_after_s`` after the flags
        last said ``valve`` or ``loading`` gets the late settling part
        (``late_settling_std_kg``; the gas has cooled or warmed, the pressure drifts less),
        the earlier ones after a load's arrival through which the valve stayed closed the
        load-settling part (``load_settling_std_kg``), the others the settling part. Beyond
        the calibration's sensor heights (``height_range_mm``, lowest and highest, mm) the
        calibration measured nothing: a part ``σ_p min(1, (d/span)²)`` is added, with ``d``
        the distance beyond the range, ``span`` its width and ``σ_p`` the estimator's
        assumed parameter errors, so one span out the interval is the uncalibrated one
        again.
    """
    if isinstance(calibration_run, (list, tuple)):
        if not calibration_run:
            raise ValueError("calibration_run is an empty list: give a run, or None")
        calibration = [_run_spec(r) for r in calibration_run]
    else:
        calibration = None if calibration_run is None else [_run_spec(calibration_run)]
    starts = [calibration_start] if isinstance(calibration_start, str) else calibration_start
    result = _native.weigh(
        _as_truck(truck)._native,
        _run_spec(run),
        method=method,
        model=model,
        window_s=float(window_s),
        calibration_run=calibration,
        start_hysteresis=start_hysteresis,
        calibration_start=None if starts is None else list(starts),
        loading_shift_kpa=float(loading_shift_kpa),
        loading_window_s=float(loading_window_s),
        loading_hold_s=float(loading_hold_s),
    )
    frame = pd.DataFrame(
        {
            "time_s": result["time_s"],
            "wheel_load_kg": result["wheel_load_kg"],
            "wheel_load_std_kg": result["wheel_load_std_kg"],
            "quality": result["quality"],
        }
    )
    frame.attrs["calibration"] = (
        None if result["calibration"] is None else dict(result["calibration"])
    )
    frame.attrs["notes"] = list(result["notes"])
    return frame


def study(
    path: Optional[PathLike],
    out: PathLike,
    *,
    models: Optional[Sequence[str]] = None,
    max_iterations: int = 60,
    seed: Optional[int] = None,
    initial_state: str = "joint",
    normalisation: str = "pooled-spread",
    starts: int = 4,
    screen: int = 32,
    variant: Optional[int] = None,
    load_ramp: str = "estimate",
    progress: Progress = None,
    exclude_after_load_change_s: float = 0.0,
    validation_transitions: str = "fitted",
    prefix_s: float = 10.0,
    allow_trades: bool = False,
) -> Dict[str, Any]:
    """Run the whole thesis pipeline, as ``airsus study STUDY.toml --out OUT``: submodel fits,
    grey-box estimation of every model, validation with residual analysis on every run, and
    the report (``report.html``, ``results.json``, figures, estimated truck files) in ``out``.

    Args:
        path: the study file (TOML), or None for the built-in virtual truck's study
            (``airsus study --builtin``: generated into ``out/data``, two protocols).
        out: output folder.
        models: the models to estimate (default all: ``m1, m2, m2x, m2xh, m3, truck``).
        max_iterations: iteration limit of each grey-box fit.
        seed: seed of the built-in study (only with ``path=None``; default 1).
        initial_state: ``"joint"`` (default: runs start from their first 10 s, refitted
            with the parameters in turn in estimation runs, with the parameters fixed in
            validation runs), ``"prefix"`` (the estimation runs' starts fitted once under the
            start values and held) or ``"equilibrium"``, as ``--initial-state``.
        normalisation: ``"pooled-spread"`` or ``"noise-level"``, as ``--normalisation``.
        starts: local fits of each grey-box fit's global stage at most, the start's
            included (1: the plain local fit), as ``--starts``.
        screen: points of the global stage's design screened by their loss before any
            local fit begins at the best of those better than the start, as ``--screen``
            (0: the starts are the design's first points, unscreened).
        variant: member of the virtual truck family for the built-in study (only with
            ``path=None``; default 0, the reference truck), as ``--variant``.
        load_ramp: ``"estimate"`` (each logged load change eased over a transition time
            fitted on the estimation runs, the parameters refitted) or ``"logged"``, as
            ``--load-ramp``.
        exclude_after_load_change_s: seconds after each logged load change that the
            estimation's loss leaves out (0: none), as ``--exclude-after-load-change-s``.
        validation_transitions: ``"fitted"`` (each logged load change of a validation run
            eased over its own transition time, fitted to the run with the parameters fixed,
            as its start is to its first seconds) or ``"common"`` (the one time fitted to the
            estimation runs), as ``--validation-transitions``.
        prefix_s: length of the prefix every run's start is fitted to, s, as
            ``--prefix-s`` (recorded as ``prefix_s`` in the results).
        allow_trades: keep each model's pooled estimate where it explains an estimation run
            and output worse than the start values did, naming each trade in the model's
            notes, as ``--allow-trades`` (recorded as ``allow_trades``). By default it is
            refitted with the traded runs weighted more; either way each estimation run's
            ``pooled`` fit is kept where the pooled estimate traded.
        progress: called with a dict per event (the GIL is released while the study runs):
            ``{"event": "stage", "message": ...}`` or ``{"event": "model_done", "protocol",
            "model", "seconds", "done", "total"}``.

    Returns:
        The content of ``results.json`` (a dict). Estimated truck files are under
        ``out/estimated/``; each model's ``truck_file`` names its file relative to ``out``.
    """
    native = _native.study(
        None if path is None else os.fsdecode(path),
        os.fsdecode(out),
        models=None if models is None else _names(models),
        max_iterations=int(max_iterations),
        seed=None if seed is None else int(seed),
        progress=progress,
        initial_state=initial_state,
        normalisation=normalisation,
        starts=int(starts),
        screen=int(screen),
        variant=None if variant is None else int(variant),
        load_ramp=load_ramp,
        exclude_after_load_change_s=float(exclude_after_load_change_s),
        validation_transitions=validation_transitions,
        prefix_s=float(prefix_s),
        allow_trades=bool(allow_trades),
    )
    with open(native["results"], encoding="utf-8") as f:
        results: Dict[str, Any] = json.load(f)
    return results


def generate(
    out: PathLike, seed: int = 1, *, variant: int = 0, progress: Progress = None
) -> Dict[str, Any]:
    """Generate the thesis' reference experiments with the built-in virtual truck, as
    ``airsus generate --out OUT --seed SEED --variant K``: data-sets 1-4 (``ds1.csv`` to
    ``ds4.csv``), two levelling runs (``lev1.csv``, ``lev2.csv``: load steps while the truck's
    deadband ECU levels) and two road runs (``road1.csv``: humps and potholes at 20 km/h;
    ``road2.csv``: ISO 8608 class C at 50 km/h), a bellow force map, four tank discharges,
    their noise-free truth
    (``truth/``), a nominal ``truck.toml`` and the study files. The same seed writes the same
    bytes. ``variant`` picks a member of the virtual truck family (0, the reference truck;
    the others differ in laws and values, with their truth in ``truth/``).

    Returns ``{"study": path of study.toml (estimation on data-set 1), "study_valve": path of
    study_valve.toml (data-sets 1 and 3, levelling run 1, road run 1), "files": every file
    written}``.
    ``progress`` is called with ``{"event": "stage", "message": ...}`` per step.
    """
    result = _native.generate(os.fsdecode(out), int(seed), progress=progress, variant=int(variant))
    return {
        "study": result["study"],
        "study_valve": result["study_valve"],
        "files": list(result["files"]),
    }


def nrmse(y: Any, yhat: Any) -> float:
    """NRMSE fit in percent, thesis eq 3.33: ``100 (1 - ||y - yhat|| / ||y - mean(y)||)``.

    100 is a perfect fit, 0 no better than the measured mean, negative worse. ``y`` is the
    measured signal. Different lengths, non-finite values or a constant ``y`` raise
    :class:`AirsusError`.
    """
    return float(_native.nrmse(_float_array(y, "y"), _float_array(yhat, "yhat")))
