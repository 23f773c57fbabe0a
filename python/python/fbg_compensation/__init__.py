"""fbg_compensation: the FBG hybrid compensator from Python, over the same Rust core the
device runs (``fbg-shared``) and the trainer (``fbg-trainer``).

- :class:`HybridCompensator`, :class:`ModelP`: scikit-learn-style estimators
  (``fit(X, y, t=...)``, ``predict(X, t=..., return_band=, return_flags=)``, ``score``);
- :class:`Model`: a ``.fbgm`` file (load, save signed or not, ``inspect``, coefficient tables,
  ``predict`` in f64 or the device's f32), :class:`Stream` for records fed in chunks;
- :func:`simulate`, :func:`read_dataset`, :func:`import_file`: records as DataFrames; :func:`compensate`: the
  CLI's ``compensate`` on a frame, bit for bit; :func:`compensate_file`: the CLI's itself.

Units are in the column names: ``t_s`` [s], ``T_amb_C`` and ``T_C`` [°C], ``dlN_pm`` [pm]
wavelength shifts, ``strain_ue`` [µε], ``p_kPa`` [kPa]. Errors are :class:`FbgError` (a
``ValueError``) with the command line's message (file, line, column)."""

from ._core import FbgError
from .estimators import HybridCompensator, ModelP
from .model import Model, Stream, compensate
from .records import compensate_file, import_file, presets, read_dataset, simulate, write_dataset

__all__ = [
    "FbgError",
    "HybridCompensator",
    "Model",
    "ModelP",
    "Stream",
    "compensate",
    "compensate_file",
    "presets",
    "read_dataset",
    "import_file",
    "simulate",
    "write_dataset",
]
__version__ = "0.1.0"
