#!/usr/bin/env python3
"""The Python package (`fbg_compensation`) against its peers, for `cargo xtask bench` (the
`python` section of BENCHMARKS.md) or alone (`cargo xtask python --bench`). Prints one JSON
object on stdout.

On one record of the `paper` preset (14 days; ``--dt-s`` 1.2096 s gives 1 000 000 rows), a
Model-H of one fixed configuration (the `paper` feature set, K = 32, σ = 2 × NN, α = 1e-5·n:
the inputs the scikit-learn peer's `paper` pipeline has) is timed:

``predict``  our ``Model.predict`` over every row (the device's compensator in f64 through
         fbg-shared's batch path: the stream state one scan in order, the RBF pass over several
         rows at once and over the cores, bit for bit its step; band and flags included), from
         a pandas DataFrame already in memory, against
         (a) the scikit-learn pipeline of ``bench/sklearn_peer.py`` (``HybridPeer.predict_h``:
         stage 1, the polynomial core and the RBF residual as vectorised NumPy/scikit-learn
         calls, no band), fitted on the same calibration rows, and (b) the CLI's
         ``fbg-trainer compensate`` on the record's CSV (a process: CSV read, compensation,
         CSV write). Each is a median of ``--repeats`` runs, alternated.
``fit``  our ``HybridCompensator(fixed=...)`` fit on the calibration rows (from the
         DataFrame; the conversion of its columns inside the clock) against ``fbg-trainer
         bench-fit --fixed`` with the same configuration (its fits timed inside the process,
         the CSV read outside the clock, as ours).

The results agree bit for bit with the CLI's (checked here on the full record, and by the
tests): ``same_as_cli`` says so.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import fbg_compensation as fc

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import sklearn_peer  # noqa: E402

# The timings are of whatever else the machine runs too: the ratios compare runs alternated
# in one invocation; the load average is recorded beside them.

INPUTS = ["dl1_pm", "dl2_pm", "dl3_pm", "T_amb_C"]
OUTPUTS = ["T_C", "strain_ue", "p_kPa"]
FIXED = {"feature_set": "paper", "k": 32, "sigma_mult": 2.0, "alpha_rel": 1e-5, "dead_band_pm": 4.0}


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), times


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trainer", required=True, help="the release fbg-trainer binary")
    ap.add_argument("--dt-s", type=float, default=1.2096, help="sample interval [s] of the 14-day record")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--workdir", default=None)
    a = ap.parse_args()
    work = Path(a.workdir or tempfile.mkdtemp(prefix="fbg-py-bench-"))
    work.mkdir(parents=True, exist_ok=True)

    record = fc.simulate("paper", seed=a.seed, days=14.0, dt_s=a.dt_s)
    data = work / "record.csv"
    fc.write_dataset(record, data)
    cal = record[record["split"] == "cal"]

    # fit: ours (fixed configuration) and `bench-fit --fixed`, alternated.
    est = fc.HybridCompensator(fixed=FIXED)
    ours_fit, ours_fit_all = median_time(lambda: est.fit(cal[INPUTS], cal[OUTPUTS], t=cal["t_s"]), a.repeats)
    bench_fit_cmd = [
        a.trainer, "bench-fit", "--data", str(data), "--fixed", "--feature-set", FIXED["feature_set"],
        "--k", str(FIXED["k"]), "--sigma-mult", str(FIXED["sigma_mult"]), "--alpha-rel", str(FIXED["alpha_rel"]),
        "--dead-band-pm", str(FIXED["dead_band_pm"]), "--repeats", str(a.repeats), "--json",
    ]
    cli_fit = json.loads(subprocess.run(bench_fit_cmd, check=True, capture_output=True, text=True).stdout)

    model_path = work / "model.fbgm"
    est.model_.save(model_path)
    model = est.model_
    X, t = record[INPUTS], record["t_s"]

    # The scikit-learn peer on the same calibration rows and inputs.
    t_all = record["t_s"].to_numpy()
    X4 = record[INPUTS].to_numpy()
    Z = np.column_stack([X4, t_all])
    calm = (record["split"] == "cal").to_numpy()
    peer = sklearn_peer.HybridPeer(FIXED["k"], FIXED["sigma_mult"], FIXED["alpha_rel"], seed=1)
    peer.fit(X4[calm], Z[calm], record.loc[calm, OUTPUTS].to_numpy())

    out_csv = work / "compensated.csv"
    comp_cmd = [a.trainer, "compensate", "--model", str(model_path), "--data", str(data), "--out", str(out_csv)]
    ours, peer_t, cli_t = [], [], []
    for _ in range(a.repeats):
        for sink, fn in (
            (ours, lambda: model.predict(X, t=t, return_band=True, return_flags=True)),
            (peer_t, lambda: peer.predict_h(X4, Z)),
            (cli_t, lambda: subprocess.run(comp_cmd, check=True, capture_output=True)),
        ):
            t0 = time.perf_counter()
            fn()
            sink.append(time.perf_counter() - t0)

    # Bit for bit: ours on the record as the CLI reads it (the CSV's 6 decimals) against the
    # CLI's file (empty cells are non-finite).
    import pandas as pd

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pandas 3 deprecates it (its default became exact)
        cli = pd.read_csv(out_csv, float_precision="round_trip")
    pred = fc.compensate(model, fc.read_dataset(data, field=True))[OUTPUTS].to_numpy().copy()
    ref = cli[OUTPUTS].to_numpy()
    pred[~np.isfinite(pred)] = np.nan
    same = bool(np.array_equal(pred, ref, equal_nan=True))

    med = lambda v: float(np.median(v))  # noqa: E731
    out = {
        "rows": int(len(record)),
        "cal_rows": int(calm.sum()),
        "repeats": a.repeats,
        "fixed": FIXED,
        "predict_seconds": {"ours": med(ours), "sklearn_peer": med(peer_t), "cli_compensate": med(cli_t)},
        "predict_all_seconds": {"ours": ours, "sklearn_peer": peer_t, "cli_compensate": cli_t},
        "speedup_vs_sklearn": med(peer_t) / med(ours),
        "ratio_to_cli_compensate": med(ours) / med(cli_t),
        "fit_seconds": {"ours": ours_fit, "ours_all": ours_fit_all, "cli_bench_fit_fixed": cli_fit["fit_seconds_median"]},
        "fit_ratio_to_cli": ours_fit / cli_fit["fit_seconds_median"],
        "same_as_cli": same,
        "load_average": list(os.getloadavg()),
        "commands": {
            "bench_fit": " ".join(bench_fit_cmd),
            "compensate": " ".join(comp_cmd),
        },
        "versions": {
            "python": sys.version.split()[0],
            "numpy": np.__version__,
            "sklearn": __import__("sklearn").__version__,
            "fbg_compensation": fc.__version__,
        },
    }
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
