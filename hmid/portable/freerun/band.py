"""The band of a free run: what the model does not know, propagated through the simulation.

Two sources, each drawn and run through the free run (:meth:`Simulator.positions`):

* the coefficients' uncertainty: the model's posterior draws where it has them (the relaxation
  times drawn with the rest), else a normal with its coefficients' covariance;
* the model's own error in simulation: a disturbance force on the balance's model side, AR(1)
  with the training residual's RMS and correlation time, times a scale ``s``.

With s = 1 the band is far too narrow (15-44 % coverage of a nominal 90 % on the shipped
rigs): most of the one-step residual is sensor noise and the acceleration's, which the rig's
inertia filters out, while a free run drifts by what the model leaves unexplained at low
frequency. So ``s`` is calibrated, on the training blocks only (:func:`calibrate`): their free
runs, cut to the held-out blocks' length and each started from the measured state, give the
scale at which the band covers the measured position at the nominal level there. The held-out
blocks' coverage, reported, is then an honest check, never the target. A model whose
coefficient band alone covers more than the level gets ``s = 0`` (the band is then wider than
nominal, and says so); one that no scale brings to the level (its draws diverge) says that.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from hmid.balance.kinds import MemoryTerm
from hmid.portable.freerun.integrator import Coefficients, Simulator


def coefficient_draws(model, sim: Simulator, n: int, seed: int) -> list[Coefficients] | None:
    """``n`` draws of the simulator's coefficients from the model's uncertainty: its posterior
    draws where it has them (the relaxation times drawn with the rest), else a normal with its
    coefficients' covariance; None where the file has neither."""
    cr, cl, taus, lags = sim.coefficients()
    n_terms = len(model.terms)
    signs = np.array([t.sign for t in model.terms], dtype=float)
    rng = np.random.default_rng(seed)
    posterior = model.posterior
    if posterior is not None:
        post = posterior.posterior
        names = [t.name for t in model.terms]
        arms = [t for t in model.terms if isinstance(t, MemoryTerm)]
        tau_names = ["tau"] if len(arms) == 1 else [f"tau_{i + 1}" for i in range(len(arms))]
        if not all(v in post for v in (*names, *tau_names)):
            return None
        flat = {v: np.asarray(post[v]).reshape(-1) for v in (*names, *tau_names)}
        pick = rng.choice(len(flat[names[0]]), size=n, replace=False)
        out = []
        for i in pick:
            draw = cr.copy()
            draw[:n_terms] = signs * np.array([flat[v][i] for v in names])
            out.append((draw, cl, np.array([flat[v][i] for v in tau_names]), lags))
        return out
    cov = model.covariance
    if cov is None:
        return None
    cov = (cov + cov.T) / 2  # symmetric to rounding; eigh clips the rounding below zero
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        coef = rng.multivariate_normal(model.coef, cov, size=n, method="eigh")
    out = []
    for row in coef:
        draw = cr.copy()
        draw[:n_terms] = signs * row
        out.append((draw, cl, taus, lags))
    return out


def disturbances(model, n: int, draws: int, rng) -> np.ndarray:
    """``draws`` realisations (rows of ``n`` samples) of the force the model leaves unexplained,
    as a disturbance of the free run: AR(1) with the training residual's RMS and integrated
    autocorrelation time tau (phi = (tau - 1) / (tau + 1)); zeros where the file has none."""
    residual = model.document.get("residual") or {}
    sigma, tau = residual.get("rmse"), residual.get("tau_int") or 1.0
    if not sigma:
        return np.zeros((draws, n))
    phi = (tau - 1.0) / (tau + 1.0)
    e = rng.standard_normal((draws, n)) * sigma * np.sqrt(1 - phi**2)
    from scipy.signal import lfilter

    start = rng.standard_normal(draws) * sigma
    return lfilter([1.0], [1.0, -phi], e, axis=1, zi=(phi * start)[:, None])[0]


@dataclass(frozen=True)
class Calibration:
    """The disturbance's scale and the band's coverage on the training blocks at that scale."""

    scale: float
    coverage: float
    samples: int  # the training samples it was calibrated on
    reachable: bool = True  # False: no scale up to the largest tried reaches the level


def quantile_band(runs: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """The central ``level`` band of ``runs`` (draws, samples), numpy's linear quantiles of the
    draws that did not diverge (NaN or inf: left out); NaN bounds where every draw did. One
    sort for every sample (``np.nanquantile`` goes sample by sample)."""
    runs = np.where(np.isfinite(runs), runs, np.nan)
    ordered = np.sort(runs, axis=0)  # NaN last
    valid = np.sum(np.isfinite(runs), axis=0)
    last = np.maximum(valid - 1, 0)[None]
    tail = (1 - level) / 2
    bounds = []
    for q in (tail, 1 - tail):
        position = (valid - 1) * q
        below = np.clip(np.floor(position).astype(int)[None], 0, last)
        low = np.take_along_axis(ordered, below, 0)[0]
        high = np.take_along_axis(ordered, np.minimum(below + 1, last), 0)[0]
        bound = low + (high - low) * (position - below[0])
        bounds.append(np.where(valid > 0, bound, np.nan))
    return bounds[0], bounds[1]


def calibrate(chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]], level: float,
              largest: float = 1e4) -> Calibration:  # fmt: skip
    """The scale s of the disturbance at which the band covers ``level`` of the measured
    position over ``chunks``, each (measured, nominal, coefficient deviations, disturbance
    deviations): the runs of the coefficient draws without disturbance, less the nominal run,
    and of the nominal coefficients under a disturbance of scale 1, less the nominal run. Their
    sum, nominal + C + s D, stands for a draw of both (to first order: a free run responds to a
    small force linearly), so s is found without a run per trial scale."""
    samples = sum(len(x) for x, *_ in chunks)

    def coverage(s: float) -> float:
        inside = 0
        for x, nominal, c, d in chunks:
            lower, upper = quantile_band(nominal + c + s * d, level)
            inside += int(np.sum((lower <= x) & (x <= upper)))
        return inside / samples

    low, covered = 0.0, coverage(0.0)
    if covered >= level:
        return Calibration(0.0, covered, samples)
    high = 1.0
    while (covered := coverage(high)) < level:
        if high >= largest:
            return Calibration(high, covered, samples, reachable=False)
        low, high = high, high * 4
    for _ in range(14):  # to ~1 % of s
        middle = np.sqrt(low * high) if low else high / 4
        if coverage(middle) >= level:
            high = middle
        else:
            low = middle
    return Calibration(high, coverage(high), samples)
