"""Records: simulated (``simulate``) and read from dataset CSVs (``read_dataset``), as
DataFrames with the dataset's columns (``t_s`` [s], the measurands, ``T_amb_C`` [°C],
``dl1_pm``.. [pm], ``split``); ``attrs['t0_unix_s']`` is the absolute time of ``t_s = 0``,
``attrs['zero']`` the record's zero (``[lambda_ref_nm or None, source]`` per grating, empty
when it states none), which :func:`write_dataset` writes back to the sidecar."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Union

from . import _core
from . import _frames as F
from .model import _attrs_t0, _attrs_zero, _number, _text, _unix_time

PathLike = Union[str, "os.PathLike[str]"]


def presets() -> List[str]:
    """The built-in scenarios (``fbg-trainer simulate --preset``)."""
    return list(_core.presets())


def simulate(preset: str = "paper", seed: int = 7, days: Optional[float] = None, dt_s: Optional[float] = None) -> Any:
    """Simulate a built-in scenario, deterministically (``fbg-trainer simulate --preset P
    --seed S``); ``days`` changes the record's length, ``dt_s`` its sample interval [s].
    Returns a DataFrame (a dict of arrays without pandas)."""
    from .estimators import _whole

    seed = _whole("seed", seed, 0, 2**64 - 1)
    cols, split, t0, zero = _core.simulate(_text("preset", preset), seed, _number("days", days), _number("dt_s", dt_s))
    return F.frame_of(cols, split, t0, zero)


def read_dataset(path: PathLike, *, field: bool = False) -> Any:
    """Read a dataset CSV as ``train``/``evaluate`` do (``field=True``: a field record, no
    reference needed, as ``compensate`` reads it), with its sidecar's clock
    (``attrs['t0_unix_s']``) and zero (``attrs['zero']``: ``[lambda_ref_nm or None, source]``
    per grating, empty when the record states none). Errors (``FbgError``) name the file, line
    and column, with the command line's message."""
    # The record's zero (its sidecar's), read with its rows, so that write_dataset keeps it.
    cols, split, t0, zero = _core.read_dataset(os.fspath(path), field)
    return F.frame_of(cols, split, t0, zero)


def compensate_file(
    model: PathLike,
    data: PathLike,
    out: PathLike,
    *,
    precision: str = "f64",
    trust_units: bool = False,
    start_unix_s: Optional[float] = None,
) -> Dict[str, Any]:
    """``fbg-trainer compensate --model M --data D --out O`` itself (the same function, so the
    same file and checks); returns its JSON summary as a dict."""
    return json.loads(
        _core.compensate_file(
            os.fspath(model), os.fspath(data), os.fspath(out), precision, trust_units, _unix_time("start_unix_s", start_unix_s)
        )
    )


def write_dataset(frame: Any, path: PathLike) -> None:
    """Write a record (the columns :func:`simulate`/:func:`read_dataset` give, ``split``
    optional) as a dataset CSV and its ``.record.json`` sidecar, atomically, exactly as
    ``fbg-trainer simulate`` writes them: the clock from ``attrs['t0_unix_s']``, the zero from
    ``attrs['zero']`` (``[lambda_ref_nm or None, source]`` per grating, as
    :func:`read_dataset` sets it)."""
    names = F.names_of(frame) if F.is_frame(frame) else list(frame)
    cols = {n: F.column(frame, n) for n in names if n != "split"}
    cal = None
    if "split" in names:
        cal = [s == "cal" for s in (frame["split"].astype(str) if hasattr(frame["split"], "astype") else frame["split"])]
    _core.write_dataset(cols, os.fspath(path), cal, _attrs_t0(frame), _attrs_zero(frame))


def import_file(
    format: str,
    path: PathLike,
    *,
    map: Optional[PathLike] = None,
    refs: Optional[PathLike] = None,
    scale: Optional[str] = None,
    cal_fraction: float = 0.5,
    on_error: str = "fail",
    max_skipped: float = 0.05,
    start_unix_s: Optional[float] = None,
) -> Any:
    """``fbg-trainer import --format F FILE [--map M] [--refs R] [--scale S]`` itself, without
    the output file: an interrogator export (``enlight``, ``csv``) or spectra
    (``spectra-csv``, ``enlight-responses``, ``pixels``, whose peaks the detector finds) as a
    DataFrame with the dataset's columns; the import summary (rows, skips, gratings, flagged
    frames) in ``attrs['import_summary']``, its zero and clock in ``attrs['zero']`` and
    ``attrs['t0_unix_s']`` as :func:`read_dataset` gives them. Errors (``FbgError``) name the file, line and
    column, with the command line's message."""
    (cols, split, t0, zero), summary = _core.import_file(
        format,
        os.fspath(path),
        None if map is None else os.fspath(map),
        None if refs is None else os.fspath(refs),
        scale,
        cal_fraction,
        on_error,
        max_skipped,
        start_unix_s,
    )
    frame = F.frame_of(cols, split, t0, zero)
    if hasattr(frame, "attrs"):
        frame.attrs["import_summary"] = json.loads(summary)
    return frame
