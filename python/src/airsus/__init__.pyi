"""Type stub of the `airsus` package (the implementation is `__init__.py`)."""

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
import numpy.typing as npt
import pandas as pd

from ._native import AirsusError as AirsusError

__version__: str
__all__: List[str]

RUN_COLUMNS: Tuple[str, ...]

PathLike = Union[str, os.PathLike[str]]
RunLike = Union[PathLike, pd.DataFrame, Mapping[str, Any]]
TruckLike = Union[Truck, PathLike]
Progress = Optional[Callable[[Dict[str, Any]], Any]]
_ArrayLike = Union[npt.ArrayLike, pd.Series]
_InitialState = Union[None, str, Mapping[str, float], Sequence[float], npt.NDArray[np.float64]]

def read_run(path: PathLike) -> pd.DataFrame: ...
def write_run(run: Union[pd.DataFrame, Mapping[str, Any]], path: PathLike) -> None: ...

class Truck:
    def __init__(self, native: Optional[Any] = None) -> None: ...
    @classmethod
    def load(cls, path: PathLike) -> Truck: ...
    @classmethod
    def builtin(cls) -> Truck: ...
    @classmethod
    def from_toml(cls, text: str, name: str = "truck.toml") -> Truck: ...
    def save(self, path: PathLike) -> None: ...
    def to_toml(self) -> str: ...
    @property
    def defaulted(self) -> List[Tuple[str, str]]: ...
    def __getitem__(self, name: str) -> float: ...
    def __setitem__(self, name: str, value: float) -> None: ...
    def __contains__(self, name: object) -> bool: ...
    def keys(self) -> List[str]: ...
    def __iter__(self) -> Iterator[str]: ...
    def __len__(self) -> int: ...
    def parameters(self) -> pd.DataFrame: ...
    def copy(self) -> Truck: ...
    def __eq__(self, other: object) -> bool: ...

def models() -> pd.DataFrame: ...
def simulate(
    model: str,
    truck: TruckLike,
    run: RunLike,
    initial_state: _InitialState = None,
    states: bool = False,
    *,
    rtol: float = 1e-6,
    method: str = "bdf",
    load_ramp_s: Optional[float] = None,
    load_transitions_s: Optional[Sequence[float]] = None,
) -> pd.DataFrame: ...

class GreyboxResult:
    truck: Truck
    estimates: pd.DataFrame
    stop_reason: str
    converged: bool
    start: str
    load: str
    load_transitions_s: List[List[float]]
    load_ramp_s: Optional[float]
    trades: Optional[str]
    nrmse: pd.DataFrame
    report: Dict[str, Any]
    text: str
    def __init__(self, native: Mapping[str, Any]) -> None: ...

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
) -> GreyboxResult: ...

class LinearModel:
    structure: str
    inputs: List[str]
    output: str
    ts_s: float
    offsets: Optional[Dict[str, Any]]
    parameters: pd.Series
    std: pd.Series
    fit: float
    simulation_fit: Optional[float]
    loss: float
    fpe: float
    aic: float
    polynomials: Dict[str, Any]
    report: Dict[str, Any]
    text: str
    def __init__(self, native: Mapping[str, Any]) -> None: ...
    def simulate(self, u: Any) -> npt.NDArray[np.float64]: ...
    def predict(
        self, data: Union[pd.DataFrame, Mapping[str, Any]], k: int = 1
    ) -> npt.NDArray[np.float64]: ...

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
) -> LinearModel: ...
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
) -> pd.DataFrame: ...
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
) -> Dict[str, Any]: ...
def generate(out: PathLike, seed: int = 1, *, progress: Progress = None) -> Dict[str, Any]: ...
def nrmse(y: _ArrayLike, yhat: _ArrayLike) -> float: ...
