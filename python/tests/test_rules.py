"""The command line's rules hold for Python too, checked by the same library code: an output
is never an input, the simulator's ranges, known reference names, a time axis that increases;
and a fitted estimator pickles and deep-copies, predicting bit for bit afterwards."""

import contextlib
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


@pytest.mark.parametrize(
    "column, value, says",
    [
        ("dl2_pm", 1e154, r"1e154 \(shift_pm\) is a shift beyond 10 nm"),
        ("dl2_pm", 1e300, r"1e300 \(shift_pm\) is a shift beyond 10 nm"),
        ("dl1_pm", 1e6, r"1000000 should be a shift in pm but looks like an absolute wavelength in pm"),
        ("dl3_pm", 1e120, r"1e120 \(shift_pm\) is a shift beyond 10 nm"),
        ("T_amb_C", 1e154, r"ambient 1e154 °C is outside -80–200 °C"),
        ("T_amb_C", 296.0, r"ambient 296 °C looks like kelvin; subtract 273.15 from column `T_amb_C`"),
    ],
)
def test_fit_refuses_an_implausible_input_by_row_and_column_at_once(cal, column, value, says):
    """One cell >= 1e154 kept the fit's SVD iterating for minutes (its square overflows), and
    1e6..1e153 failed naming no row or column: now the CSV reader's input rule refuses it."""
    import time

    X = cal[INPUTS].copy()
    X.loc[17, column] = value
    t0 = time.monotonic()
    with pytest.raises(fc.FbgError, match=rf"row 17, column {column}: {says}"):
        fc.HybridCompensator(**FIT).fit(X, cal[OUTPUTS], t=cal["t_s"])
    assert time.monotonic() - t0 < 5.0


def test_write_dataset_refuses_what_read_dataset_would(tmp_path, holdout):
    r = holdout.copy()
    r.attrs = dict(holdout.attrs)
    r.loc[4, "dl1_pm"] = 1e200
    with pytest.raises(ValueError, match=r"row 4, column dl1_pm: 1e200"):
        fc.write_dataset(r, tmp_path / "x.csv")
    assert not (tmp_path / "x.csv").exists()


@contextlib.contextmanager
def _interrupt_after(seconds):
    """Ctrl-C (simulated) after `seconds`. Python's own SIGINT handler is installed for the
    duration: a process started in the background (a CI job, `cmd &`) inherits SIGINT
    ignored, and `_thread.interrupt_main` then does nothing."""
    import _thread
    import signal
    import threading

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(seconds, _thread.interrupt_main)
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)


def test_ctrl_c_stops_a_long_fit():
    """The fit runs without the GIL; Ctrl-C (here simulated) ends the call at once (and the
    fit at its next task)."""
    import time

    rec = fc.simulate("paper", seed=7, days=140.0)
    X, y = rec[INPUTS], rec[OUTPUTS]
    t0 = time.monotonic()
    with _interrupt_after(0.2), pytest.raises(KeyboardInterrupt):
        fc.HybridCompensator(features="memory", max_centres=32).fit(X, y, t=rec["t_s"])
    # Not a speed check: the call returned instead of running the fit to its end.
    assert time.monotonic() - t0 < 5.0


def test_ctrl_c_stops_a_long_predict_and_the_stream_says_so(fitted):
    import time

    n = 3_000_000
    dl = np.zeros((n, 3))
    amb = np.full(n, 20.0)
    t = np.arange(n, dtype=np.float64)
    s = fitted.model_.stream()
    t0 = time.monotonic()
    with _interrupt_after(0.2), pytest.raises(KeyboardInterrupt):
        s.step_arrays(dl, amb, t)
    # Not a speed check: the call returned instead of running every row.
    assert time.monotonic() - t0 < 5.0
    with pytest.raises(fc.FbgError, match="interrupted"):
        s.step_arrays(dl[:2], amb[:2], t[:2] + n)


def test_python_errors_name_python_parameters(cal):
    X, y = cal[INPUTS], cal[OUTPUTS].copy()
    y.loc[300, "T_C"] = 1e6
    with pytest.raises(fc.FbgError, match=r'reference outlier.*fit with `on_outlier="skip"`') as e:
        fc.HybridCompensator(**FIT).fit(X, y, t=cal["t_s"])
    assert "--" not in str(e.value)
    with pytest.raises(fc.FbgError, match=r"fixed\['k'\] must be in 1\.\.="):
        fc.HybridCompensator(fixed=dict(k=0)).fit(X, cal[OUTPUTS], t=cal["t_s"])
    with pytest.raises(fc.FbgError, match=r"fixed\['feature_set'\]: unknown feature set `nope`"):
        fc.HybridCompensator(fixed=dict(feature_set="nope")).fit(X, cal[OUTPUTS], t=cal["t_s"])


def test_bad_parameters_are_refused_at_fit_before_any_work(cal):
    import time

    X, y, t = cal[INPUTS], cal[OUTPUTS], cal["t_s"]
    t0 = time.monotonic()
    with pytest.raises(fc.FbgError, match=r"^precision: `f16` is neither"):
        fc.HybridCompensator(precision="f16", **FIT).fit(X, y, t=t)
    for bad in (8.5, 8.0, "8", True):
        with pytest.raises(ValueError, match=rf"^max_centres: {bad!r} is not an integer"):
            fc.HybridCompensator(features="paper", max_centres=bad).fit(X, y, t=t)
    with pytest.raises(ValueError, match=r"^seed: -1 is below 0"):
        fc.HybridCompensator(seed=-1, **FIT).fit(X, y, t=t)
    with pytest.raises(ValueError, match=r"^seed: 18446744073709551616 is above"):
        fc.HybridCompensator(seed=2**64, **FIT).fit(X, y, t=t)
    assert time.monotonic() - t0 < 2.0
    # numpy integers are integers.
    est = fc.HybridCompensator(features="paper", max_centres=np.int64(8), seed=np.uint32(3)).fit(X, y, t=t)
    assert len(est.model_.inspect()["model"]["rbf_centres"]) <= 8


def test_score_takes_t(holdout, fitted):
    X, y = holdout[INPUTS], holdout[OUTPUTS]
    with_t = fitted.score(X, y, t=holdout["t_s"])
    assert with_t == fitted.score(holdout[INPUTS + ["t_s"]], y)
    # y by name in any column order; weights are used.
    assert with_t == fitted.score(X, y[OUTPUTS[::-1]], t=holdout["t_s"])
    w = np.ones(len(X))
    w[: len(X) // 2] = 0.0
    assert fitted.score(X, y, t=holdout["t_s"], sample_weight=w) != with_t


def test_ctrl_c_stops_compensate_file_and_writes_nothing(tmp_path, fitted):
    """`compensate_file` runs without the GIL; Ctrl-C (simulated) stops the run between chunks
    of rows, and the call returns only once it stopped: the old output is untouched and no
    temporary is left."""
    import time

    n = 3_000_000
    rng = np.random.default_rng(1)
    cols = {"t_s": np.arange(n, dtype=np.float64) * 60.0, "T_amb_C": 20.0 + rng.normal(0.0, 1.0, n)}
    for g in (1, 2, 3):
        cols[f"dl{g}_pm"] = rng.normal(0.0, 50.0, n)
    data, model, out = tmp_path / "big.csv", tmp_path / "m.fbgm", tmp_path / "out.csv"
    fc.write_dataset(cols, data)
    fitted.model_.save(model)
    out.write_text("old")
    t0 = time.monotonic()
    with _interrupt_after(0.2), pytest.raises(KeyboardInterrupt):
        fc.compensate_file(model, data, out)
    # Not a speed check: the call returned instead of running every row.
    assert time.monotonic() - t0 < 5.0
    time.sleep(0.2)
    assert out.read_text() == "old"
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".fbg-")]
