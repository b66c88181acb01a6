"""Friction models: small frozen strategies that evaluate friction(v) and fit a free fall.

A free fall is fitted in the *travel frame* ``u = s x`` (``s = ±1``, the direction the block
slides), where a known drive pulls the moving mass and friction opposes it (thesis eq. 4.1 with
the muscle disconnected: drive m1 g, mass M + m1; see :class:`FallRig`):

    mass u'' = drive - Fc - b u'        (b = 0 for pure Coulomb friction)

so each model only sees a monotone, accelerating travel ``u(tau)`` on the sliding segment, with
``tau = t - t_ref`` centred on the segment. Both models fit positions, never estimated
derivatives: residuals are then mostly sensor noise and quantisation; fitting ``a_est`` against
``v`` instead would use residuals that the derivative's smoothing window correlates over dozens
of samples. A position sensor's noise may still be correlated in time (a filtered amplifier), so
the covariance is the widest of the i.i.d. one, the sandwich with the residual's autocovariance up
to Sokal's window and the sandwich for AR(1) + white errors fitted through the fit's projection,
on every fall of the sensor at once where there are several (:func:`correlated_covariance`;
under AR(1) phi 0.9 position noise in ``benchmarks/bench_calibration_friction.py`` the plain one
covered 0.41 at 95 % nominal, the lag window 0.87, all three 0.96-0.98).

A plug-in model subclasses :class:`FrictionModel` and implements its four methods.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass
from math import factorial
from types import MappingProxyType
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import statsmodels.api as sm
from scipy.optimize import curve_fit

from hmid.stats import autocov_covariance, fit_ar_white, residual_correlation

if TYPE_CHECKING:
    from hmid.stats import ARWhite

#: The longest residual correlation time (samples, as :func:`correlated_covariance` measures
#: it) at which benchmarks/bench_calibration_friction.py met the band: the median over the
#: falls of its AR(1) phi = 0.97 case, 29.5 (phi 0.5: 2.6; phi 0.9: 13.5).
FRICTION_CALIBRATED_TAU = 29.0


@dataclass(frozen=True)
class FallRig:
    """A free-fall test: the ``drive`` force [N] (the hanging weight m1 g on the Ch. 4 rig)
    drags the moving ``mass`` [kg] (M + m1), and friction alone opposes it."""

    mass: float
    drive: float

    def __post_init__(self) -> None:
        for name in ("mass", "drive"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"free-fall {name}={value!r} must be a positive finite number")


@dataclass(frozen=True)
class FallFit:
    """A model fitted to the travel ``u(tau)`` of one sliding segment (travel frame, SI)."""

    params: Mapping[str, float]  # friction parameters, in the model's ``param_names`` order
    cov: np.ndarray  # their covariance (p x p)
    u0: float  # travel at tau = 0, m
    w0: float  # travel speed at tau = 0, m/s
    fitted: np.ndarray  # fitted travel at each sample, m
    dof: float  # degrees of freedom of the t intervals
    tau_int: float = float("nan")  # the residual's correlation time, samples
    design: np.ndarray | None = None  # the fit's Jacobian at the estimate (rows x parameters)


def correlated_covariance(
    jacobian: np.ndarray,
    resid: np.ndarray,
    keep: list[int],
    factor: float = 1.0,
    noise: ARWhite | None = None,
) -> tuple[np.ndarray, float, float]:
    """Covariance of the least-squares parameters ``keep`` (times ``factor``) for a residual
    correlated in time, the t intervals' degrees of freedom, and the residual's correlation
    time in samples (the larger of the lag window's and the AR(1) + white model's: the first
    reads short on a short record). The widest, direction by
    direction, of: the i.i.d. covariance (n - p df; on a short fall a white residual's
    estimated autocovariance is noisy, and a too-narrow interval fails the pooling's
    homogeneity test); the sandwich with the residual's autocovariance up to Sokal's window
    (:func:`hmid.stats.autocov_covariance`, n / (2 M + 1) df); and the sandwich for AR(1) +
    white errors fitted through the fit's projection (:func:`hmid.stats.fit_ar_white`,
    n (1 - phi) / (1 + phi) df): a fall a few correlation times long holds too few lags for the
    first, and its residual has lost the errors' slow part to the fit. ``noise``: that AR(1) +
    white model fitted on every fall of the sensor at once
    (:func:`~hmid.friction.identify_friction`), in place of this fall's own; the df stay this
    fall's n (1 - phi) / (1 + phi), since phi itself is uncertain (with the df of all the
    falls' rows, phi 0.97 falls covered 0.90)."""
    n, p = jacobian.shape
    gamma, window, tau_int = residual_correlation(resid)
    lags = window if window is not None else gamma.size - 1
    scale = np.sqrt(np.mean(jacobian**2, axis=0))
    scale[scale == 0] = 1.0
    design = jacobian / scale
    cov = np.linalg.pinv(design.T @ design) * float(resid @ resid) / max(n - p, 1)
    dof = n - p
    cov, wider = _at_least(cov, autocov_covariance(design, gamma[: lags + 1]))
    if wider:
        dof = min(dof, n / (2 * lags + 1))
    found = noise if noise is not None else fit_ar_white([(design, np.asarray(resid))])
    if found is not None:
        cov, wider = _at_least(cov, found.covariance(design))
        if wider:
            dof = min(dof, n * (1 - found.phi) / (1 + found.phi))
        tau_int = max(tau_int, found.tau_int)
    cov = cov / np.outer(scale, scale)
    return cov[np.ix_(keep, keep)] * factor**2, float(max(dof, 1)), float(tau_int)


def _at_least(base: np.ndarray, other: np.ndarray) -> tuple[np.ndarray, bool]:
    """``base`` widened, along the eigendirections of ``other`` relative to it, to ``other``
    wherever that is wider (so at least both in the Loewner order), and whether it widened."""
    lower = np.linalg.cholesky(base)
    inverse = np.linalg.inv(lower)
    ratio, vectors = np.linalg.eigh(inverse @ other @ inverse.T)
    widest = lower @ vectors @ np.diag(np.maximum(ratio, 1.0)) @ vectors.T @ lower.T
    return widest, bool(np.any(ratio > 1.0))


@dataclass(frozen=True)
class FrictionModel(abc.ABC):
    """A friction law ``friction(v)`` (N, signed along +x, opposing motion) and its fall fit."""

    name: ClassVar[str]
    param_names: ClassVar[tuple[str, ...]]
    units: ClassVar[Mapping[str, str]]

    @abc.abstractmethod
    def friction(self, v: np.ndarray, params: Mapping[str, float]) -> np.ndarray:
        """Friction force (N) at velocity ``v`` (m/s); its sign follows ``v``."""

    @abc.abstractmethod
    def fit_fall(
        self, tau: np.ndarray, u: np.ndarray, rig: FallRig, noise: ARWhite | None = None
    ) -> FallFit:
        """Least-squares fit of the travel ``u`` (m) at times ``tau`` (s, centred); ``noise``:
        the sensor's AR(1) + white errors, if fitted on all falls
        (:func:`correlated_covariance`)."""

    @abc.abstractmethod
    def travel(
        self, tau: np.ndarray, u0: float, w0: float, params: Mapping[str, float], rig: FallRig
    ) -> np.ndarray:
        """Travel (m) predicted at ``tau`` from ``u0``, ``w0`` at tau = 0 and the parameters."""

    @abc.abstractmethod
    def load_cell_design(self, speed: np.ndarray) -> np.ndarray:
        """Regressors (n x p) such that the friction magnitude at ``speed`` = design @ params."""


def _mass(rig: FallRig) -> float:
    return rig.mass


@dataclass(frozen=True)
class Coulomb(FrictionModel):
    """Coulomb friction (thesis Ch. 4): ``friction(v) = sign(v) Fc``.

    Free fall: constant acceleration, ``u = u0 + w0 tau + a tau^2 / 2`` fitted by statsmodels OLS;
    ``Fc = drive - mass a``, with the standard error of ``a`` (:func:`correlated_covariance`)
    scaled by the mass.
    """

    name: ClassVar[str] = "coulomb"
    param_names: ClassVar[tuple[str, ...]] = ("Fc",)
    units: ClassVar[Mapping[str, str]] = MappingProxyType({"Fc": "N"})

    def friction(self, v, params):
        return np.sign(np.asarray(v, dtype=float)) * params["Fc"]

    def fit_fall(self, tau, u, rig, noise=None):
        design = np.column_stack([np.ones_like(tau), tau, 0.5 * tau**2])
        ols = sm.OLS(u, design).fit()
        mass = _mass(rig)
        Fc = rig.drive - mass * ols.params[2]
        cov, dof, tau_int = correlated_covariance(design, np.asarray(ols.resid), [2], mass, noise)
        return FallFit(
            {"Fc": float(Fc)}, cov, float(ols.params[0]), float(ols.params[1]),
            np.asarray(ols.fittedvalues), dof, tau_int, design,
        )  # fmt: skip

    def travel(self, tau, u0, w0, params, rig):
        a = (rig.drive - params["Fc"]) / _mass(rig)
        return u0 + w0 * tau + 0.5 * a * tau**2

    def load_cell_design(self, speed):
        return np.ones((len(speed), 1))


# -- phi functions of the viscous solution --------------------------------------------------------
_TERMS = 14
_C1 = np.array([(-1) ** n / factorial(n + 1) for n in range(_TERMS)])
_C2 = np.array([(-1) ** n / factorial(n + 2) for n in range(_TERMS)])
_D1 = np.arange(1, _TERMS) * _C1[1:]
_D2 = np.arange(1, _TERMS) * _C2[1:]


def _phi(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``phi1 = (1 - e^-z)/z``, ``phi2 = (z - 1 + e^-z)/z^2`` and their derivatives in z.

    Taylor series for |z| < 0.1, closed forms elsewhere. The closed form of phi2 cancels
    catastrophically near 0 (its error grows as eps/z^2), which is harmless for the values but
    ruins finite-difference Jacobians: with them the interval on b came out 4x too narrow when
    the true b is near 0. So the Jacobian is analytic.
    """
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 0.1
    zs = np.where(small, 1.0, z)
    p1 = -np.expm1(-zs) / zs
    p2 = (zs + np.expm1(-zs)) / zs**2
    d1 = (np.exp(-zs) - p1) / zs
    d2 = (p1 - 2.0 * p2) / zs
    powers = z[..., None] ** np.arange(_TERMS)
    return (
        np.where(small, powers @ _C1, p1),
        np.where(small, powers @ _C2, p2),
        np.where(small, powers[..., :-1] @ _D1, d1),
        np.where(small, powers[..., :-1] @ _D2, d2),
    )


@dataclass(frozen=True)
class CoulombViscous(FrictionModel):
    """Coulomb plus viscous friction: ``friction(v) = sign(v) Fc + b v``.

    Free fall: ``u'' = alpha - k u'`` with ``alpha = (drive - Fc)/mass``, ``k = b/mass``,
    solved exactly, ``u = u0 + w0 tau phi1(k tau) + alpha tau^2 phi2(k tau)``, and fitted by
    nonlinear least squares (:func:`scipy.optimize.curve_fit`, Levenberg-Marquardt, analytic
    Jacobian, started from the Coulomb fit). The covariance is the sandwich of that Jacobian with
    the residual's autocovariance (:func:`correlated_covariance`). ``b`` is not bounded at 0, so
    a fit to Coulomb-only data returns b near 0 with an honest interval on either side.
    """

    name: ClassVar[str] = "coulomb_viscous"
    param_names: ClassVar[tuple[str, ...]] = ("Fc", "b")
    units: ClassVar[Mapping[str, str]] = MappingProxyType({"Fc": "N", "b": "N s/m"})

    def friction(self, v, params):
        v = np.asarray(v, dtype=float)
        return np.sign(v) * params["Fc"] + params["b"] * v

    def _curve(self, rig):
        mass, drive = _mass(rig), rig.drive

        def model(tau, u0, w0, Fc, b):
            p1, p2, _, _ = _phi(b / mass * tau)
            return u0 + w0 * tau * p1 + (drive - Fc) / mass * tau**2 * p2

        def jacobian(tau, u0, w0, Fc, b):
            p1, p2, d1, d2 = _phi(b / mass * tau)
            alpha = (drive - Fc) / mass
            d_b = (w0 * tau**2 * d1 + alpha * tau**3 * d2) / mass
            return np.column_stack([np.ones_like(tau), tau * p1, -(tau**2) * p2 / mass, d_b])

        return model, jacobian

    def fit_fall(self, tau, u, rig, noise=None):
        start = Coulomb().fit_fall(tau, u, rig)
        model, jacobian = self._curve(rig)
        p0 = [start.u0, start.w0, start.params["Fc"], 0.0]
        popt, _ = curve_fit(model, tau, u, p0=p0, jac=jacobian, method="lm", maxfev=2000)
        fitted = model(tau, *popt)
        design = jacobian(tau, *popt)
        cov, dof, tau_int = correlated_covariance(design, u - fitted, [2, 3], noise=noise)
        return FallFit(
            {"Fc": float(popt[2]), "b": float(popt[3])}, cov,
            float(popt[0]), float(popt[1]), fitted, dof, tau_int, design,
        )  # fmt: skip

    def travel(self, tau, u0, w0, params, rig):
        model, _ = self._curve(rig)
        return model(np.asarray(tau, dtype=float), u0, w0, params["Fc"], params["b"])

    def load_cell_design(self, speed):
        return np.column_stack([np.ones(len(speed)), np.abs(speed)])
