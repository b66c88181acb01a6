"""Calibration of the polynomial family's coefficient intervals against a known polynomial truth.

Run: ``.venv/bin/python benchmarks/bench_calibration_polynomial.py [--replications 200]
[--seconds 20] [--trajectory rig|sines] [--errors autocov]`` (``--errors`` left out: the family's
default method).

The regressors x, v, P are one trajectory of hmid's Ch. 4 rig simulator (1 kHz, random pressure
levels held 0.3-1 s), used exactly. The target is a known polynomial in them (each term worth
0.2-1 N at full scale) plus noise of one model per row of the table:

* ``white``: i.i.d. Gaussian, sd 0.02 N;
* ``AR(1) phi``: stationary AR(1), marginal sd 0.02 N, phi 0.5 / 0.9 / 0.97 (integrated
  correlation time (1 + phi) / (1 - phi) = 3 / 19 / 66 samples);
* ``smoothed``: white sensor noise (sd 0.05 N) through the pipeline's own smoother, the centred
  11 ms moving average applied 3 times (``denoise.smoother`` defaults), as ``hmid run`` applies it
  to both sides of the balance (correlation time ~19 samples).

Two harder cases are reported but judged separately, because no interval around a biased
estimate covers the truth at its nominal rate once the bias exceeds the standard error:

* ``misspecified``: the truth has a small x³ term (0.02 N at full x) that the fitted
  ``quadratic_xvP`` lacks (smoothed noise);
* ``noisy x``: x measured with smoothed white noise (sd 20 µm, one step of the 10-bit sensor)
  (errors in variables; smoothed noise on the target).

``--trajectory sines`` replaces the rig's trajectory by slow sinusoids (:func:`_calibration.sines`).
``--seconds 3`` (about 3,000 rows: 190 effective rows for 16 terms at a correlation time of 20)
is the short-log check of ``make calibration``: there the fit's projection takes a third of the
residual's autocovariance within the window (:func:`hmid.stats.fitted_correlation` gives it
back). The ``labelled calibrated`` column is the share of fits whose ``calibration`` column reads
``calibrated``: a row out of the band should not read so.

Each case runs ``--replications`` fits, replication ``r`` of case ``c`` seeded by
``SeedSequence(ENTROPY, spawn_key=(c, r))``. Reported: the empirical coverage of the 95 %
intervals pooled over coefficients with its binomial standard error (which treats the p intervals
of one fit as independent; the s.e. over replications, which does not, is given too), the median
interval width relative to the plain OLS width on the same data, and relative to the width
actually needed (2 x 1.96 x the spread of the estimates over replications, per coefficient).
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
    noise,
    sines,
    trajectory,
)
from threadpoolctl import threadpool_limits

from hmid.models.polynomial import PolynomialModel
from hmid.models.terms import variant_terms
from hmid.report.markdown import markdown_table

#: (label, noise model, truth variant, fitted variant, extra x³ in N at full x, noisy x, judged)
CASES = (
    ("white", "white", "cubic_xvP", "cubic_xvP", 0.0, False, True),
    ("AR(1) φ = 0.5", 0.5, "cubic_xvP", "cubic_xvP", 0.0, False, True),
    ("AR(1) φ = 0.9", 0.9, "cubic_xvP", "cubic_xvP", 0.0, False, True),
    ("AR(1) φ = 0.97", 0.97, "cubic_xvP", "cubic_xvP", 0.0, False, True),
    ("smoothed (11 ms × 3)", "smoothed", "cubic_xvP", "cubic_xvP", 0.0, False, True),
    ("misspecified: no x³ term", "smoothed", "quadratic_xvP", "quadratic_xvP", 0.02, False, False),
    ("noisy x (20 µm, smoothed)", "smoothed", "cubic_xvP", "cubic_xvP", 0.0, True, False),
)  # fmt: skip


def truth_of(variant: str, X: pd.DataFrame) -> np.ndarray:
    """Coefficients in physical units, each term worth 0.2-1 N at the trajectory's full scale."""
    terms = variant_terms(variant)
    rng = np.random.default_rng(np.random.SeedSequence(ENTROPY, spawn_key=(98,)))
    size = rng.uniform(0.2, 1.0, len(terms)) * rng.choice([-1.0, 1.0], len(terms))
    full = {k: float(np.max(np.abs(X[k]))) for k in X}
    return np.array([a / t.scale_factor(full) for a, t in zip(size, terms, strict=True)])


def run_case(index: int, case: tuple, X: pd.DataFrame, reps: int, errors: str | None) -> dict:
    label, model, truth_variant, fit_variant, cubic, noisy_x, judged = case
    terms = variant_terms(truth_variant)
    coef = truth_of(truth_variant, X)
    columns = {k: X[k].to_numpy() for k in X}
    clean = sum(c * t.evaluate(columns) for c, t in zip(coef, terms, strict=True))
    clean = clean + cubic * (X["x"].to_numpy() / X["x"].abs().max()) ** 3
    n = len(X)
    sigma = SIGMA_SENSOR if model == "smoothed" else SIGMA
    options = {} if errors is None else {"errors": errors}
    estimates, hits, width, width_ols, taus, labelled = [], [], [], [], [], []
    for rep in range(reps):
        rng = np.random.default_rng(np.random.SeedSequence(ENTROPY, spawn_key=(index, rep)))
        y = clean + noise(model, n, sigma, rng)
        Xm = X
        if noisy_x:
            Xm = X.assign(x=X["x"] + noise("smoothed", n, SIGMA_X, rng))
        fit = PolynomialModel(fit_variant, confidence=CONFIDENCE, **options).fit(Xm, y)
        ols = PolynomialModel(fit_variant, confidence=CONFIDENCE, errors="ols").fit(Xm, y)
        low, high = fit.conf_int_.T
        estimates.append(fit.coef_)
        hits.append((low <= coef) & (coef <= high))
        width.append(high - low)
        width_ols.append(np.diff(ols.conf_int_, axis=1)[:, 0])
        taus.append(getattr(fit, "tau_int_", np.nan))
        labelled.append(fit.interval_note().within is True)
    hits, width = np.array(hits), np.array(width)
    needed = 2 * 1.959964 * np.std(np.array(estimates), axis=0, ddof=1)
    coverage = float(hits.mean())
    return {
        "noise": label,
        "fitted": fit_variant,
        "judged": "yes" if judged else "separately",
        "coverage": coverage,
        "s.e. (binomial)": float(np.sqrt(coverage * (1 - coverage) / hits.size)),
        "s.e. (replications)": float(np.std(hits.mean(axis=1), ddof=1) / np.sqrt(reps)),
        "width / OLS": float(np.median(width / np.array(width_ols))),
        "width / needed": float(np.median(width / needed)),
        "tau_int (samples)": float(np.nanmedian(taus)) if np.isfinite(taus).any() else np.nan,
        "labelled calibrated": float(np.mean(labelled)),
        "in 0.92-0.98": "yes" if 0.92 <= coverage <= 0.98 else "no",
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replications", type=int, default=200)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--trajectory", choices=["rig", "sines"], default="rig")
    parser.add_argument("--errors", default=None, help="interval method (default: the default)")
    args = parser.parse_args()
    X = trajectory(args.seconds) if args.trajectory == "rig" else sines(args.seconds)
    method = args.errors or PolynomialModel("quadratic_xv").errors
    start = time.perf_counter()
    with threadpool_limits(limits=1):  # one core; also spares a shared machine's BLAS threads
        rows = [run_case(i, c, X, args.replications, args.errors) for i, c in enumerate(CASES)]
    wall = time.perf_counter() - start
    frame = pd.DataFrame(rows)
    print(
        f"Polynomial coefficients, {100 * CONFIDENCE:g} % intervals, errors: {method}; "
        f"{args.replications} replications x {args.seconds:g} s at {RATE:g} Hz, "
        f"{args.trajectory} trajectory ({wall:.0f} s)\n"
    )
    print(markdown_table(frame, float_format=".3f"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
