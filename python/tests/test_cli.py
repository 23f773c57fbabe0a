"""The package against the command line: `compensate` bit for bit (f64 and the device's f32),
`train` giving the same blobs, errors with the same messages (file, line, column)."""

import subprocess

import numpy as np
import pandas as pd
import pytest

import fbg_compensation as fc
from conftest import FIT, INPUTS, OUTPUTS, same_bits


def cli_csv(path):
    # round_trip: the exact f64 of each printed number (the CLI prints the shortest text that
    # reads back to the same f64).
    import warnings

    with warnings.catch_warnings():
        # pandas 3 deprecates the argument (its default parser became exact); older ones need it.
        warnings.simplefilter("ignore")
        return pd.read_csv(path, float_precision="round_trip")


@pytest.fixture(scope="module")
def gappy(record):
    """The record with gaps: empty grating and thermometer cells (rows picked by hand)."""
    r = record.copy()
    r.attrs = dict(record.attrs)
    r.loc[[5, 6, 1500], "dl2_pm"] = np.nan
    r.loc[[900], "T_amb_C"] = np.nan
    return r


@pytest.fixture(scope="module")
def files(tmp_path_factory, gappy, fitted):
    d = tmp_path_factory.mktemp("cli")
    data, model = d / "record.csv", d / "m.fbgm"
    fc.write_dataset(gappy, data)
    fitted.model_.save(model)
    return d, data, model


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_compensate_bit_for_bit(files, trainer, precision):
    d, data, model = files
    out = d / f"cli-{precision}.csv"
    cmd = [trainer, "compensate", "--model", str(model), "--data", str(data), "--out", str(out)]
    subprocess.run(cmd + (["--f32"] if precision == "f32" else []), check=True, capture_output=True)
    cli = cli_csv(out)
    frame = fc.read_dataset(data, field=True)
    ours = fc.compensate(model, frame, precision=precision)
    assert (ours["flags"].to_numpy()[[5, 6, 900, 1500]] & 1).all(), "the gaps are flagged non-finite"
    assert list(ours.columns) == list(cli.columns)
    for c in cli.columns:
        if c == "flag_names":
            assert (ours[c].to_numpy() == cli[c].to_numpy()).all()
        elif c == "flags":
            assert np.array_equal(ours[c].to_numpy(), cli[c].to_numpy())
        else:
            # The CLI writes a non-finite value (a gap's, an infinite band) as an empty cell.
            o = ours[c].to_numpy().copy()
            o[~np.isfinite(o)] = np.nan
            assert same_bits(o, cli[c].to_numpy()), c
    # The file function is the CLI's own: the same bytes.
    ours_file = d / f"py-{precision}.csv"
    s = fc.compensate_file(model, data, ours_file, precision=precision)
    assert ours_file.read_bytes() == out.read_bytes() and s["rows"] == len(frame)


def test_dataset_csv_round_trip(tmp_path, files, gappy):
    _, data, _ = files
    record = gappy
    back = fc.read_dataset(data)
    # The dataset CSV carries 6 decimals (as `simulate` writes it), gaps as empty cells ...
    for c in ["t_s"] + INPUTS + OUTPUTS:
        a, b = back[c].to_numpy(), record[c].to_numpy()
        assert np.array_equal(np.isnan(a), np.isnan(b)), c
        assert np.nanmax(np.abs(a - b)) <= 5e-7, c
    assert back.attrs["t0_unix_s"] == record.attrs["t0_unix_s"]
    assert (back["split"] == record["split"]).all()
    # ... so what was read writes back to the same bytes.
    again = tmp_path / "again.csv"
    fc.write_dataset(back, again)
    assert again.read_bytes() == data.read_bytes()


def test_train_gives_the_same_blobs(files, trainer, record):
    d, data, _ = files
    out = d / "cli-train" / "model.fbgm"
    subprocess.run(
        [trainer, "train", "--data", str(data), "--features", FIT["features"], "--max-centres", str(FIT["max_centres"]), "--out", str(out)],
        check=True,
        capture_output=True,
    )
    frame = fc.read_dataset(data)
    cal = (frame["split"] == "cal").to_numpy()
    from fbg_compensation import _core
    from fbg_compensation import _frames as F

    cols = {c: F.column(frame, c) for c in ["t_s"] + INPUTS + OUTPUTS}
    # `train` records the file's stem as the scenario when there is no .meta.json sidecar.
    h, p, _, _ = _core.fit(
        cols, list(cal), FIT["features"], FIT["max_centres"], "fail", None, frame.attrs["t0_unix_s"], str(data), "record", 0,
        zero=[tuple(z) for z in frame.attrs["zero"]],
    )
    assert h.blob_bytes() == out.read_bytes()
    assert p.blob_bytes() == (out.parent / "model-p.fbgm").read_bytes()


def test_read_errors_name_file_line_column(tmp_path, files, trainer):
    _, data, model = files
    lines = data.read_text().splitlines(keepends=True)
    header = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    cols = lines[header].strip().split(",")
    k = header + 3  # the third data row
    cells = lines[k].rstrip("\n").split(",")
    cells[cols.index("dl2_pm")] = "12.3x"
    lines[k] = ",".join(cells) + "\n"
    bad = tmp_path / "bad.csv"
    bad.write_text("".join(lines))
    cli = subprocess.run(
        [trainer, "compensate", "--model", str(model), "--data", str(bad), "--out", str(tmp_path / "o.csv")],
        capture_output=True,
        text=True,
    )
    assert cli.returncode != 0
    with pytest.raises(fc.FbgError) as e:
        fc.read_dataset(bad, field=True)
    msg = str(e.value)
    assert f"{bad}: line {k + 1}, column dl2_pm: " in msg
    assert msg in cli.stderr, (msg, cli.stderr)
    with pytest.raises(fc.FbgError, match=f"line {k + 1}, column dl2_pm"):
        fc.compensate_file(model, bad, tmp_path / "o2.csv")
    assert not (tmp_path / "o2.csv").exists()


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_batched_predict_is_the_clis_step_through_the_gate(tmp_path, trainer, record, fitted_memory, precision):
    """`predict` runs fbg-shared's batch path (the stream state one scan, the RBF pass over
    several rows at once, over the cores); `compensate` steps row after row. On a record with
    glitches the gate refuses (a thermometer's 85 °C, a 500 pm jump), gaps and a long rest,
    with a model whose memory state the gate guards: the same bits, band and flags."""
    r = record.copy()
    r.attrs = dict(record.attrs)
    r.loc[[100, 2000], "T_amb_C"] = 85.0
    r.loc[[1200], "dl1_pm"] = r.loc[1200, "dl1_pm"] + 500.0
    r.loc[[7, 2500], "dl3_pm"] = np.nan
    rest = r.index[r.index >= len(r) - 600]
    for c in INPUTS:
        r.loc[rest, c] = r.loc[rest[0], c]
    data, model, out = tmp_path / "glitched.csv", tmp_path / "m.fbgm", tmp_path / "cli.csv"
    fc.write_dataset(r, data)
    fitted_memory.model_.save(model)
    cmd = [trainer, "compensate", "--model", str(model), "--data", str(data), "--out", str(out)]
    subprocess.run(cmd + (["--f32"] if precision == "f32" else []), check=True, capture_output=True)
    cli = cli_csv(out)
    ours = fc.compensate(model, fc.read_dataset(data, field=True), precision=precision)
    refused = (ours["flags"].to_numpy() & 0b1000_0010) == 0b1000_0010
    assert refused[[100, 2000]].all(), "the glitches are refused by the gate (fallback, out of envelope)"
    assert np.array_equal(ours["flags"].to_numpy(), cli["flags"].to_numpy())
    for c in cli.columns:
        if c in ("flags", "flag_names"):
            continue
        o = ours[c].to_numpy().copy()
        o[~np.isfinite(o)] = np.nan
        assert same_bits(o, cli[c].to_numpy()), c
