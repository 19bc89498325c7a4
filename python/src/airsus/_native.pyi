"""Type stub of the native module `airsus._native` (python/rust/src). Internal: use `airsus`."""

from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

_Array = npt.NDArray[np.float64]
# (path, None, None) for a file, or (None, name, [(column, float64 array), ...]).
_RunSpec = Tuple[Optional[str], Optional[str], Optional[Sequence[Tuple[str, _Array]]]]
_Progress = Optional[Callable[[Dict[str, Any]], Any]]

class AirsusError(ValueError):
    """An input airsus rejects; the message is the `airsus` command's."""

class NativeTruck:
    @staticmethod
    def load(path: str) -> NativeTruck: ...
    @staticmethod
    def from_toml(text: str, name: str) -> NativeTruck: ...
    @staticmethod
    def builtin() -> NativeTruck: ...
    @staticmethod
    def names() -> List[str]: ...
    def save(self, path: str) -> None: ...
    def to_toml(self) -> str: ...
    def get(self, name: str) -> float: ...
    def set(self, name: str, value: float) -> None: ...
    def table(self) -> List[Tuple[str, str, str, float, float, float]]: ...
    def defaulted(self) -> List[Tuple[str, str]]: ...
    def copy(self) -> NativeTruck: ...
    def equals(self, other: NativeTruck) -> bool: ...

class NativeLinearModel:
    def simulate(self, u: Sequence[_Array]) -> _Array: ...
    def predict(self, y: _Array, u: Sequence[_Array], k: int) -> _Array: ...
    def n_inputs(self) -> int: ...

def read_run(path: str) -> Dict[str, Any]: ...
def write_run(run: _RunSpec, path: str) -> None: ...
def simulate(
    model: str,
    truck: NativeTruck,
    run: _RunSpec,
    initial_kind: Optional[str] = None,
    initial_value: Optional[float] = None,
    initial_state: Optional[_Array] = None,
    rtol: Optional[float] = None,
    method: Optional[str] = None,
    states: bool = False,
    load_ramp_s: Optional[float] = None,
    load_transitions_s: Optional[Sequence[float]] = None,
) -> Dict[str, Any]: ...
def greybox(
    model: str,
    truck: NativeTruck,
    runs: Sequence[_RunSpec],
    free: Sequence[str],
    bounds: Optional[Sequence[Tuple[str, float, float]]] = None,
    max_iterations: Optional[int] = None,
    tolerance: Optional[float] = None,
    initial: Optional[str] = None,
    height_weight: Optional[float] = None,
    pressure_weight: Optional[float] = None,
    max_relative_std: Optional[float] = None,
    keep_unidentifiable: bool = False,
    progress: _Progress = None,
    normalisation: Optional[str] = None,
    initial_state: Optional[str] = None,
    load_ramp: Optional[str] = None,
    force_map: Optional[str] = None,
    force_map_noise_n: Optional[float] = None,
    allow_trades: bool = False,
) -> Dict[str, Any]: ...
def ident(
    data: _RunSpec,
    structure: str,
    inputs: Sequence[str],
    output: str,
    na: Optional[int] = None,
    nb: Optional[Sequence[int]] = None,
    nc: Optional[int] = None,
    nd: Optional[int] = None,
    nf: Optional[Sequence[int]] = None,
    nk: Optional[Sequence[int]] = None,
    ts_s: Optional[float] = None,
    detrend: bool = False,
    merge: Optional[Sequence[_RunSpec]] = None,
) -> Dict[str, Any]: ...
def models() -> List[Dict[str, Any]]: ...
def weigh(
    truck: NativeTruck,
    run: _RunSpec,
    method: Optional[str] = None,
    model: Optional[str] = None,
    window_s: Optional[float] = None,
    calibration_run: Optional[List[_RunSpec]] = None,
    start_hysteresis: Optional[str] = None,
    calibration_start: Optional[List[str]] = None,
    loading_shift_kpa: Optional[float] = None,
    loading_window_s: Optional[float] = None,
    loading_hold_s: Optional[float] = None,
) -> Dict[str, Any]: ...
def study(
    study_file: Optional[str],
    out: str,
    models: Optional[Sequence[str]] = None,
    max_iterations: Optional[int] = None,
    seed: Optional[int] = None,
    progress: _Progress = None,
    initial_state: Optional[str] = None,
    normalisation: Optional[str] = None,
    starts: Optional[int] = None,
    screen: Optional[int] = None,
    variant: Optional[int] = None,
    load_ramp: Optional[str] = None,
    exclude_after_load_change_s: Optional[float] = None,
    validation_transitions: Optional[str] = None,
    prefix_s: Optional[float] = None,
    allow_trades: bool = False,
) -> Dict[str, Any]: ...
def generate(out: str, seed: int = 1, progress: _Progress = None) -> Dict[str, Any]: ...
def nrmse(measured: _Array, simulated: _Array) -> float: ...
def standstills(
    truck: NativeTruck,
    time_s: _Array,
    height_mm: _Array,
    pressure_kpa: _Array,
    valve: _Array,
    speed_kmh: Optional[_Array] = None,
    segment: Optional[_Array] = None,
    settle_s: float = 120.0,
    min_duration_s: float = 20.0,
) -> Dict[str, _Array]: ...
def gas_amount_mol(
    truck: NativeTruck, height_mm: _Array, pressure_kpa: _Array, temperature_k: _Array
) -> _Array: ...
