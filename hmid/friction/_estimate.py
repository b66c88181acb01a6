"""Results of friction identification: per-log fits, the pooled estimate, JSON and a table."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hmid.errors import ConfigError
from hmid.friction._law import LawCheck
from hmid.friction._models import FRICTION_CALIBRATED_TAU, FallRig, FrictionModel
from hmid.intervals import IntervalNote

Interval = tuple[float, float]


@dataclass(frozen=True)
class LoadCellCheck:
    """Friction from the load cell on the sliding segment: F_l = (M + m1) a + m1 g (eq. 4.2).

    With the muscle disconnected, F_l = -friction, so ``-s F_l`` (``s``: direction of travel) is
    the friction magnitude; it is regressed (statsmodels OLS) on the model's load-cell design
    (a constant for Coulomb, plus the estimated |v| for Coulomb + viscous, then with Newey-West
    intervals). The signed reading is used rather than ``|F_l|`` so that noise on small readings
    does not fold into a bias. Independent of the x fit, except through |v| for b.
    """

    params: Mapping[str, float]
    ci: Mapping[str, Interval]
    n_samples: int


@dataclass(frozen=True)
class LogFriction:
    """The friction fit to one free-fall log (intervals: Student t, on the covariance's dof)."""

    source: str
    params: Mapping[str, float]
    se: Mapping[str, float]
    ci: Mapping[str, Interval]
    r2: float  # of the x(t) fit on the sliding segment
    rmse_m: float  # residual RMS of x, m
    durbin_watson: float  # of the x residuals: ~2 when they are white (honest intervals)
    tau_int: float  # the x residuals' correlation time, samples (see correlated_covariance)
    n_samples: int  # samples in the fitted sliding segment
    fraction_used: float  # n_samples / samples in the log
    t_start: float  # s, first sample of the segment
    t_end: float  # s, last sample of the segment
    direction: int  # -1: sliding toward -x (the rig's free fall), +1: toward +x
    t_ref: float  # s, centre of the segment
    x_ref: float  # m, fitted x at t_ref
    v_ref: float  # m/s, fitted v at t_ref
    load_cell: LoadCellCheck | None  # None when the log has no load-cell channel F


def _clean(value):
    """JSON-ready: floats finite or None, tuples as lists, mappings as dicts."""
    if isinstance(value, Mapping):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, tuple | list):
        return [_clean(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


@dataclass(frozen=True)
class FrictionEstimate:
    """Friction identified from free-fall logs: pooled parameters, per-log fits, heterogeneity.

    The pooled parameters are the inverse-covariance weighted mean of the per-log estimates
    (fixed effect; for one parameter, the inverse-variance weighted mean), with Student-t
    intervals on the Welch-Satterthwaite dof of the per-log variances.
    ``q`` is Cochran's Q, ``sum_i (theta_i - theta)' W_i (theta_i - theta)``, chi-square with
    ``q_dof = p (k - 1)`` degrees of freedom if the logs share one friction; a small ``q_p`` says
    they do not. The pooled covariance is widened by the Birge ratio ``max(1, q / q_dof)``, so
    logs that scatter beyond their own intervals widen it. ``i2`` is Higgins' I^2.
    """

    model: FrictionModel
    params: Mapping[str, float]
    se: Mapping[str, float]
    ci: Mapping[str, Interval]
    units: Mapping[str, str]
    per_log: tuple[LogFriction, ...]
    q: float
    q_dof: int
    q_p: float  # NaN for a single log
    i2: float  # NaN for a single log
    confidence: float
    rig: FallRig
    law: LawCheck | None = None  # whether the free falls' residuals accept the law

    @classmethod
    def known(
        cls, model: FrictionModel, params: Mapping[str, float], rig: FallRig
    ) -> FrictionEstimate:
        """An estimate with exactly known parameters (zero-width intervals, no logs)."""
        values = {p: float(params[p]) for p in model.param_names}
        return cls(
            model, values, dict.fromkeys(values, 0.0), {p: (v, v) for p, v in values.items()},
            dict(model.units), (), 0.0, 0, float("nan"), float("nan"), 1.0, rig,
        )  # fmt: skip

    @property
    def model_name(self) -> str:
        return self.model.name

    def friction(self, v: np.ndarray | float) -> np.ndarray:
        """Pooled friction force (N, signed along +x, opposing motion) at velocity ``v``."""
        return self.model.friction(np.asarray(v, dtype=float), self.params)

    def impossible(self) -> tuple[str, ...]:
        """A finding, not a number, for each parameter whose whole interval says friction
        pushes the motion (Fc = -40.6 N from a free-fall mass of 7.5 kg instead of 0.75):
        every friction coefficient opposes the motion."""
        out = []
        for name, value in self.params.items():
            low, high = self.ci[name]
            if high < 0:
                out.append(
                    f"free-fall friction {name} = {value:.4g} {self.units[name]} [{low:.4g}, "
                    f"{high:.4g}] is negative: friction cannot drive the motion; the declared "
                    f"free-fall mass ({self.rig.mass:g} kg) or drive ({self.rig.drive:g} N) is "
                    "wrong, or the position's sign"
                )
        return tuple(out)

    def to_dict(self) -> dict:
        """Plain, JSON-serialisable record (non-finite numbers as None)."""
        return _clean(
            {
                "model": self.model.name,
                "confidence": self.confidence,
                "params": dict(self.params),
                "se": dict(self.se),
                "ci": dict(self.ci),
                "units": dict(self.units),
                "heterogeneity": {"Q": self.q, "dof": self.q_dof, "p": self.q_p, "I2": self.i2},
                "free_fall": {"mass": self.rig.mass, "drive": self.rig.drive},
                "law_check": None if self.law is None else self.law.to_dict(),
                "intervals": self._note_record(),
                "logs": [
                    {
                        "source": r.source,
                        "params": dict(r.params),
                        "se": dict(r.se),
                        "ci": dict(r.ci),
                        "r2": r.r2,
                        "rmse_m": r.rmse_m,
                        "durbin_watson": r.durbin_watson,
                        "tau_int": r.tau_int,
                        "n_samples": r.n_samples,
                        "fraction_used": r.fraction_used,
                        "segment_s": (r.t_start, r.t_end),
                        "direction": r.direction,
                        "load_cell": None
                        if r.load_cell is None
                        else {
                            "params": dict(r.load_cell.params),
                            "ci": dict(r.load_cell.ci),
                            "n_samples": r.load_cell.n_samples,
                        },
                    }
                    for r in self.per_log
                ],
            }
        )

    def table(self) -> pd.DataFrame:
        """One row per log plus a ``pooled`` row; parameter columns carry their unit."""
        rows = []
        for r in self.per_log:
            row = {
                "log": r.source,
                "n": r.n_samples,
                "fraction used": r.fraction_used,
                "R2": r.r2,
                "RMSE [m]": r.rmse_m,
                "DW": r.durbin_watson,
                "τ_int [samples]": r.tau_int,
            }
            row |= self._param_columns(r.params, r.ci)
            if r.load_cell is not None:
                row |= self._param_columns(r.load_cell.params, r.load_cell.ci, " (load cell)")
            rows.append(row | self.interval_note(r.tau_int).columns())
        pooled = {"log": "pooled", "n": sum(r.n_samples for r in self.per_log)}
        pooled |= self._param_columns(self.params, self.ci)
        pooled |= {"Q": self.q, "Q dof": self.q_dof, "Q p": self.q_p, "I2": self.i2}
        longest = max((r.tau_int for r in self.per_log), default=float("nan"))
        rows.append(pooled | self.interval_note(longest, pooled=True).columns())
        return pd.DataFrame(rows)

    def _note_record(self) -> dict:
        """The pooled intervals' level, method and calibration status (as the models')."""
        longest = max((r.tau_int for r in self.per_log), default=float("nan"))
        note = self.interval_note(longest, pooled=True)
        fields = ("level", "method", "status", "tau_int", "calibrated_to")
        return {name: getattr(note, name) for name in fields}

    def interval_note(self, tau_int: float, pooled: bool = False) -> IntervalNote:
        """What a row's intervals are; the pooled row is as calibrated as its most correlated
        log."""
        method = (
            "Student t, inverse-variance pooled (Welch-Satterthwaite dof)" if pooled else
            "Student t, widest of i.i.d., lag-window and AR(1) + white sandwiches"
        )  # fmt: skip
        return IntervalNote(
            self.confidence, method, tau_int if math.isfinite(tau_int) else None,
            FRICTION_CALIBRATED_TAU, "benchmarks/bench_calibration_friction.py",
        )  # fmt: skip

    def _param_columns(self, params, ci, suffix: str = "") -> dict[str, float]:
        out = {}
        for name in self.model.param_names:
            unit = self.units[name]
            out[f"{name}{suffix} [{unit}]"] = params[name]
            out[f"{name}{suffix} lo [{unit}]"] = ci[name][0]
            out[f"{name}{suffix} hi [{unit}]"] = ci[name][1]
        return out


def affine_friction(friction) -> tuple[float, float]:
    """(Fc, b) of a friction estimate whose magnitude is Fc + b |v| (Coulomb, or Coulomb +
    viscous): the law as a model file states it, read off the estimate at three speeds."""
    if friction is None:
        raise ConfigError("no identified friction (free falls) to state as Fc + b |v|")
    speeds = np.array([1e-9, 0.1, 1.0])
    magnitude = np.asarray(friction.friction(speeds), dtype=float)
    Fc = float(magnitude[0])
    b = float((magnitude[2] - magnitude[0]) / (speeds[2] - speeds[0]))
    if not np.isfinite([Fc, b]).all() or abs(Fc + b * 0.1 - magnitude[1]) > 1e-9 * (1 + abs(Fc)):
        raise ConfigError("the friction law is not Coulomb + viscous (Fc + b |v|)")
    return Fc, b
