"""The estimators in scikit-learn's shape: :class:`HybridCompensator` (Model-H: polynomial
core, memory terms and RBF residual) and :class:`ModelP` (the polynomial core alone), fitted
by the trainer's ``train`` (cross-validated hyper-parameters) on the Rust core.

They inherit scikit-learn's ``BaseEstimator`` and ``RegressorMixin`` when scikit-learn is
importable (so ``clone``, ``Pipeline``, ``cross_val_score`` with a ``TimeSeriesSplit`` work),
else a minimal base with the same ``get_params``/``set_params``; ``score`` is their own (R²
averaged over the outputs, as scikit-learn's, with ``t`` passed on to ``predict``)."""

from __future__ import annotations

import json
import numbers
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _core
from . import _frames as F
from .model import Model, Stream, _attrs_t0, _attrs_zero, _text, _unix_time, _zero

try:  # scikit-learn is optional
    from sklearn.base import BaseEstimator as _Base
    from sklearn.base import RegressorMixin as _Regressor

    _HAVE_SKLEARN = True
except ImportError:  # pragma: no cover - exercised only without scikit-learn
    _HAVE_SKLEARN = False

    class _Base:  # type: ignore[no-redef]
        """``get_params``/``set_params`` from the constructor's keyword arguments."""

        def get_params(self, deep: bool = True) -> Dict[str, Any]:
            import inspect

            names = [p for p in inspect.signature(type(self).__init__).parameters if p != "self"]
            return {n: getattr(self, n) for n in names}

        def set_params(self, **params: Any) -> "_Base":
            valid = self.get_params()
            for k, v in params.items():
                if k not in valid:
                    raise ValueError(f"invalid parameter {k!r} for {type(self).__name__}")
                setattr(self, k, v)
            return self

    class _Regressor:  # type: ignore[no-redef]
        """The regressor's mixin; ``score`` is the estimators' own (it takes ``t``)."""


class _NotFitted(ValueError, AttributeError):
    """Raised by ``predict`` before ``fit`` (scikit-learn's ``NotFittedError`` when present)."""


def _not_fitted(name: str) -> Exception:
    msg = f"This {name} instance is not fitted yet. Call 'fit' with appropriate arguments before using this estimator."
    if _HAVE_SKLEARN:
        from sklearn.exceptions import NotFittedError

        return NotFittedError(msg)
    return _NotFitted(msg)


class _Compensator(_Base, _Regressor):
    """What both estimators share: the fit through ``fbg-trainer train`` and the prediction
    through the compensator the device runs."""

    _which = "h"

    def __init__(
        self,
        features: str = "memory",
        max_centres: int = 32,
        on_outlier: str = "fail",
        seed: Optional[int] = None,
        precision: str = "f64",
        outputs: Optional[Sequence[str]] = None,
        fixed: Optional[Dict[str, Any]] = None,
        drift_spec: Optional[float] = None,
        drift_gains: Optional[Sequence[float]] = None,
    ) -> None:
        self.features = features
        self.max_centres = max_centres
        self.on_outlier = on_outlier
        self.seed = seed
        self.precision = precision
        self.outputs = outputs
        self.fixed = fixed
        self.drift_spec = drift_spec
        self.drift_gains = drift_gains

    # --- fit -------------------------------------------------------------------------------
    def fit(self, X: Any, y: Any, t: Any = None, *, t0_unix_s: Optional[float] = None, zero: Any = None, cal: Any = None):
        """Fit on the calibration rows. ``X``: ``dl1_pm..dlN_pm`` [pm] and ``T_amb_C`` [°C]
        (a frame by name; an array in that order); ``y``: the reference measurands (``T_C``
        [°C], ``strain_ue`` [µε], ``p_kPa`` [kPa], ...; an array's columns named by
        ``outputs``, the paper's three by default); ``t``: time since the start [s] (or a
        ``t_s`` column in X), in order and on the record's clock; ``cal``: a boolean mask of
        the rows that calibrate (default all; the others still run through the stream);
        ``t0_unix_s`` and ``zero`` (per grating ``(lambda_ref_nm or None, source)``) the record's
        clock and calibration zero, by default a frame's ``attrs`` (as :func:`read_dataset`
        sets them): the model carries both, as ``fbg-trainer train`` takes them from the
        record. Errors (``FbgError``) carry the trainer's message."""
        # Types and signs here; the trainer checks the range of max_centres.
        max_centres, seed = _whole("max_centres", self.max_centres, 0, 2**31), self.seed
        if seed is not None:
            seed = _whole("seed", seed, 0, 2**64 - 1)
        cols, tx = F.input_columns(X, gratings=None, ambient=None, where="fit")
        n = next(iter(cols.values())).shape[0]
        cols[F.T_S] = F.time_column(t, tx, n, "fit")
        targets = F.target_columns(y, self.outputs, "fit")
        for name, v in targets.items():
            if v.shape[0] != n:
                raise ValueError(f"fit: y column {name} has {v.shape[0]} values for {n} rows of X")
        cols.update(targets)
        mask = None if cal is None else [bool(b) for b in np.asarray(cal, dtype=bool)]
        t0_unix_s = _attrs_t0(X) if t0_unix_s is None else _unix_time("t0_unix_s", t0_unix_s)
        if self.fixed is not None and not isinstance(self.fixed, dict):
            raise ValueError(f"fixed: {self.fixed!r:.40} is not a dict (or None)")
        h, p, coefficients, summary = _core.fit(
            cols,
            mask,
            _text("features", self.features),
            max_centres,
            _text("on_outlier", self.on_outlier),
            seed,
            t0_unix_s,
            "<frame>",
            None,
            0,
            self.fixed,
            targets=list(targets),
            precision=_text("precision", self.precision),
            drift_spec=None if self.drift_spec is None else _number("drift_spec", self.drift_spec),
            zero=_attrs_zero(X) if zero is None else _zero("zero", zero),
            drift_gains=_gains("drift_gains", self.drift_gains),
        )
        self.model_h_ = Model(h)
        self.model_p_ = Model(p)
        self.model_ = self.model_h_ if self._which == "h" else self.model_p_
        self.coefficients_json_ = json.loads(coefficients)
        self.fit_summary_ = json.loads(summary)
        self.outputs_ = self.model_.outputs
        self.n_gratings_ = self.model_.gratings
        self.ambient_ = self.model_.ambient
        if F.is_frame(X):
            self.feature_names_in_ = np.asarray(F.names_of(X), dtype=object)
        self.n_features_in_ = len(F.names_of(X)) if F.is_frame(X) else np.asarray(X).shape[1]
        return self

    # --- predict ---------------------------------------------------------------------------
    def _model(self) -> Model:
        m = getattr(self, "model_", None)
        if m is None:
            raise _not_fitted(type(self).__name__)
        return m

    def predict(
        self,
        X: Any,
        t: Any = None,
        *,
        t0_unix_s: Optional[float] = None,
        return_band: bool = False,
        return_flags: bool = False,
    ):
        """The measurands of every row, in one pass from the first row (the stream's state
        starts fresh): a frame with the output names when X is one, else an array (rows ×
        outputs, units of the outputs). ``return_band``: also the 95 % half-bands (same
        units); ``return_flags``: also the flags (uint8 bits: 1 non-finite, 2 out of the
        calibration envelope, 4 weak RBF support, 8 lead unknown, 16 implausible)."""
        return self._model().predict(
            X,
            t,
            precision=self.precision,
            t0_unix_s=t0_unix_s,
            return_band=return_band,
            return_flags=return_flags,
        )

    def score(self, X: Any, y: Any, t: Any = None, sample_weight: Any = None, *, t0_unix_s: Optional[float] = None) -> float:
        """The coefficient of determination R² of ``predict(X, t)`` against ``y``, averaged
        over the outputs (scikit-learn's ``r2_score``); ``t`` as for :meth:`predict`."""
        pred = np.asarray(self.predict(X, t, t0_unix_s=t0_unix_s), dtype=np.float64)
        if F.is_frame(y):  # by name, in the model's output order
            truth = np.column_stack([F.column(y, o) for o in self.outputs_])
        else:
            truth = F.floats(y, "score: y")
        if truth.size != pred.size:
            raise ValueError(f"score: y has {truth.size} values for {pred.shape[0]} rows × {pred.shape[1]} outputs")
        truth = truth.reshape(pred.shape)
        w = np.ones(pred.shape[0]) if sample_weight is None else F.floats(sample_weight, "score: sample_weight")
        if w.size != pred.shape[0]:
            raise ValueError(f"score: sample_weight has {w.size} values for {pred.shape[0]} rows")
        w = w.reshape(-1, 1)
        mean = (w * truth).sum(axis=0) / w.sum()
        ss_res = (w * (truth - pred) ** 2).sum(axis=0)
        ss_tot = (w * (truth - mean) ** 2).sum(axis=0)
        return float(np.mean(1.0 - ss_res / ss_tot))

    def stream(self, t0_unix_s: Optional[float] = None) -> Stream:
        """A fresh stream state to predict a long record chunk by chunk (same result)."""
        return self._model().stream(self.precision, t0_unix_s)

    def __sklearn_tags__(self):  # scikit-learn >= 1.6
        tags = super().__sklearn_tags__()  # type: ignore[misc]
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = False
        tags.input_tags.allow_nan = True
        return tags


def _whole(name: str, value: Any, lo: int, hi: Optional[int] = None) -> int:
    """``value`` as an int in ``lo..=hi``, or a ValueError naming the parameter: a float is
    refused rather than truncated (8.5 centres are not 8), and so is a bool."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name}: {value!r:.40} is not an integer")
    v = int(value)
    if v < lo:
        raise ValueError(f"{name}: {v} is below {lo}")
    if hi is not None and v > hi:
        raise ValueError(f"{name}: {v} is above {hi}")
    return v


def _number(name: str, value: Any) -> float:
    """``value`` as a float, or a ValueError naming the parameter (a bool or a string is not a
    number); its range is the trainer's to check."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name}: {value!r:.40} is not a number")
    return float(value)


def _gains(name: str, value: Any) -> Optional[List[float]]:
    """``value`` (None, or a sequence of numbers) as a list of floats, or a ValueError naming
    the parameter and the entry; their count and range are the trainer's to check."""
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise ValueError(f"{name}: {value!r:.40} is not a sequence of numbers (one per grating)")
    return [_number(f"{name}[{i}]", v) for i, v in enumerate(value)]


class HybridCompensator(_Compensator):
    """Model-H, the hybrid compensator (DESIGN §4): the polynomial core on the first-guess
    measurands, its memory terms, and the RBF residual with its 95 % band, fitted as
    ``fbg-trainer train --features FEATURES --max-centres K``.

    Parameters: ``features`` (``memory``, ``paper``, ``hysteresis-aware``, ``all``, ...: the
    feature sets cross-validation may choose from), ``max_centres`` (largest number of RBF
    centres, the device's capacity), ``on_outlier`` (``fail``: an outlying reference cell is
    an error naming file, line and column; ``skip``: its row is left out), ``seed`` (None:
    the trainer's default), ``precision`` (``f64`` host / ``f32`` device arithmetic for
    predict), ``outputs`` (names of y's columns when y is an array), ``fixed`` (one
    configuration instead of cross-validation, as ``fbg-trainer bench-fit --fixed``: a dict
    of ``feature_set``, ``k``, ``sigma_mult``, ``alpha_rel``, ``dead_band_pm``, ``memory``),
    ``drift_spec`` (the interrogator's stated stability as a random walk [pm/√day], as
    ``fbg-trainer train --drift-spec``: the band adds such a drift's walk through each
    output; None: the rate the calibration's errors show), ``drift_gains`` (the drift's
    relative gain per grating, in the order ``dl1_pm..dlN_pm``, as ``fbg-trainer train --drift-gains``; None:
    every grating drifts alike)."""

    _which = "h"


class ModelP(_Compensator):
    """Model-P, the polynomial core alone (the baseline the hybrid is measured against),
    from the same fit as :class:`HybridCompensator`; the parameters are the same."""

    _which = "p"
