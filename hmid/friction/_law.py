"""Does the free-fall residual accept the fitted friction law?

A free fall under Coulomb friction travels a parabola; viscous friction bends it towards a
terminal speed, so a Coulomb fit of such a fall leaves a smooth, one-signed-by-stretches residual
and a level that absorbs the viscous force (the loop then sees every other friction law through
a biased level). Two checks on the position residuals:

* a runs test (Wald-Wolfowitz, statsmodels) of the residual's signs, per log, Fisher-combined:
  few runs is structure of any kind;
* for a Coulomb fit, the extra-sum-of-squares F-test of Coulomb + viscous (one more parameter per
  log), pooled over the logs, and the pooled viscous coefficient.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

#: Level of both checks: a rejected law is said on every run, so false alarms must be rare.
ALPHA = 0.01


@dataclass(frozen=True)
class LawCheck:
    model: str  # the law that was fitted
    runs_p: float  # Fisher-combined runs test of the residual signs (small: structure)
    f: float  # F of Coulomb + viscous against the fitted Coulomb law (NaN: not tested)
    f_p: float
    b: float  # pooled viscous coefficient of that alternative, N s/m (NaN: not tested)
    b_ci: tuple[float, float]

    @property
    def viscous(self) -> bool:
        """The falls show viscous friction: the F-test rejects Coulomb and b > 0 surely."""
        return bool(self.f_p < ALPHA and self.b_ci[0] > 0)

    @property
    def rejected(self) -> bool:
        return bool(self.viscous or self.runs_p < ALPHA)

    def message(self) -> str:
        if not self.rejected:
            return ""
        text = f"friction: the free falls reject the {self.model} law"
        if self.viscous:
            return (
                f"{text}: Coulomb + viscous fits them better (F = {self.f:.1f}, p = "
                f"{self.f_p:.2g}; b = {self.b:.3g} N·s/m [{self.b_ci[0]:.3g}, "
                f"{self.b_ci[1]:.3g}]), so the Coulomb level absorbs viscous friction; set "
                "friction.model: coulomb_viscous, or let the loop revise the law (its friction "
                "candidates refit the level)"
            )
        return (
            f"{text}: their residuals run in long stretches of one sign (runs test p = "
            f"{self.runs_p:.2g}): either structure no fitted law explains, which biases the "
            "friction level, or position noise correlated in time, which leaves the level "
            "unbiased but its pooled interval too narrow; check the free-fall logs and "
            "friction.v_min"
        )

    def to_dict(self) -> dict:
        return {"model": self.model, "runs_p": self.runs_p, "f": self.f, "f_p": self.f_p,
                "b": self.b, "b_ci": list(self.b_ci), "rejected": self.rejected,
                "message": self.message()}  # fmt: skip


def _runs_p(residual: np.ndarray) -> float:
    from statsmodels.sandbox.stats.runs import runstest_1samp

    signs = np.sign(residual)
    signs = signs[signs != 0]
    if len(signs) < 10 or len(np.unique(signs)) < 2:
        return float("nan")
    _, p = runstest_1samp(signs, cutoff=0.0, correction=False)
    return float(p)


def check_law(model, falls, rig, confidence: float) -> LawCheck:
    """The checks on ``falls``: per log (tau, u, fitted travel) of ``model``'s fit."""
    from hmid.friction._models import Coulomb, CoulombViscous

    runs = [p for p in (_runs_p(u - fitted) for _, u, fitted in falls) if np.isfinite(p)]
    runs_p = float(stats.combine_pvalues(runs)[1]) if runs else float("nan")
    nan = float("nan")
    if not isinstance(model, Coulomb):
        return LawCheck(model.name, runs_p, nan, nan, nan, (nan, nan))
    sse0 = sse1 = 0.0
    n = 0
    bs, ws = [], []
    for tau, u, fitted in falls:
        try:
            alt = CoulombViscous().fit_fall(tau, u, rig)
        except (RuntimeError, ValueError):
            return LawCheck(model.name, runs_p, nan, nan, nan, (nan, nan))
        sse0 += float(np.sum((u - fitted) ** 2))
        sse1 += float(np.sum((u - alt.fitted) ** 2))
        n += len(u)
        var = float(alt.cov[1, 1])
        if var > 0 and np.isfinite(var):
            bs.append(alt.params["b"])
            ws.append(1.0 / var)
    k = len(falls)
    dof = n - 4 * k
    if dof <= 0 or sse1 <= 0 or not bs:
        return LawCheck(model.name, runs_p, nan, nan, nan, (nan, nan))
    f = max(sse0 - sse1, 0.0) / k / (sse1 / dof)
    b = float(np.average(bs, weights=ws))
    half = stats.norm.ppf(0.5 + confidence / 2) / np.sqrt(np.sum(ws))
    return LawCheck(model.name, runs_p, float(f), float(stats.f.sf(f, k, dof)), b,
                    (b - half, b + half))  # fmt: skip
