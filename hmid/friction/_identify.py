"""Friction from free-fall logs (thesis Ch. 4): sliding segment, fit of x(t), pooling over logs."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import statsmodels.api as sm
from scipy import stats
from statsmodels.stats.stattools import durbin_watson

from hmid.errors import ConfigError, LogError, SignalError
from hmid.friction._estimate import FrictionEstimate, LoadCellCheck, LogFriction
from hmid.friction._law import check_law
from hmid.friction._models import FallRig, FrictionModel, correlated_covariance
from hmid.io.log import Log
from hmid.signal import Differentiator
from hmid.stats import fit_ar_white

#: Fewest samples a sliding segment must keep after trimming.
MIN_SLIDING_SAMPLES = 30


def derivative_reach(t: np.ndarray, differentiator: Differentiator) -> int:
    """Samples either side of i that the velocity estimate at i depends on (impulse response)."""
    from hmid.signal.reach import impulse_reach

    return impulse_reach(t, lambda t, y: differentiator.derivative(t, y, 1))


def sliding_segment(v: np.ndarray, v_min: float, reach: int) -> tuple[int, int]:
    """``(i0, i1)``: the longest run with ``|v| > v_min``, as a slice, trimmed at its transitions.

    An end of the run inside the log is a stick/slide transition, where the velocity estimate
    mixes samples from both sides: it is moved ``reach`` samples inwards, so that every kept
    sample truly slides. An end at the log's first or last sample is kept: the fit uses positions
    only, which are as accurate there as anywhere, and at the end of a free fall the speed is far
    above ``v_min``, so the less accurate edge velocity cannot change the selection.
    """
    fast = np.abs(v) > v_min
    if not fast.any():
        return 0, 0
    steps = np.diff(np.concatenate([[0], fast.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(steps == 1), np.flatnonzero(steps == -1)
    k = int(np.argmax(ends - starts))
    i0, i1 = int(starts[k]), int(ends[k])
    if i0 > 0:
        i0 += reach
    if i1 < len(v):
        i1 -= reach
    return i0, max(i0, i1)


def _interval(value: float, se: float, quantile: float) -> tuple[float, float]:
    return (float(value - quantile * se), float(value + quantile * se))


def _load_cell_check(F, v, direction, model, confidence, sign) -> LoadCellCheck:
    """OLS of the friction magnitude ``sign s F`` on the model's load-cell design (``sign``: how
    friction enters the force reading, -1 for a load cell behind it: F_l = -friction).

    The covariance is the sandwich with the residual's autocovariance, never narrower than the
    i.i.d. one (:func:`~hmid.friction._models.correlated_covariance`), as for the position fit.
    Measured in ``benchmarks/bench_calibration_friction.py`` (95 % nominal): 0.95-0.96 for
    Coulomb falls and for b = 0; 0.996-0.999 for b = 5 N s/m, wider than needed (the velocity's
    errors make the estimates heavy-tailed). Newey-West with 2 reach + 1 lags, used before,
    covered 0.96 at b = 5 but 0.83 at b = 0.
    """
    design = model.load_cell_design(np.abs(v))
    fitted = sm.OLS(sign * direction * F, design).fit()
    keep = list(range(design.shape[1]))
    cov, dof, _ = correlated_covariance(design, np.asarray(fitted.resid), keep)
    half = stats.t.ppf(0.5 + confidence / 2, dof) * np.sqrt(np.diag(cov))
    params = np.asarray(fitted.params)
    return LoadCellCheck(
        {p: float(params[j]) for j, p in enumerate(model.param_names)},
        {p: (float(params[j] - half[j]), float(params[j] + half[j]))
         for j, p in enumerate(model.param_names)},
        len(F),
    )  # fmt: skip


def _position_and_velocity(log, position: str, differentiator: Differentiator):
    """``(t, x, v, reach)``: the log's position channel, its velocity estimate and that
    estimate's reach in samples (:func:`derivative_reach`)."""
    if position not in log:
        raise LogError(f"{log.source}: a free-fall log needs the position channel {position!r}")
    t, x = log.t, log[position]
    bad = ~np.isfinite(x)
    if bad.any():
        raise LogError(
            f"{log.source}: friction: column {position!r} row {int(np.argmax(bad))} is not "
            "finite; drop or interpolate bad samples when loading"
        )
    try:
        v = differentiator.derivative(t, x, 1)
        reach = derivative_reach(t, differentiator)
    except SignalError as err:
        raise LogError(
            f"{log.source}: friction: differentiating {position} failed: {err}"
        ) from None
    return t, x, v, reach


def _sliding_rows(log, t: np.ndarray, v: np.ndarray, v_min: float, reach: int) -> slice:
    """The fall's sliding segment (:func:`sliding_segment`), or an error that says why the log
    has none long enough."""
    i0, i1 = sliding_segment(v, v_min, reach)
    n = i1 - i0
    not_a_fall = _not_a_fall(t, v, v_min) if n < MIN_SLIDING_SAMPLES else ""
    if not_a_fall:
        raise LogError(
            f"{log.source}: given role free_fall, but it is no free fall: {not_a_fall}; check "
            "the log's role in the experiment's logs (a free fall slides one way, once, in a "
            "fraction of a second)"
        )
    if n < MIN_SLIDING_SAMPLES:
        raise LogError(
            f"{log.source}: the free-fall sliding segment has {n} samples with |v| > {v_min} m/s "
            f"after trimming {reach} at each transition (need {MIN_SLIDING_SAMPLES}); record a "
            "longer fall (start higher on the rail), lower friction.v_min or shorten the "
            "derivative window"
        )
    return slice(i0, i1)


def _fit_fall(log, model, tau, u, rig, noise):
    """``model``'s fit of the fall ``u(tau)`` and its parameters' standard errors (finite)."""
    try:
        fit = model.fit_fall(tau, u, rig, noise)
    except (RuntimeError, ValueError) as err:
        raise LogError(f"{log.source}: the {model.name} fit of x(t) failed: {err}") from None
    se = np.sqrt(np.diag(fit.cov))
    if not np.all(np.isfinite(se)):
        raise LogError(
            f"{log.source}: the {model.name} parameters are not identifiable from this fall "
            "(infinite variance); record a longer fall or use a simpler friction model"
        )
    return fit, se


def _fit_log(log, rig, model, differentiator, v_min, confidence, position, sign, force,
             noise=None):  # fmt: skip
    """One fall: ``(its LogFriction, the parameters' covariance, (tau, u, fitted), dof,
    the noise model's design)``."""
    # position: the position channel; sign: how friction enters the force channel ``force``
    t, x, v, reach = _position_and_velocity(log, position, differentiator)
    seg = _sliding_rows(log, t, v, v_min, reach)
    n = seg.stop - seg.start
    direction = 1 if np.mean(v[seg]) > 0 else -1
    t_ref = float(np.mean(t[seg]))
    tau, u = t[seg] - t_ref, direction * x[seg]
    fit, se = _fit_fall(log, model, tau, u, rig, noise)
    names = model.param_names
    quantile = stats.t.ppf(0.5 + confidence / 2, fit.dof)
    resid = u - fit.fitted
    sst = np.sum((u - u.mean()) ** 2)
    load_cell = None
    if force is not None and force in log:
        load_cell = _load_cell_check(log[force][seg], v[seg], direction, model, confidence, sign)
    result = LogFriction(
        source=log.source,
        params=dict(fit.params),
        se={p: float(se[j]) for j, p in enumerate(names)},
        ci={p: _interval(fit.params[p], se[j], quantile) for j, p in enumerate(names)},
        r2=float(1.0 - np.sum(resid**2) / sst),
        rmse_m=float(np.sqrt(np.mean(resid**2))),
        durbin_watson=float(durbin_watson(resid)),
        tau_int=float(fit.tau_int),
        n_samples=n,
        fraction_used=n / len(log),
        t_start=float(t[seg.start]),
        t_end=float(t[seg.stop - 1]),
        direction=direction,
        t_ref=t_ref,
        x_ref=direction * fit.u0,
        v_ref=direction * fit.w0,
        load_cell=load_cell,
    )
    return result, np.asarray(fit.cov), (tau, u, fit.fitted), fit.dof, fit.design


def _pooled_dof(covs: list[np.ndarray], dofs: list[float]) -> np.ndarray:
    """Welch-Satterthwaite degrees of freedom of each pooled parameter's variance
    1 / sum(1 / v_i), each log's v_i estimated on its own dof: a few short falls whose
    noise is correlated give far fewer than their samples."""
    weights = np.array([1.0 / np.diag(c) for c in covs])  # (logs, parameters)
    return weights.sum(axis=0) ** 2 / np.sum(weights**2 / np.asarray(dofs)[:, None], axis=0)


def _pool(thetas: list[np.ndarray], covs: list[np.ndarray]):
    """Fixed-effect (inverse-covariance weighted) mean, its covariance, Cochran's Q and dof.

    Logs that scatter more than their covariances say (Q > dof: noise correlated beyond what
    the per-log covariance captures, or friction that differs between falls) widen the pooled
    covariance by the Birge ratio Q / dof (the Particle Data Group's scale factor, squared); it
    never narrows it."""
    weights = [np.linalg.inv(c) for c in covs]
    cov = np.linalg.inv(sum(weights))
    mean = cov @ sum(w @ th for w, th in zip(weights, thetas, strict=True))
    q = float(sum((th - mean) @ w @ (th - mean) for w, th in zip(weights, thetas, strict=True)))
    dof = len(mean) * (len(thetas) - 1)
    return mean, cov * (max(1.0, q / dof) if dof > 0 else 1.0), q, dof


def _not_a_fall(t: np.ndarray, v: np.ndarray, v_min: float) -> str:
    """What shows that a log is not a free fall (empty if nothing does): its position moves
    both ways, or barely at all over a long time."""
    up, down = float(np.max(v)), float(np.min(v))
    if up > v_min / 2 and down < -v_min / 2:
        return (
            f"its position moves both ways ({down:.3g} to {up:.3g} m/s) over {t[-1] - t[0]:.3g} s"
        )
    peak = max(up, -down)
    if t[-1] - t[0] > 2.0 and peak < v_min:
        return (
            f"its position never moves faster than {peak:.3g} m/s over {t[-1] - t[0]:.3g} s "
            f"(a fall slides at more than friction.v_min {v_min:g} m/s)"
        )
    return ""


def _check_arguments(logs, rig, model, differentiator, v_min, confidence) -> None:
    """An error naming the first argument :func:`identify_friction` cannot use."""
    if not isinstance(model, FrictionModel):
        raise ConfigError(f"friction model must be a FrictionModel, got {model!r}")
    if not isinstance(differentiator, Differentiator):
        raise ConfigError(f"differentiator must be a Differentiator, got {differentiator!r}")
    if not isinstance(rig, FallRig):
        raise ConfigError(f"friction needs the free fall's mass and drive (a FallRig), got {rig!r}")
    if not (np.isfinite(v_min) and v_min > 0):
        raise ConfigError(f"friction.v_min={v_min!r} must be a positive speed in m/s")
    if not 0 < confidence < 1:
        raise ConfigError(f"friction.confidence={confidence!r} must lie in (0, 1)")
    if len(logs) == 0:
        raise LogError("friction: no free-fall logs given; add logs with role 'free_fall'")


def _fit_logs(logs, rig, model, differentiator, settings):
    """Every fall's :func:`_fit_log` and the position noise's model (None: none fitted)."""
    fits = [_fit_log(log, rig, model, differentiator, *settings) for log in logs]
    # one sensor, one noise process: its AR(1) + white model is fitted on every fall at once
    # (a 0.3 s fall holds too few correlation times to tell phi 0.97 from 0.9 alone)
    noise = fit_ar_white([(design, u - fitted) for _, _, (_, u, fitted), _, design in fits])
    if noise is not None and len(fits) > 1:
        fits = [_fit_log(log, rig, model, differentiator, *settings, noise) for log in logs]
    return fits, noise


def _heterogeneity(q: float, dof: int) -> tuple[float, float]:
    """Cochran's Q's p-value and I² (the share of the logs' scatter beyond their noise)."""
    q_p = float(stats.chi2.sf(q, dof)) if dof > 0 else float("nan")
    i2 = max(0.0, (q - dof) / q) if dof > 0 and q > 0 else (0.0 if dof > 0 else float("nan"))
    return q_p, i2


def identify_friction(
    logs: Sequence[Log],
    rig: FallRig,
    model: FrictionModel,
    *,
    differentiator: Differentiator,
    v_min: float = 0.02,
    confidence: float = 0.95,
    position: str = "x",
    friction_sign: int = -1,
    explained: str | None = "F",
) -> FrictionEstimate:
    """Friction of the rig from free-fall logs (actuator disconnected; the ``position`` channel,
    optionally the force channel ``explained``).

    Per log: velocity from ``differentiator`` on the raw position; the sliding segment is the
    longest run with ``|v| > v_min``, trimmed at stick/slide transitions by the derivative's
    reach; ``model`` is fitted to the position there (see :mod:`hmid.friction._models`), giving
    the parameters with Student-t intervals, their position noise's AR(1) + white model fitted
    on all the logs at once (one sensor; :func:`~hmid.friction._models.correlated_covariance`).
    The logs are pooled by inverse-covariance weighting (Student-t intervals on the
    Welch-Satterthwaite dof of the per-log variances, at most the shared noise model's), with
    Cochran's Q for their agreement. The fall's mass and drive are taken as exact. A force
    channel, where the log has it, gives an independent cross-check: in a free fall it reads the
    friction alone, entering with ``friction_sign``.
    """
    _check_arguments(logs, rig, model, differentiator, v_min, confidence)
    settings = (v_min, confidence, position, friction_sign, explained)
    fits, noise = _fit_logs(logs, rig, model, differentiator, settings)
    names = model.param_names
    thetas = [np.array([r.params[p] for p in names]) for r, *_ in fits]
    mean, cov, q, dof = _pool(thetas, [c for _, c, *_ in fits])
    se = np.sqrt(np.diag(cov))
    pooled_dof = _pooled_dof([c for _, c, *_ in fits], [f[3] for f in fits])
    if noise is not None and len(fits) > 1:  # the falls share their noise model's one scale
        pooled_dof = np.minimum(pooled_dof, noise.dof)
    z = stats.t.ppf(0.5 + confidence / 2, pooled_dof)
    q_p, i2 = _heterogeneity(q, dof)
    return FrictionEstimate(
        model=model,
        params={p: float(mean[j]) for j, p in enumerate(names)},
        se={p: float(se[j]) for j, p in enumerate(names)},
        ci={p: _interval(mean[j], se[j], z[j]) for j, p in enumerate(names)},
        units=dict(model.units),
        per_log=tuple(r for r, *_ in fits),
        q=q,
        q_dof=dof,
        q_p=q_p,
        i2=float(i2),
        confidence=confidence,
        rig=rig,
        law=check_law(model, [f[2] for f in fits], rig, confidence),
    )
