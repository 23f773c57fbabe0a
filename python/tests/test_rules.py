"""The command line's rules hold for Python too, checked by the same library code: an output
is never an input, the simulator's ranges, known reference names, a time axis that increases;
and a fitted estimator pickles and deep-copies, predicting bit for bit afterwards."""

import copy
import pickle

import numpy as np
import pytest

import fbg_compensation as fc
from conftest import FIT, INPUTS, OUTPUTS, same_bits


def test_compensate_file_refuses_to_overwrite_its_input(tmp_path, holdout, fitted):
    data, model = tmp_path / "d.csv", tmp_path / "m.fbgm"
    fc.write_dataset(holdout, data)
    fitted.model_.save(model)
    before = data.read_bytes()
    for out in (data, tmp_path / "." / "d.csv", model):
        with pytest.raises(fc.FbgError, match=r"^out: .*input"):
            fc.compensate_file(model, data, out)
    link = tmp_path / "link.csv"
    link.symlink_to(data)
    with pytest.raises(fc.FbgError, match=r"^out: "):
        fc.compensate_file(model, data, link)
    assert data.read_bytes() == before


@pytest.mark.parametrize(
    "kw, param",
    [
        (dict(days=1e9), "days"),
        (dict(days=0.01), "days"),
        (dict(days=float("nan")), "days"),
        (dict(days=-1.0), "days"),
        (dict(dt_s=1e-6), "dt_s"),
        (dict(dt_s=1e6), "dt_s"),
        (dict(days=3000.0, dt_s=1e-3), "days/dt_s"),
    ],
)
def test_simulate_keeps_the_cli_ranges(kw, param):
    with pytest.raises(ValueError, match=rf"^{param}: "):
        fc.simulate("paper", **kw)


def test_simulate_range_messages_name_the_range():
    with pytest.raises(ValueError) as e:
        fc.simulate("paper", days=1e9)
    assert "[0.041666666666666664, 3650]" in str(e.value) and len(str(e.value)) < 200


def test_an_unknown_y_column_is_refused(cal):
    y = cal[OUTPUTS].rename(columns={"T_C": "foo"})
    with pytest.raises(ValueError, match=r"^y: column `foo` is not a measurand column"):
        fc.HybridCompensator(**FIT).fit(cal[INPUTS], y, t=cal["t_s"])
    # An input's name as a y column would replace the input.
    with pytest.raises(ValueError, match=r"^y: column `dl1_pm`"):
        fc.HybridCompensator(**FIT).fit(cal[INPUTS], cal[["dl1_pm"]], t=cal["t_s"])


@pytest.mark.parametrize("how", ["reversed", "shuffled", "constant", "nan"])
def test_fit_refuses_a_time_that_does_not_increase(cal, how):
    t = cal["t_s"].to_numpy().copy()
    if how == "reversed":
        t = t[::-1].copy()
    elif how == "shuffled":
        t[[10, 11]] = t[[11, 10]]
    elif how == "constant":
        t[:] = 5.0
    else:
        t[20] = np.nan
    with pytest.raises(ValueError, match=r"t \(t_s\) at row \d+: .*(does not increase|not a finite time)"):
        fc.HybridCompensator(**FIT).fit(cal[INPUTS], cal[OUTPUTS], t=t)


def test_write_dataset_refuses_a_nan_time(tmp_path, holdout):
    r = holdout.copy()
    r.attrs = dict(holdout.attrs)
    r.loc[3, "t_s"] = np.nan
    with pytest.raises(ValueError, match=r"at row 3: NaN is not a finite time"):
        fc.write_dataset(r, tmp_path / "x.csv")
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("which", ["fitted", "fitted_memory"])
def test_a_fitted_estimator_pickles_and_deep_copies_bit_for_bit(request, holdout, which):
    est = request.getfixturevalue(which)
    want, band, flags = est.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True, return_flags=True)
    for restored in (pickle.loads(pickle.dumps(est)), copy.deepcopy(est), copy.copy(est)):
        assert restored is not est
        assert restored.model_.to_bytes() == est.model_.to_bytes()
        assert restored.get_params() == est.get_params()
        got, b, f = restored.predict(holdout[INPUTS], t=holdout["t_s"], return_band=True, return_flags=True)
        assert same_bits(got, want) and same_bits(b, band) and np.array_equal(f, flags)
    m = pickle.loads(pickle.dumps(est.model_))
    assert m.to_bytes() == est.model_.to_bytes() and m.outputs == est.model_.outputs


def test_a_pickle_of_bad_bytes_is_refused(fitted):
    from fbg_compensation import _core

    raw = bytearray(fitted.model_.to_bytes())
    raw[20] ^= 0xFF
    with pytest.raises(fc.FbgError, match="CRC"):
        _core.Model(bytes(raw))
