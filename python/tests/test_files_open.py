"""Every CSV the tool writes opens in a notebook and a spreadsheet with no options:
``pandas.read_csv(path)``, ``numpy.genfromtxt(path, names=True, delimiter=",")`` and a plain
CSV reader (one header line, then rows of its width, as a spreadsheet shows them). A record's
zero and clock travel in its ``.record.json`` sidecar, which the package reads back."""

import csv
import json
import subprocess
import warnings

import numpy as np
import pandas as pd
import pytest

import fbg_compensation as fc

#: The CSV files each command writes (at least these; any other CSV found is checked too).
EXPECTED = {
    "demo": [
        "data.csv",
        "table2.csv",
        "table3.csv",
        "error_budget.csv",
        "drift_sweep.csv",
        "recalibration.csv",
        "sensitivity.csv",
        "sensitivity_inverse.csv",
        "coef_hyper.csv",
        "coef_stage1.csv",
        "golden/golden_expected.csv",
    ],
    "simulate": ["record.csv", "spectra.csv"],
    "peaks": ["peaks.csv"],
    "import": ["imported.csv"],
    "compensate": ["compensated.csv"],
    "bench-fit": ["holdout_errors.csv"],
    "python": ["written.csv"],
}

#: The dataset CSVs (records) among them: each has its sidecar.
RECORDS = ["demo/data.csv", "simulate/record.csv", "import/imported.csv", "python/written.csv"]


@pytest.fixture(scope="module")
def written(tmp_path_factory, trainer):
    root = tmp_path_factory.mktemp("written")

    def run(*args):
        r = subprocess.run([trainer, *map(str, args)], capture_output=True, text=True)
        assert r.returncode == 0, (args, r.stderr)

    short = root / "short.toml"
    short.write_text('name = "short"\n[clock]\ndays = 2.0\n')
    tiny = root / "tiny.toml"
    tiny.write_text('name = "tiny"\n[clock]\ndays = 0.08\n')
    for d in EXPECTED:
        (root / d).mkdir(exist_ok=True)
    run("demo", "--config", short, "--out", root / "demo")
    run("simulate", "--config", tiny, "--out", root / "simulate/record.csv", "--spectra", root / "simulate/spectra.csv")
    run("peaks", "--format", "spectra-csv", root / "simulate/spectra.csv", "--out", root / "peaks/peaks.csv")
    run("import", "--format", "csv", root / "demo/data.csv", "--out", root / "import/imported.csv")
    model = root / "demo/model.fbgm"
    run("compensate", "--model", model, "--data", root / "demo/data.csv", "--out", root / "compensate/compensated.csv")
    run(
        "bench-fit", "--data", root / "demo/data.csv", "--fixed", "--k", "4", "--repeats", "1",
        "--holdout-errors", root / "bench-fit/holdout_errors.csv",
    )
    fc.write_dataset(fc.read_dataset(root / "demo/data.csv"), root / "python/written.csv")
    return root


def all_csv(root):
    return sorted(p for p in root.rglob("*.csv"))


def test_every_expected_csv_is_written(written):
    for d, names in EXPECTED.items():
        for n in names:
            assert (written / d / n).is_file(), f"{d} did not write {n}"


def test_every_csv_opens_with_pandas_numpy_and_a_plain_reader(written):
    files = all_csv(written)
    assert len(files) >= sum(len(v) for v in EXPECTED.values())
    for p in files:
        name = p.relative_to(written)
        frame = pd.read_csv(p)
        assert len(frame) > 0 and not any(str(c).startswith("Unnamed") for c in frame.columns), name
        with warnings.catch_warnings():
            # A warning (e.g. a row of another width) is a failure too.
            warnings.simplefilter("error")
            arr = np.genfromtxt(p, names=True, delimiter=",")
        assert len(arr.dtype.names) == frame.shape[1], (name, arr.dtype.names, list(frame.columns))
        assert np.atleast_1d(arr).shape[0] == len(frame), name
        with open(p, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        header = rows[0]
        assert not header[0].startswith("#"), f"{name}: a comment line before the header"
        assert all(len(r) == len(header) for r in rows), f"{name}: rows of another width than the header"
        # What numpy reads is what pandas reads (numbers where pandas has numbers).
        for c, n in zip(frame.columns, arr.dtype.names):
            if pd.api.types.is_float_dtype(frame[c]) or pd.api.types.is_integer_dtype(frame[c]):
                a, b = np.asarray(arr[n], dtype=float), frame[c].to_numpy(dtype=float)
                assert np.array_equal(a, b, equal_nan=True), (name, c)


def test_records_carry_their_zero_and_clock_in_the_sidecar(written):
    for r in RECORDS:
        p = written / r
        side = json.loads(p.with_suffix(".record.json").read_text())
        assert side["format"] == "fbg-trainer record v1" and side["record"] == p.name, r
        frame = pd.read_csv(p)
        gratings = [c for c in frame.columns if c.startswith("dl") and c.endswith("_pm")]
        if side["zero"]:
            assert [z["column"] for z in side["zero"]] == gratings, r
    demo = json.loads((written / "demo/data.record.json").read_text())
    assert [z["source"] for z in demo["zero"]] == ["simulated"] * 3
    assert demo["t0_utc"] == "2026-01-05T00:00:00.000Z"
    # The package reads the clock back from the sidecar, and writes it again.
    back = fc.read_dataset(written / "python/written.csv")
    assert back.attrs["t0_unix_s"] == fc.read_dataset(written / "demo/data.csv").attrs["t0_unix_s"]
    ours = json.loads((written / "python/written.record.json").read_text())
    assert ours["t0_utc"] == demo["t0_utc"]
    # ... and the zero (attrs['zero']), so a record read and written again keeps it.
    assert ours["zero"] == demo["zero"]
    assert back.attrs["zero"] == [[z["lambda_ref_nm"], z["source"]] for z in demo["zero"]]


def test_simulated_frames_carry_their_zero_through_write_and_read(tmp_path):
    frame = fc.simulate("temperature-1", seed=3, days=0.5)
    # simulate's frame states its zero and clock as read_dataset's does.
    assert len(frame.attrs["zero"]) == 1 and frame.attrs["zero"][0][1] == "simulated", frame.attrs
    assert frame.attrs["t0_unix_s"] is not None
    p = tmp_path / "sim.csv"
    fc.write_dataset(frame, p)
    side = json.loads(p.with_suffix(".record.json").read_text())
    assert [[z["lambda_ref_nm"], z["source"]] for z in side["zero"]] == frame.attrs["zero"]
    # The sidecar identifies the table it was written with.
    assert side["csv_bytes"] == p.stat().st_size and len(side["csv_crc32c"]) == 8, side
    back = fc.read_dataset(p)
    assert back.attrs["zero"] == frame.attrs["zero"]
    assert back.attrs["t0_unix_s"] == frame.attrs["t0_unix_s"]
    # Written again from what was read: the same sidecar.
    q = tmp_path / "again.csv"
    fc.write_dataset(back, q)
    again = json.loads(q.with_suffix(".record.json").read_text())
    assert again["zero"] == side["zero"] and again["t0_utc"] == side["t0_utc"]
    # The CSV rewritten by another tool (pandas, other rows) beside its old sidecar: refused,
    # naming both files.
    pd.read_csv(p).iloc[::2].to_csv(p, index=False)
    with pytest.raises(fc.FbgError) as e:
        fc.read_dataset(p)
    assert str(p.with_suffix(".record.json")) in str(e.value) and str(p) + " is not the table" in str(e.value), str(e.value)
