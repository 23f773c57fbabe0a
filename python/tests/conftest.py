"""Shared fixtures: a short simulated record of the `paper` installation, a quick fit on its
calibration rows, and the `fbg-trainer` binary for the comparisons with the command line.

The record and the fit options were chosen for speed (2 days at 60 s, the `paper` feature
set, at most 8 centres): the tests check behaviour and bit-for-bit agreement, not accuracy."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import fbg_compensation as fc

ROOT = Path(__file__).resolve().parents[2]
INPUTS = ["dl1_pm", "dl2_pm", "dl3_pm", "T_amb_C"]
OUTPUTS = ["T_C", "strain_ue", "p_kPa"]
#: The quick fit of the tests (the CLI's `train --features paper --max-centres 8`).
FIT = dict(features="paper", max_centres=8)


@pytest.fixture(scope="session")
def record():
    """Two days of the `paper` preset, seed 7: the first half calibrates."""
    return fc.simulate("paper", seed=7, days=2.0)


@pytest.fixture(scope="session")
def cal(record):
    return record[record["split"] == "cal"].reset_index(drop=True)


@pytest.fixture(scope="session")
def holdout(record):
    h = record[record["split"] == "holdout"].reset_index(drop=True)
    h.attrs = dict(record.attrs)
    return h


@pytest.fixture(scope="session")
def fitted(cal):
    return fc.HybridCompensator(**FIT).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])


@pytest.fixture(scope="session")
def fitted_memory(cal):
    """The default model's inputs (memory terms, direction latches): a model with state."""
    return fc.HybridCompensator(features="memory", max_centres=8).fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"])


@pytest.fixture(scope="session")
def trainer():
    """The `fbg-trainer` binary: `$FBG_TRAINER` (set by `cargo xtask python`), else one built
    in target/. A missing binary fails the tests that need it when `$FBG_TRAINER` is set."""
    env = os.environ.get("FBG_TRAINER")
    if env:
        assert Path(env).is_file(), f"FBG_TRAINER={env} does not exist"
        return env
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "fbg-trainer"
        if p.is_file():
            return str(p)
    found = shutil.which("fbg-trainer")
    if found:
        return found
    pytest.skip("no fbg-trainer binary (build it with `cargo build -p fbg-trainer` or set FBG_TRAINER)")


def same_bits(a, b):
    """Equal bit for bit, NaN where the other is NaN (a gap is a gap in both)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
