"""Calibration of the balance's coefficient intervals (the loop's effects, the balance family, the
SLS sign check) against a known linear truth.

Run: ``.venv/bin/python benchmarks/bench_calibration_balance.py [--replications 200]``.

The rows are one simulated rig trajectory (``_calibration.trajectory``: 1 kHz, random pressure
levels), cut into two logs, with the stopped rows (|v| < 2 mm/s) left out as the pipeline does.
The columns are those the loop fits: a constant, x, x³, P, v (viscous) and the smoothed sign(v)
(Coulomb), each worth 0.1-1 N; the target is their sum with known coefficients plus noise of
one model per row (white, AR(1) phi 0.5 / 0.9 / 0.97, white sensor noise through the pipeline's
smoother; see ``_calibration``). Side by side on the same fits:

* ``autocov`` (default, :func:`hmid.balance.inference.inference`): the sandwich with the
  residual's autocovariance up to Sokal's window, lag products within segments, t on
  n / (2 M + 1) df;
* ``n/tau_int``: the method used before, OLS errors inflated by sqrt(tau_int), t on n/tau - p df.

Reported: 95 % coverage pooled over coefficients with its binomial s.e., and the median width
relative to the width needed (2 x 1.96 x the spread of the estimates over replications).
Target (issue "Intervals that mean what they say"): 0.92-0.98.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd
from _calibration import CONFIDENCE, ENTROPY, SIGMA, SIGMA_SENSOR, noise, trajectory
from scipy import stats

from hmid.balance import Signals, inference
from hmid.balance.columns import Columns
from hmid.report.markdown import markdown_table
from hmid.stats import residual_tau_int

CASES = (("white", "white"), ("AR(1) φ = 0.5", 0.5), ("AR(1) φ = 0.9", 0.9),
         ("AR(1) φ = 0.97", 0.97), ("smoothed", "smoothed"))  # fmt: skip
#: coefficient x full-scale column ~ 0.1-1 N
TRUTH = {"F0": 0.3, "k": 40.0, "k3": 1.5e5, "A": 2e-6, "b": 2.0, "Fc": 0.15}


def problem(seconds: float) -> tuple[Signals, Columns, np.ndarray]:
    """Signals (two logs), the columns and the usable rows of the simulated trajectory."""
    traj = trajectory(seconds)
    n = len(traj)
    t = np.arange(n) / 1000.0
    half = n // 2
    frame = pd.DataFrame({"log": np.where(np.arange(n) < half, "a", "b"),
                          "t": np.where(np.arange(n) < half, t, t - t[half]),
                          "x": traj.x, "v": traj.v, "P": traj.P, "target": 0.0})  # fmt: skip
    signals = Signals.from_frame(frame, {"x": "m", "v": "m/s", "P": "Pa", "target": "N"})
    sign = signals.smooth(np.sign(traj.v.to_numpy()))
    x = traj.x.to_numpy()
    values = np.column_stack([np.ones(n), x, x**3, traj.P, traj.v, sign])
    columns = Columns(tuple(TRUTH), ("N", "N/m", "N/m3", "m2", "N s/m", "N"), values)
    rows = np.abs(traj.v.to_numpy()) > 2e-3
    rows[[0, half - 1, half, n - 1]] = False
    return signals, columns, rows


def old_method(columns, y, rows, signals, confidence):
    """OLS errors inflated by sqrt(tau_int) (hmid before this benchmark)."""
    import statsmodels.api as sm

    X = columns.values[rows]
    scale = np.max(np.abs(X), axis=0)
    fit = sm.OLS(y[rows], X / scale).fit()
    residual = np.zeros(len(y))
    residual[rows] = fit.resid
    tau = residual_tau_int(residual, signals, rows)
    value = np.asarray(fit.params) / scale
    se = np.asarray(fit.bse) / scale * np.sqrt(tau)
    half = stats.t.ppf(0.5 + confidence / 2, max(len(X) / tau - len(value), 1.0)) * se
    return value, value - half, value + half


def run_case(index: int, model, replications: int, problem_) -> dict[str, float]:
    signals, columns, rows = problem_
    truth = np.array(list(TRUTH.values()))
    clean = columns.values @ truth
    sigma = SIGMA_SENSOR if model == "smoothed" else SIGMA
    found = {"autocov": [], "n/tau_int": []}
    for r in range(replications):
        rng = np.random.default_rng(np.random.SeedSequence(ENTROPY, spawn_key=(50 + index, r)))
        y = clean + noise(model, len(clean), sigma, rng)
        table = inference(columns, y, rows, signals, CONFIDENCE)
        found["autocov"].append(table[["value", "lower", "upper"]].to_numpy().T)
        found["n/tau_int"].append(np.array(old_method(columns, y, rows, signals, CONFIDENCE)))
    out = {}
    for method, fits in found.items():
        value, lower, upper = (np.array([f[k] for f in fits]) for k in range(3))
        hits = (lower <= truth) & (truth <= upper)
        needed = 2 * stats.norm.ppf(0.5 + CONFIDENCE / 2) * value.std(axis=0)
        coverage = hits.mean()
        out[f"{method} coverage"] = coverage
        out[f"{method} ± s.e."] = np.sqrt(coverage * (1 - coverage) / hits.size)
        out[f"{method} width / needed"] = float(np.median(np.median(upper - lower, 0) / needed))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replications", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args()
    problem_ = problem(args.seconds)
    rows = []
    for index, (label, model) in enumerate(CASES):
        rows.append({"noise": label} | run_case(index, model, args.replications, problem_))
        print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    covered = table["autocov coverage"].between(0.92, 0.98)
    table["autocov in 0.92-0.98"] = np.where(covered, "met", "NOT met")
    print(f"\n95 % intervals, {args.replications} replications per row, "
          f"{len(TRUTH)} coefficients per fit\n")  # fmt: skip
    print(markdown_table(table, ".3f"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
