"""The README's example, run as written (extracted from python/README.md, so the two cannot
drift), in a temporary directory; then what it should have shown is checked."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_example(tmp_path, monkeypatch):
    text = README.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) == 1, "one example block in python/README.md"
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(blocks[0], str(README), "exec"), scope)
    assert (tmp_path / "model.fbgm").is_file()
    # A model that compensates: the hold-out errors well under the measurands' spans (tens of
    # °C, hundreds of µε and kPa), the band covering most hold-out rows, and the device's
    # arithmetic within f32 rounding of the host's. The bounds were written before the first
    # run, from those spans, and not adjusted after it.
    rmse = scope["rmse"]
    assert rmse["T_C"] < 0.5 and rmse["strain_ue"] < 20 and rmse["p_kPa"] < 20, rmse
    diff = (scope["f32"] - scope["f64"]).abs().max()
    assert (diff < np.array([1e-3, 0.05, 0.05])).all(), diff
    assert scope["inside"].min() > 0.5
