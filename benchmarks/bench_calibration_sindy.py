"""Calibration of the SINDy family's coefficient intervals against a known sparse truth.

Run: ``.venv/bin/python benchmarks/bench_calibration_sindy.py [--replications 30] [--seconds 20]
[--only AR,white]`` (``--only``: the cases whose label contains one of the comma-separated
texts; seeds stay those of the full run). About 0.6 s a replication on one core.

The regressors are the trajectory of ``bench_calibration_polynomial.py`` (``_calibration.py``:
hmid's Ch. 4 rig simulator at 1 kHz under random pressure levels). The target is the rig's own
muscle force map, sparse in the SINDy library: F_m = A_eff P - k1 x - k3 x³ (A_eff 2e-4 m²,
k1 3000 N/m, k3 2e6 N/m³), plus noise of one model per row (sd 0.02 N; ``_calibration.noise``):
white, AR(1) phi 0.5 / 0.9 / 0.97 (correlation times 3 / 19 / 66 samples), and white sensor noise
(sd 0.05 N) through the pipeline's 11 ms x 3 moving average. Two harder cases are judged
separately, since no interval around a biased estimate covers at its nominal rate:

* ``misspecified``: the truth has a small x⁴ term (0.02 N at full x) that the degree-3 library
  lacks (smoothed noise);
* ``noisy x``: x measured with smoothed white noise (sd 20 µm) (errors in variables).

Each replication is one default ``SINDyForceModel`` fit (CV-chosen threshold, nothing spared by
``keep``, |v| < 0.01 m/s left out: about 3000 of the 20 s's rows slide), replication ``r`` of case
``c`` seeded by ``SeedSequence(ENTROPY, spawn_key=(c, r))``. From each fit, both intervals:

* ``autocov`` (the default): the OLS refit on the selected support, covariance from the
  residual's autocovariance; conditional on the selected support;
* ``bootstrap`` (the old default): percentile intervals of the 50-model blocked bootstrap at the
  chosen threshold, zeros included.

Reported: how often the selected support equals the truth, and how often the fit warns that
its support is in doubt (a term kept by 20-80 % of the bootstrap fits); the coverage of the true
coefficients by the 95 % intervals, pooled over the three true terms and all replications (a
true term left out counts as a miss), with its binomial standard error (treating the intervals
of a fit as independent), and over the replications that selected the true support / that carry
no doubt warning; the median width (over the replications with the true support) relative to
the width needed, 2 x 1.96 x the spread of the *oracle* estimates (OLS on the true terms alone,
on the rows the fit uses); the residual's median correlation time.

Why the oracle's spread and not that of the SINDy estimates with the true support: selection
truncates the latter. A noise draw that pushes x, P and x³ far (a slow component like x² or
x·P) is the one where cross-validation picks the alternative support, so the replications that
keep the true support have estimates less spread than OLS's (on the SINDy tests' chirp under
AR(1) phi 0.9, the 4 % of fits that leave it took the largest deviations with them: the rest
spread 16 % less). The intervals, matched to OLS's spread, then cover more than nominal given
the true support.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from _calibration import (
    CONFIDENCE,
    ENTROPY,
    RATE,
    SIGMA,
    SIGMA_SENSOR,
    SIGMA_X,
    Z95,
    binomial_se,
    noise,
    trajectory,
)
from threadpoolctl import threadpool_limits

from hmid.models.sindy import SINDyForceModel, SINDySettings
from hmid.models.sindy._intervals import percentile_intervals
from hmid.models.sindy._model import DOUBT
from hmid.models.sindy._select import SUPPORT
from hmid.report.markdown import markdown_table

#: The true terms and coefficients (SI), the rig's muscle without memory.
TRUE = {"x": -3000.0, "P": 2e-4, "x^3": -2e6}
#: (label, noise model, extra x⁴ in N at full x, noisy x, judged)
CASES = (
    ("white", "white", 0.0, False, True),
    ("AR(1) φ = 0.5", 0.5, 0.0, False, True),
    ("AR(1) φ = 0.9", 0.9, 0.0, False, True),
    ("AR(1) φ = 0.97", 0.97, 0.0, False, True),
    ("smoothed (11 ms × 3)", "smoothed", 0.0, False, True),
    ("misspecified: x⁴ not in the library", "smoothed", 0.02, False, False),
    ("noisy x (20 µm, smoothed)", "smoothed", 0.0, True, False),
)  # fmt: skip
METHODS = ("autocov", "bootstrap")


def true_force(X: pd.DataFrame) -> np.ndarray:
    x, P = X["x"].to_numpy(), X["P"].to_numpy()
    return TRUE["P"] * P + TRUE["x"] * x + TRUE["x^3"] * x**3


def oracle(X: pd.DataFrame, y: np.ndarray, stick_speed: float) -> np.ndarray:
    """OLS on the true terms alone, on the rows a SINDy fit uses (|v| >= stick_speed)."""
    rows = np.abs(X["v"].to_numpy()) >= stick_speed
    x, P = X["x"].to_numpy()[rows], X["P"].to_numpy()[rows]
    design = np.column_stack([{"x": x, "P": P, "x^3": x**3}[term] for term in TRUE])
    scale = np.abs(design).max(axis=0)  # physical units span 1e-6 to 1e5
    return np.linalg.lstsq(design / scale, y[rows], rcond=None)[0] / scale


def replicate(X: pd.DataFrame, y: np.ndarray, seed: int, support: str) -> dict:
    """One fit: its support, both intervals of the true terms, and the oracle's estimates."""
    model = SINDyForceModel(
        SINDySettings(keep=(), ensemble={"confidence": CONFIDENCE}, support=support), seed=seed
    ).fit(X, y)
    names = [f.name for f in model.features_]
    index = [names.index(term) for term in TRUE]
    _, boot = percentile_intervals(model.ensemble_coef_, CONFIDENCE)
    return {
        "support": set(model.selected) == set(TRUE),
        # the fit's "support in doubt" warning: a term kept by 20-80 % of the bootstrap fits
        "doubt": bool(np.any((model.inclusion_ >= DOUBT[0]) & (model.inclusion_ < DOUBT[1]))),
        "oracle": oracle(X, y, model.stick_speed),
        # a true term left out has no interval under autocov: a miss (NaN compares False)
        "autocov": model.ci_[index],
        "bootstrap": boot[index],
        "tau": model.tau_int_,
    }


def summarise(fits: list[dict], truth: np.ndarray, method: str) -> dict:
    intervals = np.array([fit[method] for fit in fits])  # reps x terms x 2
    hits = (intervals[..., 0] <= truth) & (truth <= intervals[..., 1])
    right = np.array([fit["support"] for fit in fits])
    clear = ~np.array([fit["doubt"] for fit in fits])
    needed = 2 * Z95 * np.std(np.array([fit["oracle"] for fit in fits]), axis=0, ddof=1)
    ratio = np.nan
    if right.any():
        ratio = float(np.median(np.diff(intervals[right], axis=2)[..., 0] / needed))
    return {
        "coverage ± s.e.": f"{hits.mean():.3f} ± {binomial_se(hits):.3f}",
        "coverage | true support": float(hits[right].mean()) if right.any() else np.nan,
        "coverage | no doubt": float(hits[clear].mean()) if clear.any() else np.nan,
        "width / needed": ratio,
    }


def run_case(index: int, case: tuple, X: pd.DataFrame, reps: int, support: str) -> dict:
    label, model, quartic, noisy_x, judged = case
    x_full = float(X["x"].abs().max())
    clean = true_force(X) + quartic * (X["x"].to_numpy() / x_full) ** 4
    truth = np.array(list(TRUE.values()))
    n = len(X)
    sigma = SIGMA_SENSOR if model == "smoothed" else SIGMA
    fits = []
    for rep in range(reps):
        rng = np.random.default_rng(np.random.SeedSequence(ENTROPY, spawn_key=(index, rep)))
        y = clean + noise(model, n, sigma, rng)
        Xm = X.assign(x=X["x"] + noise("smoothed", n, SIGMA_X, rng)) if noisy_x else X
        fits.append(replicate(Xm, y, seed=rep, support=support))
    row = {
        "noise": label,
        "judged": "yes" if judged else "separately",
        "support = truth": float(np.mean([fit["support"] for fit in fits])),
        "support in doubt": float(np.mean([fit["doubt"] for fit in fits])),
    }
    for method in METHODS:
        found = summarise(fits, truth, method)
        if method != "autocov":  # the bootstrap's intervals are not conditional on the support
            del found["coverage | true support"], found["coverage | no doubt"]
        row |= {f"{method} {k}": v for k, v in found.items()}
    row["tau_int (samples)"] = float(np.median([fit["tau"] for fit in fits]))
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replications", type=int, default=30)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--only", default="", help="cases whose label contains one of a,b,...")
    parser.add_argument(
        "--support", choices=SUPPORT, default=SUPPORT[0], help="how the fits choose the support"
    )
    args = parser.parse_args()
    X = trajectory(args.seconds)
    start = time.perf_counter()
    with threadpool_limits(limits=1):  # one core; also spares a shared machine's BLAS threads
        rows = [
            run_case(i, case, X, args.replications, args.support)
            for i, case in enumerate(CASES)
            if any(text in case[0] for text in args.only.split(","))
        ]
    wall = time.perf_counter() - start
    print(
        f"SINDy coefficients of the true terms ({', '.join(TRUE)}), {100 * CONFIDENCE:g} % "
        f"intervals, autocov (default) vs bootstrap percentile; support by {args.support}; "
        f"{args.replications} "
        f"replications x {args.seconds:g} s at {RATE:g} Hz ({wall:.0f} s)\n"
    )
    print(markdown_table(pd.DataFrame(rows), float_format=".3f"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
