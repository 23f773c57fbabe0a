"""The stream state: chunks in order give what one pass gives, in both arithmetics; and the
device's f32 path agrees with the host's f64 within the rounding of f32."""

import numpy as np
import pytest

from conftest import INPUTS, OUTPUTS, same_bits


@pytest.mark.parametrize("precision", ["f64", "f32"])
@pytest.mark.parametrize("sizes", [[1, 2, 997], [500, 500, 500], [7]])
def test_chunks_equal_one_pass(record, fitted_memory, precision, sizes):
    m = fitted_memory.model_
    whole, band, flags = m.predict(record[INPUTS], t=record["t_s"], precision=precision, return_band=True, return_flags=True)
    s = m.stream(precision, record.attrs["t0_unix_s"])
    parts, bands, fl = [], [], []
    start = 0
    # Uneven chunks, cycled over the whole record (sizes chosen before looking at the data).
    k = 0
    while start < len(record):
        n = sizes[k % len(sizes)]
        chunk = record.iloc[start : start + n]
        v, b, f = s.predict(chunk[INPUTS], t=chunk["t_s"], return_band=True, return_flags=True)
        parts.append(v.to_numpy())
        bands.append(b.to_numpy())
        fl.append(f)
        start += n
        k += 1
    assert s.rows == len(record)
    assert same_bits(np.vstack(parts), whole.to_numpy())
    assert same_bits(np.vstack(bands), band.to_numpy())
    assert np.array_equal(np.concatenate(fl), flags)


def test_fresh_stream_differs_from_continued(record, fitted_memory):
    """A chunk depends on the rows before it (the memory): the test above could fail."""
    m = fitted_memory.model_
    assert any(g["groups"] for g in fitted_memory.fit_summary_["chosen"]["memory"]) or m.inspect()["model"][
        "hyper_parameters"
    ]["feature_set"] != "paper"
    half = len(record) // 2
    whole = m.predict(record[INPUTS], t=record["t_s"]).to_numpy()
    fresh = m.predict(record.iloc[half:][INPUTS], t=record["t_s"].iloc[half:]).to_numpy()
    assert not same_bits(fresh, whole[half:])


def test_f32_device_path_close_to_f64(holdout, fitted):
    m = fitted.model_
    a = m.predict(holdout[INPUTS], t=holdout["t_s"], precision="f64").to_numpy()
    b = m.predict(holdout[INPUTS], t=holdout["t_s"], precision="f32").to_numpy()
    assert not same_bits(a, b), "the f32 path is another arithmetic"
    # Tolerances in the outputs' units (°C, µε, kPa): f32 carries ~7 digits; set from the
    # ranges of the paper preset (tens of °C, hundreds of µε, hundreds of kPa), not tuned.
    tol = np.array([1e-3, 0.05, 0.05])
    assert (np.abs(a - b) <= tol).all(), np.abs(a - b).max(axis=0)


def test_gaps_stay_gaps(holdout, fitted):
    x = holdout[INPUTS].copy()
    x.iloc[10, 1] = np.nan
    v, f = fitted.predict(x, t=holdout["t_s"], return_flags=True)
    assert np.isnan(v.iloc[10]).all() and f[10] & 1
    assert np.isfinite(v.iloc[11]).all()


def test_wrong_inputs_are_refused(holdout, fitted):
    import fbg_compensation as fc

    with pytest.raises(fc.FbgError, match="2 grating columns; the model reads 3"):
        fitted.predict(holdout[["dl1_pm", "dl2_pm", "T_amb_C"]], t=holdout["t_s"])
    with pytest.raises(fc.FbgError, match="no T_amb_C"):
        fitted.predict(holdout[["dl1_pm", "dl2_pm", "dl3_pm"]], t=holdout["t_s"])
    with pytest.raises(fc.FbgError, match="precision"):
        fitted.model_.predict(holdout[INPUTS], t=holdout["t_s"], precision="f16")


def test_columns_and_matrix_give_the_same_bits(record, fitted_memory):
    """`predict` hands the frame's columns to the core as they are; `step_arrays` a rows ×
    gratings matrix: the same rows give the same bits, and a column of the wrong length is
    refused by name."""
    m = fitted_memory.model_
    t0 = record.attrs["t0_unix_s"]
    whole, band, flags = m.predict(record[INPUTS], t=record["t_s"], t0_unix_s=t0, return_band=True, return_flags=True)
    dl = np.column_stack([record[c].to_numpy() for c in INPUTS[:-1]])
    v, b, f = m.stream("f64", t0).step_arrays(dl, record["T_amb_C"].to_numpy(), record["t_s"].to_numpy())
    assert same_bits(v, whole.to_numpy())
    assert same_bits(b, band.to_numpy())
    assert np.array_equal(f, flags)
    from fbg_compensation import _core

    cols = [np.ascontiguousarray(dl[:, i]) for i in range(dl.shape[1])]
    cols[1] = cols[1][:-1]
    with pytest.raises(_core.FbgError, match="dl_pm needs one row per value of t_s"):
        _core.Stream(m._m, "f64", t0).step(cols, record["T_amb_C"].to_numpy(), record["t_s"].to_numpy())
