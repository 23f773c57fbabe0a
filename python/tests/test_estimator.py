"""The estimators in scikit-learn's shape.

Which of scikit-learn's `check_estimator` checks apply: the compensator is a multi-output
*time-series* regressor that needs the time of every row (`t=` or a `t_s` column) and named
measurand outputs, so the generic checks that feed it random 2-D arrays without time cannot
run. What is checked here instead is the subset that fits: scikit-learn's own
check_get_params_invariance, check_parameters_default_constructible,
check_no_attributes_set_in_init and check_set_params (they need no fit), `clone`; and, written
here on a record with its time, `fit` returns self (check_fit_returns_self), predict before
fit raises NotFittedError (check_estimators_unfitted), determinism of refitting
(check_fit_idempotent), n_features_in_ and feature_names_in_ (check_n_features_in,
check_dataframe_column_names_consistency), and use in a Pipeline and in cross_val_score with a
TimeSeriesSplit."""

import numpy as np
import pandas as pd
import pytest

import fbg_compensation as fc
from conftest import FIT, INPUTS, OUTPUTS, same_bits

sklearn = pytest.importorskip("sklearn")
from sklearn.base import clone  # noqa: E402
from sklearn.exceptions import NotFittedError  # noqa: E402
from sklearn.model_selection import TimeSeriesSplit, cross_val_score  # noqa: E402
from sklearn.pipeline import Pipeline  # noqa: E402
from sklearn.preprocessing import FunctionTransformer  # noqa: E402


def test_params_round_trip_and_clone():
    est = fc.HybridCompensator(features="paper", max_centres=8, seed=3)
    p = est.get_params()
    assert p == dict(
        features="paper", max_centres=8, on_outlier="fail", seed=3, precision="f64", outputs=None, fixed=None, drift_spec=None,
        drift_gains=None,
    )
    est.set_params(max_centres=16, precision="f32")
    assert (est.max_centres, est.precision) == (16, "f32")
    c = clone(est)
    assert c.get_params() == est.get_params() and c is not est
    assert fc.ModelP().get_params()["features"] == "memory"
    with pytest.raises(ValueError):
        est.set_params(centres=4)


def test_no_attributes_set_in_init_and_unfitted(holdout):
    est = fc.HybridCompensator()
    assert not [k for k in vars(est) if k.endswith("_")]
    with pytest.raises(NotFittedError):
        est.predict(holdout[INPUTS], t=holdout["t_s"])


def test_fit_returns_self_and_is_deterministic(cal, holdout, fitted):
    est = fc.HybridCompensator(**FIT)
    assert est.fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"]) is est
    a = est.predict(holdout[INPUTS], t=holdout["t_s"])
    b = fitted.predict(holdout[INPUTS], t=holdout["t_s"])
    assert same_bits(a, b)
    assert list(a.columns) == OUTPUTS and a.index.equals(holdout.index)
    assert est.n_features_in_ == 4 and list(est.feature_names_in_) == INPUTS
    assert est.model_.blob_bytes() == fitted.model_.blob_bytes()


def test_dataframe_and_array_inputs_agree(holdout, fitted):
    frame = fitted.predict(holdout[INPUTS], t=holdout["t_s"])
    array = fitted.predict(holdout[INPUTS].to_numpy(), t=holdout["t_s"].to_numpy())
    assert isinstance(array, np.ndarray) and same_bits(frame.to_numpy(), array)
    # t_s as a column of X instead of t=, the columns in another order.
    shuffled = holdout[["t_s", "T_amb_C", "dl3_pm", "dl1_pm", "dl2_pm"]]
    assert same_bits(fitted.predict(shuffled).to_numpy(), array)


def test_array_fit_equals_frame_fit(cal, fitted):
    X, y, t = cal[INPUTS].to_numpy(), cal[OUTPUTS].to_numpy(), cal["t_s"].to_numpy()
    est = fc.HybridCompensator(**FIT).fit(X, y, t=t, t0_unix_s=cal.attrs["t0_unix_s"], zero=cal.attrs["zero"])
    assert est.model_.blob_bytes() == fitted.model_.blob_bytes()
    # Without the record's zero the model does not carry it.
    assert fc.HybridCompensator(**FIT).fit(X, y, t=t, t0_unix_s=cal.attrs["t0_unix_s"]).model_.blob_bytes() != fitted.model_.blob_bytes()
    # Without the record's start the model does not know its calibration's absolute end.
    other = fc.HybridCompensator(**FIT).fit(X, y, t=t)
    assert other.model_.blob_bytes() != fitted.model_.blob_bytes()
    assert est.outputs_ == OUTPUTS


def test_polars_inputs(holdout, fitted):
    pl = pytest.importorskip("polars")
    out = fitted.predict(pl.from_pandas(holdout[INPUTS + ["t_s"]]))
    assert isinstance(out, pl.DataFrame) and out.columns == OUTPUTS
    assert same_bits(out.to_numpy(), fitted.predict(holdout[INPUTS], t=holdout["t_s"]).to_numpy())


def test_band_and_flags(holdout, fitted):
    v, band, flags = fitted.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True, return_flags=True)
    assert list(band.columns) == [f"{o}_band95" for o in OUTPUTS]
    assert flags.dtype == np.uint8 and flags.shape == (len(holdout),)
    assert (band.to_numpy() > 0).all()
    # The frame carries the record's start (attrs["t0_unix_s"], as simulate/read_dataset set
    # it) and the model its calibration's end: the band's lead is known on every row.
    assert holdout.attrs["t0_unix_s"] is not None
    assert not (flags & 8).any()
    # An array carries no clock: every row is flagged lead-unknown (bit 8), and the band is
    # taken at one lead (the largest validated), not growing along the record as above.
    _, band_u, flags_u = fitted.predict(
        holdout[INPUTS].to_numpy(), t=holdout["t_s"].to_numpy(), return_band=True, return_flags=True
    )
    assert (flags_u & 8).all()
    b = band.to_numpy()
    assert (b[-1] > b[0]).all() and not same_bits(band_u, b)


def test_a_stated_drift_widens_the_band_with_the_lead(cal, holdout, fitted):
    # A day of calibration is too short to read the drift's walk from its errors (the
    # structure function needs 36-h stretches): a stated stability (a poor interrogator's,
    # so that it binds over this fit's own steep growth) makes the band grow faster.
    stated = fc.HybridCompensator(**FIT, drift_spec=500.0).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])
    v0, b0 = fitted.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True)
    v1, b1 = stated.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True)
    assert same_bits(v0, v1), "the stated drift changes the band only"
    growth0 = b0.to_numpy()[-1] - b0.to_numpy()[0]
    growth1 = b1.to_numpy()[-1] - b1.to_numpy()[0]
    # The drift moves every grating alike: temperature most, whose band grows faster and is
    # wider at the end; strain, read from the gratings' difference, hardly (the rest of its
    # band is refitted without the walk's share, so its growth may go either way).
    assert growth1[0] > growth0[0] and b1.to_numpy()[-1, 0] > b0.to_numpy()[-1, 0], (growth0, growth1)
    with pytest.raises(fc.FbgError, match="drift_spec: .*the stated drift is -1"):
        fc.HybridCompensator(**FIT, drift_spec=-1.0).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])
    with pytest.raises(ValueError, match="drift_spec: 'x' is not a number"):
        fc.HybridCompensator(**FIT, drift_spec="x").fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])


def test_drift_gains_carry_the_walk_per_grating(cal, holdout):
    # Gains of one are the plain sum bit for bit; other gains change the band, never the values.
    fit = lambda **kw: fc.HybridCompensator(**FIT, drift_spec=500.0, **kw).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])
    alike, ones, apart = fit(), fit(drift_gains=[1.0, 1.0, 1.0]), fit(drift_gains=(1.0, 1.5, 2.0))
    v0, b0 = alike.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True)
    v1, b1 = ones.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True)
    v2, b2 = apart.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True)
    assert same_bits(v0, v1) and same_bits(b0, b1)
    assert same_bits(v0, v2) and not same_bits(b0, b2)
    with pytest.raises(fc.FbgError, match="drift_gains: 2 drift gains given for the 3 gratings"):
        fit(drift_gains=[1.0, 1.1])
    with pytest.raises(fc.FbgError, match="drift_gains: drift gain 2 is 11"):
        fit(drift_gains=[1.0, 11.0, 1.0])
    with pytest.raises(ValueError, match=r"drift_gains\[1\]: 'x' is not a number"):
        fit(drift_gains=[1.0, "x", 1.0])
    with pytest.raises(ValueError, match="drift_gains: '1.0' is not a sequence"):
        fit(drift_gains="1.0")


def test_score_and_model_p(cal, holdout, fitted):
    r2_h = fitted.score(holdout[INPUTS + ["t_s"]], holdout[OUTPUTS])
    p = fc.ModelP(**FIT).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])
    assert p.model_.is_model_p and not fitted.model_.is_model_p
    r2_p = p.score(holdout[INPUTS + ["t_s"]], holdout[OUTPUTS])
    assert 0.9 < r2_p <= 1.0 and 0.9 < r2_h <= 1.0
    # The same fit gives both: ModelP's model is the HybridCompensator's Model-P.
    assert p.model_.blob_bytes() == fitted.model_p_.blob_bytes()


def test_pipeline_and_time_series_cv(cal):
    X = cal[INPUTS + ["t_s"]]
    y = cal[OUTPUTS]
    pipe = Pipeline([("keep", FunctionTransformer(lambda df: df[INPUTS + ["t_s"]])), ("comp", fc.HybridCompensator(**FIT))])
    pipe.fit(X, y)
    assert pipe.predict(X).shape == (len(X), 3)
    scores = cross_val_score(fc.ModelP(**FIT), X, y, cv=TimeSeriesSplit(n_splits=2))
    assert scores.shape == (2,) and np.isfinite(scores).all()


def test_errors_carry_the_trainer_message(cal):
    with pytest.raises(fc.FbgError, match="features: unknown feature set `nope`"):
        fc.HybridCompensator(features="nope").fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])
    with pytest.raises(fc.FbgError, match="max centres must be in 1..=128"):
        fc.HybridCompensator(max_centres=0).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])
    with pytest.raises(ValueError, match="give t="):
        fc.HybridCompensator(**FIT).fit(cal[INPUTS], cal[OUTPUTS])


@pytest.mark.parametrize("Est", [fc.HybridCompensator, fc.ModelP])
def test_sklearn_checks_that_need_no_fit(Est):
    """scikit-learn's own checks among those of check_estimator that do not fit on its
    generic data (which has no time column, so the others cannot run as written)."""
    from sklearn.utils import estimator_checks as ec

    name = Est.__name__
    ec.check_get_params_invariance(name, Est())
    ec.check_parameters_default_constructible(name, Est())
    ec.check_no_attributes_set_in_init(name, Est())
    ec.check_set_params(name, Est())
