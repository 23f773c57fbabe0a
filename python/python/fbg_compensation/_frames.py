"""Inputs and outputs as frames: NumPy arrays, pandas or polars DataFrames with the dataset's
column names (``t_s`` [s], ``T_amb_C`` [°C], ``dl1_pm``..``dlN_pm`` [pm], the measurands
``T_C`` [°C], ``strain_ue`` [µε], ``p_kPa`` [kPa], ...), converted to the column dict the Rust
core takes. No per-row Python loop: every conversion is a whole-column NumPy operation."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _core

#: The ambient thermometer's column [°C].
T_AMB = "T_amb_C"
#: Time since the start of the record [s].
T_S = "t_s"
#: The outputs of the paper's installation, in the model's order.
PAPER_OUTPUTS = ("T_C", "strain_ue", "p_kPa")
#: The flag bits of an estimate and their names, from ``fbg_shared::Flags`` itself.
FLAG_BITS = tuple(_core.flag_bits())


def grating_column(g: int) -> str:
    """The column of grating ``g`` (1-based): its wavelength shift [pm]."""
    return f"dl{g}_pm"


def is_frame(x: Any) -> bool:
    """A pandas or polars DataFrame (anything with named columns)."""
    return hasattr(x, "columns") and not isinstance(x, np.ndarray)


def kind_of(x: Any) -> str:
    """``pandas``, ``polars`` or ``numpy``: what the outputs should look like."""
    mod = type(x).__module__
    if mod.startswith("pandas"):
        return "pandas"
    if mod.startswith("polars"):
        return "polars"
    return "numpy"


def floats(x: Any, what: str) -> np.ndarray:
    """``x`` as a contiguous float64 array; what cannot be one is a ValueError naming ``what``."""
    try:
        return np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    except (TypeError, ValueError, OverflowError) as e:
        raise ValueError(f"{what}: not numbers ({str(e)[:80]})") from None


def column(x: Any, name: str) -> np.ndarray:
    """One column of a frame as a contiguous float64 array."""
    try:
        v = x[name]
    except (KeyError, IndexError, TypeError):
        raise ValueError(f"no column {name}") from None
    out = floats(v, f"column {name}")
    if out.ndim != 1:
        raise ValueError(f"column {name}: {out.shape} values, one per row expected (a name that appears twice?)")
    return out


def names_of(x: Any) -> List[str]:
    """The column names of a frame."""
    return [str(c) for c in x.columns]


def gratings_in(names: Sequence[str]) -> int:
    """The number of ``dlN_pm`` columns numbered from 1 without holes."""
    g = 0
    while grating_column(g + 1) in names:
        g += 1
    return g


def input_columns(
    X: Any, *, gratings: Optional[int], ambient: Optional[bool], where: str
) -> Tuple[Dict[str, np.ndarray], Optional[np.ndarray]]:
    """The input columns of ``X`` (``dl1_pm``.., ``T_amb_C``) and its ``t_s`` when it has one.

    A frame is read by column name; an array's columns are ``dl1_pm..dlN_pm`` then ``T_amb_C``
    when ``ambient`` (N = ``gratings``, or all the other columns when ``gratings`` is None)."""
    if is_frame(X):
        names = names_of(X)
        g = gratings_in(names)
        if g == 0:
            raise ValueError(f"{where}: X has no grating column (dl1_pm, dl2_pm, ...); it has {names}")
        cols = {grating_column(i + 1): column(X, grating_column(i + 1)) for i in range(g)}
        if T_AMB in names:
            cols[T_AMB] = column(X, T_AMB)
        t = column(X, T_S) if T_S in names else None
        return cols, t
    a = floats(X, f"{where}: X")
    if a.ndim != 2:
        raise ValueError(f"{where}: X must be 2-D (rows × [dl1_pm..dlN_pm, T_amb_C]); it has shape {a.shape}")
    amb = True if ambient is None else ambient
    g = a.shape[1] - int(amb) if gratings is None else gratings
    if g < 1 or a.shape[1] != g + int(amb):
        raise ValueError(
            f"{where}: X has {a.shape[1]} columns; the model reads {g} gratings"
            + (" and T_amb_C" if amb else "")
        )
    cols = {grating_column(i + 1): np.ascontiguousarray(a[:, i]) for i in range(g)}
    if amb:
        cols[T_AMB] = np.ascontiguousarray(a[:, g])
    return cols, None


def time_column(t: Any, from_x: Optional[np.ndarray], n: int, where: str) -> np.ndarray:
    """The time [s] of each row: ``t`` when given, else X's ``t_s`` column."""
    if t is None:
        if from_x is None:
            raise ValueError(f"{where}: give t= (time since the start, s) or a t_s column in X")
        out = from_x
    else:
        out = floats(t, f"{where}: t").reshape(-1)
    if out.shape[0] != n:
        raise ValueError(f"{where}: t has {out.shape[0]} values for {n} rows")
    return out


def target_columns(y: Any, outputs: Optional[Sequence[str]], where: str) -> Dict[str, np.ndarray]:
    """The reference columns of ``y``: a frame's by name, an array's named by ``outputs``
    (the paper's ``T_C, strain_ue, p_kPa`` for three columns when None)."""
    if is_frame(y):
        return {n: column(y, n) for n in names_of(y)}
    if hasattr(y, "name") and getattr(y, "ndim", 2) == 1:  # a named Series
        return {str(y.name): floats(y, f"{where}: y")}
    a = floats(y, f"{where}: y")
    if a.ndim == 1:
        a = a.reshape(-1, 1)
    if a.ndim != 2:
        raise ValueError(f"{where}: y must be 1-D or 2-D; it has shape {a.shape}")
    names = list(outputs) if outputs is not None else (list(PAPER_OUTPUTS) if a.shape[1] == 3 else None)
    if names is not None and not all(isinstance(n, str) for n in names):
        raise ValueError(f"{where}: outputs: {names!r:.60} are not all column names (strings)")
    if names is None or len(names) != a.shape[1]:
        raise ValueError(
            f"{where}: y has {a.shape[1]} columns; name them with outputs=[...] (T_C, strain_ue, p_kPa, ...)"
        )
    return {n: np.ascontiguousarray(a[:, i]) for i, n in enumerate(names)}


def flag_names(flags: np.ndarray) -> np.ndarray:
    """The names of each row's flags as ``compensate`` writes them (``ok``, or names joined by
    ``|``), computed per distinct flag value (at most 32), not per row."""
    flags = np.asarray(flags, dtype=np.uint8)
    out = np.empty(flags.shape[0], dtype=object)
    for v in np.unique(flags):
        names = [n for b, n in FLAG_BITS if int(v) & b]
        out[flags == v] = "|".join(names) if names else "ok"
    return out


def shape_output(values: np.ndarray, names: Sequence[str], like: Any, index: Any = None) -> Any:
    """``values`` (rows × outputs) as ``like`` is: a pandas/polars DataFrame with the output
    names, else the array itself."""
    kind = kind_of(like)
    if kind == "pandas":
        import pandas as pd

        # `values` is the caller's own new array: the frame takes it without a copy.
        return pd.DataFrame(values, columns=list(names), index=index if index is not None else like.index, copy=False)
    if kind == "polars":
        import polars as pl

        return pl.DataFrame({n: values[:, i] for i, n in enumerate(names)})
    return values


def frame_of(
    columns: Dict[str, np.ndarray],
    split: Optional[List[str]],
    t0_unix_s: Optional[float],
    zero: Optional[List[Tuple[Optional[float], str]]] = None,
) -> Any:
    """A record's columns as a pandas DataFrame (``attrs['t0_unix_s']`` the absolute time of
    ``t_s = 0``, ``attrs['zero']`` its zero: ``[lambda_ref_nm or None, source]`` per grating,
    empty when the record states none), or as the dict itself (with ``split``) when pandas is
    absent."""
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - pandas is optional
        out = dict(columns)
        if split is not None:
            out["split"] = np.asarray(split, dtype=object)
        return out
    df = pd.DataFrame(columns)
    if split is not None:
        df["split"] = pd.Categorical(split, categories=["cal", "holdout"])
    df.attrs["t0_unix_s"] = t0_unix_s
    df.attrs["zero"] = [list(z) for z in (zero or [])]
    return df
