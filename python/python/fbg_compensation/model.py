"""A model file (``.fbgm``, Model-H or Model-P) and running it: one pass over a record or an
explicit stream fed in chunks, in the host's f64 or the device's f32 arithmetic."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _core
from . import _frames as F

PathLike = Union[str, "os.PathLike[str]"]


class Stream:
    """The compensator's state over one stream of rows: ``predict`` on consecutive chunks gives
    exactly what one ``predict`` over the whole record gives (the memory terms, direction
    latches and drift observer carry over).

    ``precision``: ``"f64"`` (the host's arithmetic) or ``"f32"`` (the device's, on inputs
    rounded to f32). ``t0_unix_s``: the absolute time (Unix s, UTC) of ``t_s = 0``; without it
    the 95 % band takes the model's largest validated lead and every row is flagged
    ``lead-unknown`` (as ``fbg-trainer compensate`` does for a record without its start)."""

    def __init__(self, model: "Model", precision: str = "f64", t0_unix_s: Optional[float] = None) -> None:
        self.model = model
        self._s = _core.Stream(model._m, _text("precision", precision), _unix_time("t0_unix_s", t0_unix_s))

    @property
    def rows(self) -> int:
        """Rows compensated so far."""
        return self._s.rows

    def step_arrays(self, dl_pm: np.ndarray, t_amb_c: Optional[np.ndarray], t_s: np.ndarray):
        """The raw step: ``dl_pm`` (rows × gratings [pm]), ``t_amb_c`` [°C], ``t_s`` [s] ->
        (values, band95, flags) as arrays, values and band in the outputs' units."""
        dl = F.floats(dl_pm, "step_arrays: dl_pm")
        if dl.ndim != 2:
            raise ValueError(f"step_arrays: dl_pm must be 2-D (rows × gratings); it has shape {dl.shape}")
        t = F.floats(t_s, "step_arrays: t_s")
        amb = None if t_amb_c is None else F.floats(t_amb_c, "step_arrays: t_amb_c")
        for name, v in (("t_s", t), ("t_amb_c", amb)):
            if v is not None and v.ndim != 1:
                raise ValueError(f"step_arrays: {name} must be 1-D (one value per row); it has shape {v.shape}")
        return self._s.step(dl, amb, t)

    def predict(self, X: Any, t: Any = None, *, return_band: bool = False, return_flags: bool = False):
        """Compensate the next rows of the stream. ``X``: a frame with ``dl1_pm..dlN_pm``
        [pm] and ``T_amb_C`` [°C] (and ``t_s`` [s] when ``t`` is not given) or an array with
        those columns in that order. Returns the measurands (a frame with their column names
        when X is one), then the 95 % half-bands (same units) and the flags when asked."""
        m = self.model
        cols, tx = F.input_columns(X, gratings=m.gratings, ambient=m.ambient, where="predict")
        n = next(iter(cols.values())).shape[0]
        tt = F.time_column(t, tx, n, "predict")
        g = F.gratings_in(list(cols))
        if g != m.gratings:
            raise _core.FbgError(
                f"predict: X has {g} grating columns; the model reads {m.gratings} (dl1_pm..dl{m.gratings}_pm)"
            )
        if m.ambient and F.T_AMB not in cols:
            raise _core.FbgError("predict: the model reads the ambient thermometer and X has no T_amb_C column")
        # The columns as they are (contiguous float64 each), not copied into a matrix.
        dl = [cols[F.grating_column(i + 1)] for i in range(g)]
        amb = cols.get(F.T_AMB)
        values, band, flags = self._s.step(dl, amb, tt)
        out = [F.shape_output(values, m.outputs, X)]
        if return_band:
            out.append(F.shape_output(band, [f"{o}_band95" for o in m.outputs], X))
        if return_flags:
            out.append(flags)
        return out[0] if len(out) == 1 else tuple(out)


class Model:
    """A model as ``fbg-trainer`` writes it and a device loads it (``Model.load(path)``). The
    file is the blob of f32 coefficients (signed or not); the host runs it in f64 or f32."""

    def __init__(self, core_model: "_core.Model") -> None:
        self._m = core_model

    @classmethod
    def load(cls, path: PathLike) -> "Model":
        """Read and fully validate a model file; errors (``FbgError``) name the file."""
        return cls(_core.Model.load(os.fspath(path)))

    @classmethod
    def from_bytes(cls, data: bytes, source: str = "<bytes>") -> "Model":
        """A model from a file's bytes; ``source`` names them in errors."""
        return cls(_core.Model.from_bytes(bytes(data), source))

    def to_bytes(self) -> bytes:
        """The file's bytes (a signature trailer included when signed)."""
        return self._m.to_bytes()

    def blob_bytes(self) -> bytes:
        """The blob alone, without a signature trailer."""
        return self._m.blob_bytes()

    def save(
        self,
        path: PathLike,
        *,
        key: Optional[PathLike] = None,
        serial: Optional[int] = None,
        state_dir: Optional[PathLike] = None,
    ) -> Optional[Dict[str, Any]]:
        """Write the model atomically; with ``key`` (an Ed25519 PEM from ``fbg-trainer
        keygen``) signed as ``fbg-trainer sign`` signs, the serial the key's next unless given.
        Returns the signature record (key id, serial) or None."""
        rec = self._m.save(
            os.fspath(path),
            None if key is None else os.fspath(key),
            serial,
            None if state_dir is None else os.fspath(state_dir),
        )
        return None if rec is None else json.loads(rec)

    def inspect(self, pubkey: Optional[PathLike] = None) -> Dict[str, Any]:
        """The audit view as a dict: ``model`` (the coefficients as ``fbg-trainer inspect
        --json`` shows them), ``signature`` (verified against ``pubkey`` when given), sizes."""
        return json.loads(self._m.inspect_json(None if pubkey is None else os.fspath(pubkey)))

    @property
    def outputs(self) -> list:
        """The output columns in order (``T_C`` [°C], ``strain_ue`` [µε], ``p_kPa`` [kPa], ...)."""
        return list(self._m.outputs)

    @property
    def gratings(self) -> int:
        """Gratings the model reads (``dl1_pm..dlN_pm``)."""
        return self._m.gratings

    @property
    def ambient(self) -> bool:
        """Whether the model reads the ambient thermometer ``T_amb_C``."""
        return self._m.ambient

    @property
    def is_model_p(self) -> bool:
        """Model-P (polynomial core alone) rather than Model-H."""
        return self._m.is_model_p

    def stream(self, precision: str = "f64", t0_unix_s: Optional[float] = None) -> Stream:
        """A fresh stream state for chunked prediction (see :class:`Stream`)."""
        return Stream(self, precision, t0_unix_s)

    def predict(
        self,
        X: Any,
        t: Any = None,
        *,
        precision: str = "f64",
        t0_unix_s: Optional[float] = None,
        return_band: bool = False,
        return_flags: bool = False,
    ):
        """One pass over a record from its first row (see :meth:`Stream.predict`). Without
        ``t0_unix_s`` a pandas frame's ``attrs['t0_unix_s']`` is used when it has one."""
        if t0_unix_s is None:
            t0_unix_s = _attrs_t0(X)
        return self.stream(precision, t0_unix_s).predict(X, t, return_band=return_band, return_flags=return_flags)

    def coefficients(self) -> Dict[str, Any]:
        """The coefficient tables as DataFrames (dicts of arrays without pandas): ``poly``
        (output × polynomial term, on the standardised first guesses), ``stage1`` (the
        linear first guess per output), ``centres`` (RBF centres in physical units and their
        weights per output)."""
        m = self.inspect()["model"]
        outs = self.outputs
        poly = {o: m["poly_B_standardised_guesses"][o] for o in outs}
        s1 = m["stage1_linear_inverse"]
        stage1 = {o: dict(zip(s1["columns"], s1[o])) for o in outs}
        inputs = m["rbf_input_scalers"]["inputs"]
        rows = []
        for c in m["rbf_centres"]:
            row = {f"mu_{n}": v for n, v in zip(inputs, c["mu_physical"]) if v is not None}
            row.update({f"w_{o}": c["w"][o] for o in outs})
            rows.append(row)
        try:
            import pandas as pd
        except ImportError:  # pragma: no cover
            return {"poly": poly, "stage1": stage1, "centres": rows}
        return {
            "poly": pd.DataFrame(poly).T,
            "stage1": pd.DataFrame(stage1).T,
            "centres": pd.DataFrame(rows),
        }


def _unix_time(name: str, v: Any) -> Optional[float]:
    """``v`` as a finite absolute time (Unix s) or None; otherwise a ValueError naming ``name``."""
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: {v!r:.40} is not a time (Unix seconds, a number) or None")
    t = float(v)
    if not np.isfinite(t):
        raise ValueError(f"{name}: {t} is not a finite time (Unix seconds)")
    return t


def _number(name: str, v: Any) -> Optional[float]:
    """``v`` as a float or None; a non-number is a ValueError naming ``name`` (the range is
    the Rust core's to check)."""
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: {v!r:.40} is not a number")
    return float(v)


def _text(name: str, v: Any) -> str:
    """``v`` when it is a string; otherwise a ValueError naming ``name``."""
    if not isinstance(v, str):
        raise ValueError(f"{name}: {v!r:.40} is not a string")
    return v


def _attrs_t0(X: Any) -> Optional[float]:
    attrs = getattr(X, "attrs", None)
    if isinstance(attrs, dict):
        return _unix_time("attrs['t0_unix_s']", attrs.get("t0_unix_s"))
    return None


def _zero(name: str, zero: Any) -> Optional[List[Tuple[Optional[float], str]]]:
    """A record's zero (``[lambda_ref_nm or None, source]`` per grating, as :func:`read_dataset`
    sets ``attrs['zero']``) as the trainer takes it, or a ValueError naming ``name``; None for
    None."""
    if zero is None:
        return None
    try:
        return [(None if nm is None else float(nm), str(source)) for nm, source in zero]
    except (TypeError, ValueError):
        raise ValueError(f"{name}: {zero!r:.60} is not a list of [lambda_ref_nm, source] pairs") from None


def _attrs_zero(X: Any) -> Optional[List[Tuple[Optional[float], str]]]:
    """The calibration zero a frame states in ``attrs['zero']`` (as :func:`read_dataset` and
    :func:`simulate` set it), or None."""
    attrs = getattr(X, "attrs", None)
    return _zero("attrs['zero']", attrs.get("zero")) if isinstance(attrs, dict) else None


def compensate(model: Union[Model, PathLike], frame: Any, *, precision: str = "f64", t0_unix_s: Optional[float] = None):
    """``fbg-trainer compensate`` on a frame: a frame with the columns the CLI writes —
    ``t_s``, each measurand and its ``_band95``, ``flags``, ``flag_names`` — holding the same
    numbers, bit for bit. Gaps (NaN inputs) stay NaN. ``frame`` needs ``t_s``; its
    ``attrs['t0_unix_s']`` (as :func:`read_dataset` sets it) gives the band's clock."""
    m = model if isinstance(model, Model) else Model.load(model)
    if t0_unix_s is None:
        t0_unix_s = _attrs_t0(frame)
    if F.is_frame(frame) and F.T_S not in F.names_of(frame):
        raise ValueError("compensate: frame has no t_s column (time since the start, s)")
    t = F.column(frame, F.T_S) if F.is_frame(frame) else None
    values, band, flags = m.stream(precision, t0_unix_s).predict(frame, t, return_band=True, return_flags=True)
    cols: Dict[str, Any] = {F.T_S: t}
    v = np.asarray(values)
    b = np.asarray(band)
    for i, o in enumerate(m.outputs):
        cols[o] = v[:, i]
        cols[f"{o}_band95"] = b[:, i]
    cols["flags"] = flags
    cols["flag_names"] = F.flag_names(flags)
    if F.kind_of(frame) == "pandas":
        import pandas as pd

        return pd.DataFrame(cols, index=frame.index)
    if F.kind_of(frame) == "polars":
        import polars as pl

        return pl.DataFrame(cols)
    return cols
