"""Model files: round trips through bytes and files, signed and unsigned, inspect, tables."""

import subprocess

import numpy as np
import pytest

import fbg_compensation as fc
from conftest import INPUTS, OUTPUTS, same_bits


def test_bytes_and_file_round_trip(tmp_path, holdout, fitted):
    m = fitted.model_
    again = fc.Model.from_bytes(m.to_bytes())
    assert again.to_bytes() == m.to_bytes()
    path = tmp_path / "m.fbgm"
    assert m.save(path) is None
    assert path.read_bytes() == m.blob_bytes()
    loaded = fc.Model.load(path)
    assert (loaded.outputs, loaded.gratings, loaded.ambient) == (OUTPUTS, 3, True)
    # The file holds f32 coefficients and the fitted model is its decoding: the same numbers.
    a = m.predict(holdout[INPUTS], t=holdout["t_s"])
    assert same_bits(a, loaded.predict(holdout[INPUTS], t=holdout["t_s"]))


def test_signed_round_trip(tmp_path, trainer, fitted):
    key = tmp_path / "lab.key"
    subprocess.run([trainer, "keygen", "--out", str(key)], check=True, capture_output=True)
    pub = tmp_path / "lab.pub"
    path = tmp_path / "signed.fbgm"
    rec = fitted.model_.save(path, key=key, serial=5, state_dir=tmp_path / "state")
    assert rec["serial"] == 5
    signed = fc.Model.load(path)
    assert signed.blob_bytes() == fitted.model_.blob_bytes()
    assert len(signed.to_bytes()) > len(signed.blob_bytes())
    info = signed.inspect(pubkey=pub)
    assert info["signature"]["signed"] and info["signature"]["verifies"] is True
    assert info["signature"]["record"]["serial"] == 5
    assert fc.Model.from_bytes(signed.to_bytes()).to_bytes() == path.read_bytes()


def test_inspect_and_coefficient_tables(fitted):
    info = fitted.model_.inspect()
    assert info["kind"] == "model-h" and info["outputs"] == OUTPUTS
    assert info["signature"]["signed"] is False
    model = info["model"]
    assert model["model_dims"] == {"gratings": 3, "ambient": True, "measurands": OUTPUTS}
    t = fitted.model_.coefficients()
    assert list(t["poly"].index) == OUTPUTS and "1" in t["poly"].columns
    assert len(t["centres"]) == model["hyper_parameters"]["centres"] > 0
    assert [c for c in t["centres"].columns if c.startswith("w_")] == [f"w_{o}" for o in OUTPUTS]
    assert fitted.model_p_.coefficients()["centres"].empty


def test_corrupt_blob_is_an_error_naming_it(fitted):
    b = bytearray(fitted.model_.to_bytes())
    b[len(b) // 2] ^= 0xFF
    with pytest.raises(fc.FbgError, match=r"^m\.fbgm: .*CRC"):
        fc.Model.from_bytes(bytes(b), "m.fbgm")
    with pytest.raises(fc.FbgError, match="nowhere.fbgm"):
        fc.Model.load("nowhere.fbgm")
