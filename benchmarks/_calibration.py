"""Shared by the interval-calibration benchmarks: the simulated trajectory and the noise models.

The regressors x, v, P are one trajectory of hmid's Ch. 4 rig simulator (1 kHz, random pressure
levels held 0.3-1 s), used exactly, or (:func:`sines`) slow sinusoids, a slowly excited rig whose
regressors each change over hundreds of rows: there a short log's fit takes the most of its
residual's correlation. Noise of one model is added to a known target:

* ``"white"``: i.i.d. Gaussian;
* a number phi: stationary AR(1) of that coefficient (integrated correlation time
  (1 + phi) / (1 - phi) samples), marginal sd ``sigma``;
* ``"smoothed"``: white sensor noise through the pipeline's own smoother, the centred 11 ms
  moving average applied 3 times (``denoise.smoother`` defaults), as ``hmid run`` applies it to
  both sides of the balance (correlation time ~19 samples).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hmid.signal.moving_average import MovingAverage, Window
from hmid.simulate.params import RigParams
from hmid.simulate.profiles import RandomLevels
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle

ENTROPY = 20261115
RATE = 1000.0
CONFIDENCE = 0.95
SIGMA = 0.02  # N, marginal sd of white and AR(1) noise
SIGMA_SENSOR = 0.05  # N, white load-cell noise before the pipeline's smoothing
SIGMA_X = 2e-5  # m, position noise before smoothing (noisy-inputs case)
SMOOTHER = MovingAverage(Window(seconds=0.011), "centred", "shrink", 3)  # hmid run's default
Z95 = 1.959964  # the normal quantile of a 95 % interval ("needed" width = 2 Z95 sd)


def trajectory(seconds: float) -> pd.DataFrame:
    """x [m], v [m/s], P [Pa] of the simulated rig under random pressure levels."""
    rng = np.random.default_rng(np.random.SeedSequence(ENTROPY, spawn_key=(99,)))
    t = np.arange(int(seconds * RATE)) / RATE
    profile = RandomLevels(low=6e4, high=2e5, hold_min=0.3, hold_max=1.0)
    traj = integrate(HydroMuscle(RigParams()), {"P_cmd": profile.command(t, rng)}, RATE)
    return pd.DataFrame({"x": traj.x, "v": traj.v, "P": traj.P})


def sines(seconds: float) -> pd.DataFrame:
    """x [m], v [m/s], P [Pa] as slow sinusoids (0.45-1.9 Hz), as ``tests/models``' rig log."""
    t = np.arange(int(seconds * RATE)) / RATE
    x = 0.0075 + 0.004 * np.sin(2 * np.pi * 0.7 * t) + 0.002 * np.sin(2 * np.pi * 1.9 * t + 1)
    P = 1.2e5 + 6e4 * np.sin(2 * np.pi * 0.45 * t + 0.3)
    return pd.DataFrame({"x": x, "v": np.gradient(x, t), "P": P})


def noise(model: str | float, n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` samples of the noise ``model`` (see the module docstring) of scale ``sigma``."""
    from scipy.signal import lfilter

    if model == "white":
        return rng.normal(0.0, sigma, n)
    if model == "smoothed":
        return SMOOTHER(np.arange(n) / RATE, rng.normal(0.0, sigma, n))
    phi = float(model)
    burn = int(20 / (1 - phi))  # the start-up transient decays to phi^burn ~ 1e-9
    e = lfilter([1.0], [1.0, -phi], rng.normal(0.0, sigma * np.sqrt(1 - phi**2), n + burn))
    return e[burn:]


def binomial_se(hits: np.ndarray) -> float:
    """Standard error of the coverage ``hits.mean()`` treating every interval as independent."""
    coverage = float(np.mean(hits))
    return float(np.sqrt(coverage * (1 - coverage) / max(hits.size, 1)))
