"""`import_file` against the command line's `import`: the same record from a spectra file
(peaks found by the detector) and the same error, naming line and column."""

import json
import subprocess

import numpy as np
import pandas as pd
import pytest

import fbg_compensation as fc


def spectra_csv(path, seed=1):
    """Three Gaussian peaks (0.3 nm FWHM) moving by known shifts on a 10 pm grid, 12 frames,
    one channel, noise from `seed`, plus a reference temperature column in a refs file."""
    rng = np.random.default_rng(seed)
    wl = np.round(np.arange(1545.0, 1556.0, 0.01), 3)
    centres = np.array([1547.0, 1550.0, 1553.0])
    sigma = 0.3 / 2.354820045
    lines = ["t_s,channel," + ",".join(f"{w:.3f}" for w in wl)]
    for k in range(12):
        shift = 0.002 * k * np.array([1.0, 2.0, -1.0])
        y = sum(np.exp(-0.5 * ((wl - c - s) / sigma) ** 2) for c, s in zip(centres, shift))
        y = 1000.0 * y + 20.0 + rng.normal(0.0, 0.1, wl.size)
        lines.append(f"{10.0 * k},1," + ",".join(f"{v:.4f}" for v in y))
    path.write_text("\n".join(lines) + "\n")


def test_import_file_equals_the_cli(tmp_path, trainer):
    src = tmp_path / "spectra.csv"
    spectra_csv(src)
    frame = fc.import_file("spectra-csv", src)
    out = tmp_path / "data.csv"
    subprocess.run([trainer, "import", "--format", "spectra-csv", str(src), "--out", str(out)], check=True, capture_output=True)
    cli = fc.read_dataset(out, field=True)
    for g in (1, 2, 3):
        a, b = np.asarray(frame[f"dl{g}_pm"]), np.asarray(cli[f"dl{g}_pm"])
        # The CLI's file prints 6 decimals of pm.
        assert np.allclose(a, b, atol=1e-6, rtol=0), (g, a, b)
    # The known shifts, 2 pm per frame times (1, 2, -1), within the detector's accuracy.
    k = np.arange(12)
    assert np.allclose(np.asarray(frame["dl2_pm"]), 4.0 * k, atol=0.1)
    assert frame.attrs["import_summary"]["spectra"] is not None
    # The zero and clock the CLI writes to the sidecar are the frame's too.
    side = json.loads(out.with_suffix(".record.json").read_text())
    assert frame.attrs["zero"] == [[z["lambda_ref_nm"], z["source"]] for z in side["zero"]], (frame.attrs, side)
    assert frame.attrs["zero"] == cli.attrs["zero"]
    assert frame.attrs["t0_unix_s"] == cli.attrs["t0_unix_s"]


def test_import_file_errors_name_line_and_column(tmp_path):
    src = tmp_path / "spectra.csv"
    spectra_csv(src)
    lines = src.read_text().splitlines()
    cells = lines[3].split(",")
    cells[5] = "abc"
    lines[3] = ",".join(cells)
    src.write_text("\n".join(lines) + "\n")
    with pytest.raises(fc.FbgError) as e:
        fc.import_file("spectra-csv", src)
    assert "line 4" in str(e.value) and "column 6" in str(e.value), str(e.value)
    with pytest.raises(fc.FbgError, match="not a format"):
        fc.import_file("nope", src)
