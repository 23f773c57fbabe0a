"""Type stubs of the Rust core (``fbg_compensation._core``)."""

from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

class FbgError(ValueError):
    """An error of the compensator, with the command line's message."""

class Model:
    def __init__(self, data: bytes, source: str = "<bytes>") -> None: ...
    def __reduce__(self) -> Tuple[type, Tuple[bytes]]: ...
    @staticmethod
    def load(path: str) -> Model: ...
    @staticmethod
    def from_bytes(data: bytes, source: str = "<bytes>") -> Model: ...
    def to_bytes(self) -> bytes: ...
    def blob_bytes(self) -> bytes: ...
    def save(
        self, path: str, key: Optional[str] = None, serial: Optional[int] = None, state_dir: Optional[str] = None
    ) -> Optional[str]: ...
    def inspect_json(self, pubkey: Optional[str] = None) -> str: ...
    @property
    def outputs(self) -> List[str]: ...
    @property
    def gratings(self) -> int: ...
    @property
    def ambient(self) -> bool: ...
    @property
    def is_model_p(self) -> bool: ...

class Stream:
    def __init__(self, model: Model, precision: str = "f64", t0_unix_s: Optional[float] = None) -> None: ...
    def step(
        self,
        dl_pm: Union[npt.NDArray[np.float64], Sequence[npt.NDArray[np.float64]]],
        t_amb_c: Optional[npt.NDArray[np.float64]],
        t_s: npt.NDArray[np.float64],
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.uint8]]: ...
    @property
    def rows(self) -> int: ...
    @property
    def outputs(self) -> int: ...

Columns = Tuple[Dict[str, npt.NDArray[np.float64]], List[str], Optional[float], List[Tuple[Optional[float], str]]]

def fit(
    columns: Dict[str, npt.NDArray[np.float64]],
    cal: Optional[List[bool]] = None,
    features: str = "memory",
    max_centres: int = 32,
    on_outlier: str = "fail",
    seed: Optional[int] = None,
    t0_unix_s: Optional[float] = None,
    source: str = "<frame>",
    scenario: Optional[str] = None,
    sim_seed: int = 0,
    fixed: Optional[Dict[str, object]] = None,
    targets: Optional[List[str]] = None,
    precision: str = "f64",
    drift_spec: Optional[float] = None,
    zero: Optional[List[Tuple[Optional[float], str]]] = None,
    drift_gains: Optional[List[float]] = None,
) -> Tuple[Model, Model, str, str]: ...
def simulate(
    preset: str = "paper", seed: int = 7, days: Optional[float] = None, dt_s: Optional[float] = None
) -> Columns: ...
def flag_bits() -> List[Tuple[int, str]]: ...
def read_dataset(path: str, field: bool = False) -> Columns: ...
def import_file(
    format: str,
    path: str,
    map: Optional[str] = None,
    refs: Optional[str] = None,
    scale: Optional[str] = None,
    cal_fraction: float = 0.5,
    on_error: str = "fail",
    max_skipped: float = 0.05,
    start_unix_s: Optional[float] = None,
) -> Tuple[Columns, str]: ...
def compensate_file(
    model: str,
    data: str,
    out: str,
    precision: str = "f64",
    trust_units: bool = False,
    start_unix_s: Optional[float] = None,
) -> str: ...
def presets() -> List[str]: ...
def write_dataset(
    columns: Dict[str, npt.NDArray[np.float64]],
    path: str,
    cal: Optional[List[bool]] = None,
    t0_unix_s: Optional[float] = None,
    zero: Optional[List[Tuple[Optional[float], str]]] = None,
) -> None: ...
def record_zero(path: str) -> List[Tuple[Optional[float], str]]: ...
