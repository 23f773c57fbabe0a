#!/usr/bin/env python3
"""scikit-learn peers of the FBG hybrid compensator, for `cargo xtask bench` (BENCHMARKS.md).

Two sub-commands, each printing one JSON object on stdout:

``fit``  The equivalent scikit-learn pipeline of a *fixed-hyper-parameter* Model-P + Model-H
         fit (DESIGN §4), timed the way ``fbg-trainer bench-fit --fixed`` times ours: the CSV is
         read once, outside the clock, then the fit runs ``--repeats`` times, each timed alone,
         and the last fit is evaluated on the hold-out. What one fit computes, on the
         calibration rows (``split == cal``) only:

         1. stage 1: ``LinearRegression`` (with intercept) from [dl1, dl2, dl3, T_amb] to the
            references [T, strain, p]: the first guesses g;
         2. stage 2: ``StandardScaler`` -> ``PolynomialFeatures(2)`` (the ten terms 1, T, e, p,
            T², Te, Tp, e², ep, p²) -> ``LinearRegression(fit_intercept=False)``: Model-P;
         3. the RBF inputs z: ``paper`` = [dl1, dl2, dl3, T_amb, t]; ``hysteresis-aware`` =
            [dl1, dl2, dl3, T_amb, latch1, latch2, latch3], where the direction latches are
            computed by a Python loop that is a line-by-line port of
            ``fbg_shared::DirectionLatch`` (ticks of 1/1024 pm, rounding half away from zero,
            running extreme, dead band), run once over the whole record in time order *before*
            the clock starts (its time is reported separately as ``latch_seconds``);
         4. ``StandardScaler`` on z; then, with ``--kmeans all`` (the pipeline as a notebook
            writes it), ``KMeans(n_clusters=K, random_state=seed)`` with scikit-learn's defaults
            (k-means++, one initialisation, up to 300 iterations, tol 1e-4) on every calibration
            row; with ``--kmeans subsample`` (our algorithm ported to scikit-learn: the
            implementations compared alone), ``KMeans(n_clusters=K, init="k-means++",
            n_init=1, max_iter=100, random_state=seed)`` on every ceil(n/20000)-th row, the
            subsample and iteration cap ours uses;
         5. sigma = sigma_mult x the median distance from each centre to its nearest other
            centre (upper median, as ours); psi = ``rbf_kernel(z, centres, gamma=1/(2 sigma²))``,
            values below 1e-150 set to 0 (their products would be subnormal and slow the BLAS
            products tenfold);
         6. ``Ridge(alpha=alpha_rel * n_cal, fit_intercept=False)`` from psi to the Model-P
            residuals: Model-H = Model-P + psi W.

         With ``--features memory`` (the default model's inputs, ``fbg-trainer bench-fit --fixed
         --memory``): the RBF inputs are the ``hysteresis-aware`` ones, and the memory terms of
         each output are fitted on what Model-P's core leaves (DESIGN §4, static fidelity): ridge
         least squares of the core's residual on the memory terms scaled by their standard
         deviations (penalty λ·n), solved from the normal equations. The terms are ours, ported to numpy (``memory_terms``): grating
         high-passes Δλ − EMA_τ(Δλ) at τ = 5, 15, 30, 60, 120, 240 min, ambient high-passes at
         5, 15, 30, 60 min, stop terms Δλ − play_r(Δλ) at r = 2, 4, 8 pm, and the drift
         observer for temperature (its grating-temperature row is stage 1's, so it is computed
         inside the clock). The groups and λ of each output are given (``--memory-groups``,
         ``--memory-lambda``: ours as our cross-validation chose them), so this pipeline does
         *less* than ours, which cross-validates them. The high-passes and stop terms depend on
         no fitted number and are computed once, before the clock, like the latches (their time
         is ``feature_seconds``); a record with an irregular clock is refused (the EMAs are run
         as ``scipy.signal.lfilter`` with one smoothing factor).

         It does not compute what ours also does inside a fit: the blocked time-series
         cross-validation that calibrates the 95 % band, the envelope, the weak-support
         threshold and the variance eigen-directions.

``blackbox``  Black-box accuracy peers on the same calibration rows and the same inputs:
         ``HistGradientBoostingRegressor`` (one per output, defaults, random_state=0) and
         ``MLPRegressor`` (two hidden layers of 64, early stopping, random_state=0, inputs and
         targets standardised), on [dl1..3, T_amb], on [dl1..3, T_amb, t] (time-aware) and on
         [dl1..3, T_amb, latch1..3] (the latches above). Model size = ``len(pickle.dumps(model))``.

         Also hybrids with a black-box residual learner: Model-P (as in ``fit``) plus a
         ``HistGradientBoostingRegressor`` per output fitted to Model-P's calibration residuals,
         on [dl1..3, T_amb, latch1..3] and on a much richer set of causal features (``history``:
         per grating the direction latches at dead bands 1, 2, 4 and 6 pm, the changes over the
         last 1..32 samples, the samples since the latch's running extreme last moved, the
         deviations from exponential moving averages of 2..180 samples; the changes of T_amb
         over the last 1..32 samples and its averages over 60..720 samples: 59 inputs, every one
         computable on a stream). It bounds what more information and a far larger learner buy
         over the compensator's own inputs.

``hybrids``  Only those two gradient-boosting hybrids, for the comparison over every
         coverage seed (`cargo xtask bench` runs it on seeds 8..26; seed 7's are in
         ``blackbox``).

``versions`` prints the Python, numpy and scikit-learn versions.
"""

import argparse
import json
import math
import pickle
import platform
import sys
import time

import numpy as np
from scipy.signal import lfilter
from sklearn.cluster import KMeans
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.metrics.pairwise import rbf_kernel
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

COLUMNS = ["t_s", "T_C", "strain_ue", "p_kPa", "T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm", "split"]
KMEANS_MAX_POINTS = 20_000  # fbg_trainer::fit::KMEANS_MAX_POINTS
TICKS_PER_PM = 1024.0  # fbg_shared::direction_latch::TICKS_PER_PM


def read_csv(path):
    # Records of earlier versions carried their λ_ref and start time as `#` comment lines
    # before the header (now in the `.record.json` sidecar): skipped when there.
    skip = 0
    with open(path) as f:
        line = f.readline()
        while line.startswith("#"):
            skip += 1
            line = f.readline()
        header = line.strip().split(",")
    if header != COLUMNS:
        sys.exit(f"{path}: expected the columns {','.join(COLUMNS)}, found {','.join(header)}")
    num = np.loadtxt(path, delimiter=",", skiprows=skip + 1, usecols=range(8), dtype=np.float64, ndmin=2)
    split = np.loadtxt(path, delimiter=",", skiprows=skip + 1, usecols=[8], dtype="U8", ndmin=1)
    cal = split == "cal"
    return {
        "t": num[:, 0],
        "Y": num[:, 1:4],
        "X4": np.column_stack([num[:, 5], num[:, 6], num[:, 7], num[:, 4]]),
        "cal": cal,
        "hold": split == "holdout",
    }


def ticks(pm):
    """fbg_shared::ticks: round(pm * 1024) half away from zero, saturating to i32."""
    v = pm * TICKS_PER_PM
    r = math.floor(abs(v) + 0.5)
    r = r if v >= 0 else -r
    return int(max(-(2**31), min(2**31 - 1, r)))


def latches(dl, dead_band_pm):
    """fbg_shared::LatchBank over the whole record, in time order: (n, 3) of -1/0/+1."""
    db = ticks(dead_band_pm)
    out = np.zeros(dl.shape, dtype=np.float64)
    for g in range(dl.shape[1]):
        col = dl[:, g].tolist()
        res = [0.0] * len(col)
        anchor, direction, primed = 0, 0, False
        for i, v in enumerate(col):
            if math.isfinite(v):
                x = ticks(v)
                if not primed:
                    anchor, primed = x, True
                else:
                    rise, fall = x > anchor + db, x < anchor - db
                    if direction == 1 and x > anchor:
                        anchor = x
                    elif direction == -1 and x < anchor:
                        anchor = x
                    elif direction in (1, 0) and fall:
                        direction, anchor = -1, x
                    elif direction in (-1, 0) and rise:
                        direction, anchor = 1, x
            res[i] = float(direction)
        out[:, g] = res
    return out


def median_nn_distance(c):
    """fbg_trainer::fit::median_nn_distance: upper median of each centre's nearest other centre."""
    if len(c) < 2:
        return 1.0
    d = np.sqrt(((c[:, None, :] - c[None, :, :]) ** 2).sum(-1))
    np.fill_diagonal(d, np.inf)
    nn = np.sort(d.min(axis=1))
    m = nn[len(nn) // 2]
    return m if m > 0 else 1.0


GRATING_TAUS_S = [300.0, 900.0, 1800.0, 3600.0, 7200.0, 14400.0]  # MemoryOptions::default_menu
AMBIENT_TAUS_S = [300.0, 900.0, 1800.0, 3600.0]
PLAY_HALF_WIDTHS_PM = [2.0, 4.0, 8.0]
OBSERVER_LAG_S, OBSERVER_SMOOTH_S = 1200.0, 2400.0
MEMORY_GROUPS = ["grating-high-pass", "ambient-high-pass", "stop", "drift-observer"]


def regular_step(t):
    """The record's one sampling interval [s]; exits when the clock is irregular."""
    dt = np.diff(t)
    if len(dt) == 0 or not np.allclose(dt, dt[0], rtol=1e-6, atol=0.0):
        sys.exit("memory features: the peer needs a regular clock (one smoothing factor per EMA)")
    return float(dt[0])


def low_pass(x, tau_s, dt_s):
    """fbg_shared::LowPass over a whole record: primed at x[0], then s += a (x - s) with
    a = 1 - exp(-dt/tau)."""
    a = -math.expm1(-dt_s / tau_s)
    out = np.empty_like(x)
    out[0] = x[0]
    if len(x) > 1:
        out[1:], _ = lfilter([a], [1.0, a - 1.0], x[1:], zi=[(1.0 - a) * x[0]])
    return out


def stop_terms(x, r):
    """fbg_shared::Play's stop complement x - play_r(x) over a whole record (primed at x[0])."""
    out = np.zeros(len(x))
    state = None
    for i, v in enumerate(x.tolist()):
        if state is None:
            state = v
        elif state < v - r:
            state = v - r
        elif state > v + r:
            state = v + r
        out[i] = v - state
    return out


def memory_terms(data, dt_s):
    """The fixed memory terms (everything but the observer), by group: name -> (n, k) array."""
    dl, t_amb = data["X4"][:, :3], data["X4"][:, 3]
    grating = [dl[:, g] - low_pass(dl[:, g], tau, dt_s) for tau in GRATING_TAUS_S for g in range(3)]
    ambient = [t_amb - low_pass(t_amb, tau, dt_s) for tau in AMBIENT_TAUS_S]
    stop = [stop_terms(dl[:, g], r) for r in PLAY_HALF_WIDTHS_PM for g in range(3)]
    return {
        "grating-high-pass": np.column_stack(grating),
        "ambient-high-pass": np.column_stack(ambient),
        "stop": np.column_stack(stop),
    }


def drift_observer(X4, row, intercept, dt_s):
    """fbg_shared::DriftObserver: EMA_smooth(EMA_lag(T_g) - T_amb), T_g = row . X4 + intercept."""
    t_g = X4 @ row + intercept
    lagged = low_pass(t_g, OBSERVER_LAG_S, dt_s)
    return low_pass(lagged - X4[:, 3], OBSERVER_SMOOTH_S, dt_s)


def rbf_inputs(data, features, lat):
    if features == "paper":
        return np.column_stack([data["X4"], data["t"]])
    return np.column_stack([data["X4"], lat])


class HybridPeer:
    """Model-P + Model-H as a scikit-learn pipeline (see the module doc)."""

    def __init__(self, k, sigma_mult, alpha_rel, seed, kmeans="subsample", memory=None):
        self.k, self.sigma_mult, self.alpha_rel, self.seed = k, sigma_mult, alpha_rel, seed
        self.kmeans = kmeans
        # memory: None, or (groups per output, lambda per output, dt_s).
        self.memory = memory

    def fit(self, X4, Z, Y, M=None):
        n = len(Y)
        self.stage1 = LinearRegression().fit(X4, Y)
        g = self.stage1.predict(X4)
        self.stage2 = make_pipeline(StandardScaler(), PolynomialFeatures(2), LinearRegression(fit_intercept=False))
        self.stage2.fit(g, Y)
        if self.memory is None:
            resid = Y - self.stage2.predict(g)
        else:
            resid = Y - self.fit_memory(X4, g, Y, M)
        self.zscale = StandardScaler().fit(Z)
        zs = self.zscale.transform(Z)
        if self.kmeans == "all":
            km = KMeans(n_clusters=self.k, random_state=self.seed)
            self.centres = km.fit(zs).cluster_centers_
        else:
            stride = max(1, -(-n // KMEANS_MAX_POINTS))
            km = KMeans(n_clusters=self.k, init="k-means++", n_init=1, max_iter=100, random_state=self.seed)
            self.centres = km.fit(zs[::stride]).cluster_centers_
        sigma = self.sigma_mult * median_nn_distance(self.centres)
        self.gamma = 1.0 / (2.0 * sigma * sigma)
        psi = self.features(zs)
        self.ridge = Ridge(alpha=self.alpha_rel * n, fit_intercept=False).fit(psi, resid)
        return self

    def memory_columns(self, X4, M, o):
        """Output o's memory terms (unstandardised): its groups' precomputed terms, and the
        drift observer from this fit's stage 1."""
        groups, _, dt_s = self.memory
        cols = [M[gr] for gr in MEMORY_GROUPS[:3] if gr in groups[o]]
        if "drift-observer" in groups[o]:
            obs = drift_observer(X4, self.stage1.coef_[0], self.stage1.intercept_[0], dt_s)
            cols.append(obs[:, None])
        return np.column_stack(cols) if cols else np.zeros((len(X4), 0))

    def fit_memory(self, X4, g, Y, M):
        """Gamma per output on what Model-P's core leaves (static fidelity), ridge lambda * n
        on the memory terms scaled by their standard deviations (not centred, as ours);
        returns the fitted values of core plus memory terms."""
        groups, lambdas, _ = self.memory
        fitted = self.stage2.predict(g)
        resid = Y - fitted
        self.mem = []
        for o in range(Y.shape[1]):
            m = self.memory_columns(X4, M, o)
            if m.shape[1] == 0:
                self.mem.append((np.ones(0), np.zeros(0)))
                continue
            sd = m.std(axis=0)
            sd[sd == 0] = 1.0
            X = m / sd
            beta = np.linalg.solve(X.T @ X + lambdas[o] * len(Y) * np.eye(X.shape[1]), X.T @ resid[:, o])
            self.mem.append((sd, beta))
            fitted[:, o] += X @ beta
        return fitted

    def predict_core(self, X4, M=None):
        """Model-P, plus with memory terms Gamma m."""
        out = self.predict_p(X4)
        if self.memory is None:
            return out
        for o, (sd, beta) in enumerate(self.mem):
            out[:, o] += (self.memory_columns(X4, M, o) / sd) @ beta
        return out

    def features(self, zs):
        """psi, with activations below 1e-150 (far centres) set to 0: their products would be
        subnormal and slow the BLAS products of the ridge fit down tenfold; they change no
        result."""
        psi = rbf_kernel(zs, self.centres, gamma=self.gamma)
        psi[psi < 1e-150] = 0.0
        return psi

    def predict_p(self, X4):
        return self.stage2.predict(self.stage1.predict(X4))

    def predict_h(self, X4, Z, M=None):
        psi = self.features(self.zscale.transform(Z))
        return self.predict_core(X4, M) + self.ridge.predict(psi)


def rmse(pred, Y):
    return np.sqrt(((pred - Y) ** 2).mean(axis=0)).tolist()


def cmd_fit(a):
    data = read_csv(a.data)
    memory = a.features == "memory"
    t0 = time.perf_counter()
    lat = latches(data["X4"][:, :3], a.dead_band_pm) if a.features != "paper" else None
    latch_seconds = time.perf_counter() - t0 if lat is not None else 0.0
    Z = rbf_inputs(data, a.features, lat)
    cal, hold = data["cal"], data["hold"]
    M, spec, feature_seconds = None, None, 0.0
    if memory:
        groups = [g.split("+") if g else [] for g in a.memory_groups.split(",")]
        lambdas = [float(x) for x in a.memory_lambda.split(",")]
        if len(groups) != 3 or len(lambdas) != 3 or any(x not in MEMORY_GROUPS for gs in groups for x in gs):
            sys.exit("--memory-groups needs three outputs' groups (a+b,c,...) and --memory-lambda three values")
        n_cal = int(cal.sum())
        if not cal[:n_cal].all():
            sys.exit("memory features: the calibration rows must come first (the terms run over the record)")
        t0 = time.perf_counter()
        dt_s = regular_step(data["t"])
        M = memory_terms(data, dt_s)
        feature_seconds = time.perf_counter() - t0
        spec = (groups, lambdas, dt_s)
    X4c, Zc, Yc = data["X4"][cal], Z[cal], data["Y"][cal]
    Mc = {k: v[cal] for k, v in M.items()} if memory else None
    secs, model = [], None
    for _ in range(max(1, a.repeats)):
        t = time.perf_counter()
        model = HybridPeer(a.k, a.sigma_mult, a.alpha_rel, a.seed, a.kmeans, spec).fit(X4c, Zc, Yc, Mc)
        secs.append(time.perf_counter() - t)
    # Predict over the whole record (the memory terms and the observer are causal over it).
    pred_h = model.predict_h(data["X4"], Z, M)[hold]
    Yh = data["Y"][hold]
    out = {
        "peer": "scikit-learn hybrid pipeline",
        "features": a.features,
        "kmeans": a.kmeans,
        "k": a.k,
        "sigma_mult": a.sigma_mult,
        "alpha_rel": a.alpha_rel,
        "dead_band_pm": a.dead_band_pm,
        "memory_groups": spec[0] if memory else None,
        "memory_lambda": spec[1] if memory else None,
        "n_samples": int(len(data["t"])),
        "n_cal": int(cal.sum()),
        "latch_seconds": latch_seconds,
        "feature_seconds": feature_seconds,
        "fit_seconds": secs,
        "fit_seconds_median": float(np.median(secs)),
        "model_p": {"rmse": rmse(model.predict_p(data["X4"][hold]), Yh)},
        "model_h": {"rmse": rmse(pred_h, Yh), "pickle_bytes": len(pickle.dumps(model))},
    }
    print(json.dumps(out, indent=1))


def cmd_blackbox(a):
    from sklearn.compose import TransformedTargetRegressor
    from sklearn.ensemble import HistGradientBoostingRegressor
    from sklearn.multioutput import MultiOutputRegressor
    from sklearn.neural_network import MLPRegressor

    data = read_csv(a.data)
    lat = latches(data["X4"][:, :3], a.dead_band_pm)
    inputs = {
        "dl+T_amb": data["X4"],
        "dl+T_amb+t": np.column_stack([data["X4"], data["t"]]),
        "dl+T_amb+latch": np.column_stack([data["X4"], lat]),
    }
    models = {
        "HistGradientBoosting": lambda: MultiOutputRegressor(HistGradientBoostingRegressor(random_state=0)),
        "MLP": lambda: TransformedTargetRegressor(
            regressor=make_pipeline(
                StandardScaler(),
                MLPRegressor(hidden_layer_sizes=(64, 64), early_stopping=True, max_iter=1000, random_state=0),
            ),
            transformer=StandardScaler(),
        ),
    }
    cal, hold = data["cal"], data["hold"]
    rows = gb_hybrids(data, inputs["dl+T_amb+latch"])
    for mname, make in models.items():
        for iname, X in inputs.items():
            m = make()
            t = time.perf_counter()
            m.fit(X[cal], data["Y"][cal])
            secs = time.perf_counter() - t
            rows.append({
                "model": mname,
                "inputs": iname,
                "fit_seconds": secs,
                "rmse": rmse(m.predict(X[hold]), data["Y"][hold]),
                "pickle_bytes": len(pickle.dumps(m)),
            })
    print_peers(data, rows)


def gb_hybrids(data, latch_inputs):
    """Model-P plus a gradient-boosting residual (one regressor per output on Model-P's
    calibration residuals), on [dl, T_amb, latches] and on the 59 history inputs."""
    from sklearn.ensemble import HistGradientBoostingRegressor
    from sklearn.multioutput import MultiOutputRegressor

    cal, hold = data["cal"], data["hold"]
    rows = []
    hyb = HybridPeer(1, 1.0, 1.0, 0)
    for iname, X in {"dl+T_amb+latch": latch_inputs, "dl+T_amb+history": history_features(data)}.items():
        t = time.perf_counter()
        hyb.stage1 = LinearRegression().fit(data["X4"][cal], data["Y"][cal])
        g = hyb.stage1.predict(data["X4"][cal])
        hyb.stage2 = make_pipeline(StandardScaler(), PolynomialFeatures(2), LinearRegression(fit_intercept=False)).fit(g, data["Y"][cal])
        resid = data["Y"][cal] - hyb.predict_p(data["X4"][cal])
        gb = MultiOutputRegressor(HistGradientBoostingRegressor(random_state=0)).fit(X[cal], resid)
        secs = time.perf_counter() - t
        pred = hyb.predict_p(data["X4"][hold]) + gb.predict(X[hold])
        rows.append({
            "model": "Model-P + HistGradientBoosting residual",
            "inputs": iname,
            "n_inputs": int(X.shape[1]),
            "fit_seconds": secs,
            "rmse": rmse(pred, data["Y"][hold]),
            "pickle_bytes": len(pickle.dumps((hyb.stage1, hyb.stage2, gb))),
        })
    return rows


def cmd_hybrids(a):
    data = read_csv(a.data)
    lat = latches(data["X4"][:, :3], a.dead_band_pm)
    print_peers(data, gb_hybrids(data, np.column_stack([data["X4"], lat])))


def print_peers(data, rows):
    """The JSON object of ``blackbox`` and ``hybrids``: the record's sizes and one row a peer."""
    print(json.dumps({"n_samples": int(len(data["t"])), "n_cal": int(data["cal"].sum()), "peers": rows}, indent=1))


def ema(x, samples):
    """Exponential moving average with time constant `samples`, causal, started at x[0]."""
    a = 1.0 / (1.0 + samples)
    out = np.empty_like(x)
    acc = x[0]
    for i, v in enumerate(x.tolist()):
        acc += a * (v - acc)
        out[i] = acc
    return out


def samples_since_extreme(x, dead_band_pm):
    """Samples since the latch's running extreme last moved (0 while the signal makes new
    extremes, growing while it sits inside the dead band)."""
    out = np.zeros(len(x))
    anchor, direction, since = None, 0, 0
    for i, v in enumerate(x.tolist()):
        if anchor is None:
            anchor = v
            continue
        moved = True
        if direction == 1 and v > anchor:
            anchor = v
        elif direction == -1 and v < anchor:
            anchor = v
        elif direction in (1, 0) and v < anchor - dead_band_pm:
            direction, anchor = -1, v
        elif direction in (-1, 0) and v > anchor + dead_band_pm:
            direction, anchor = 1, v
        else:
            moved = False
        since = 0 if moved else since + 1
        out[i] = since
    return out


def lagged_change(x, k):
    out = np.zeros(len(x))
    out[k:] = x[k:] - x[:-k]
    return out


def history_features(data):
    """59 causal inputs (see the module doc): what a much richer residual learner could see."""
    dl, t_amb = data["X4"][:, :3], data["X4"][:, 3]
    cols = [data["X4"][:, c] for c in range(4)]
    for g in range(3):
        y = dl[:, g]
        for db in (1.0, 2.0, 4.0, 6.0):
            cols.append(latches(y[:, None], db)[:, 0])
        for k in (1, 2, 4, 8, 16, 32):
            cols.append(lagged_change(y, k))
        for db in (2.0, 4.0):
            cols.append(samples_since_extreme(y, db))
        for tau in (2, 8, 60, 180):
            cols.append(y - ema(y, tau))
    for k in (1, 4, 16, 32):
        cols.append(lagged_change(t_amb, k))
    for tau in (60, 180, 720):
        cols.append(ema(t_amb, tau))
    return np.column_stack(cols)


def cmd_versions(_a):
    import sklearn

    print(json.dumps({"python": platform.python_version(), "numpy": np.__version__, "scikit_learn": sklearn.__version__}))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fit", help="time the equivalent fixed-hyper-parameter hybrid pipeline")
    f.add_argument("--data", required=True)
    f.add_argument("--repeats", type=int, default=3)
    f.add_argument("--features", choices=["paper", "hysteresis-aware", "memory"], default="paper")
    f.add_argument("--memory-groups", default="",
                   help="with --features memory: each output's groups, outputs by ',' and groups by '+'")
    f.add_argument("--memory-lambda", default="", help="with --features memory: each output's lambda, by ','")
    f.add_argument("--k", type=int, default=32)
    f.add_argument("--sigma-mult", type=float, default=2.0)
    f.add_argument("--alpha-rel", type=float, default=1e-5)
    f.add_argument("--dead-band-pm", type=float, default=4.0)
    f.add_argument("--seed", type=int, default=1)
    f.add_argument("--kmeans", choices=["all", "subsample"], default="subsample",
                   help="cluster every calibration row with KMeans' defaults (as a notebook does), or our subsample")
    f.set_defaults(func=cmd_fit)
    b = sub.add_parser("blackbox", help="gradient boosting and MLP accuracy peers")
    b.add_argument("--data", required=True)
    b.add_argument("--dead-band-pm", type=float, default=4.0)
    b.set_defaults(func=cmd_blackbox)
    h = sub.add_parser("hybrids", help="only the gradient-boosting hybrids of blackbox (the per-seed comparison)")
    h.add_argument("--data", required=True)
    h.add_argument("--dead-band-pm", type=float, default=4.0)
    h.set_defaults(func=cmd_hybrids)
    v = sub.add_parser("versions")
    v.set_defaults(func=cmd_versions)
    a = p.parse_args()
    a.func(a)


if __name__ == "__main__":
    main()
