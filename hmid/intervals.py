"""What a printed interval is: its level, its method, and whether a calibration benchmark covers
the fit it came from.

Every family's intervals are calibrated by a benchmark (``benchmarks/bench_calibration_*.py``)
for residuals correlated up to some integrated autocorrelation time; a fit whose own residual is
correlated for longer lies beyond that evidence, and a method that assumes independent errors is
not calibrated for correlated ones at all. :class:`IntervalNote` says which, as two table columns
(``interval``, ``calibration``) that the report adds to every coefficient table.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class IntervalNote:
    """``level`` (e.g. 0.95) intervals by ``method``; ``tau_int``: the fit's residual correlation
    time in rows (None: not measured); ``calibrated_to``: the largest correlation time at which
    ``benchmark`` measured nominal coverage (None: the method is not calibrated for correlated
    residuals); ``window_closed``: whether the residual's autocorrelation window closed (if not,
    ``tau_int`` is only a lower bound)."""

    level: float
    method: str
    tau_int: float | None = None
    calibrated_to: float | None = None
    benchmark: str = ""
    window_closed: bool = True
    claim: str = ""  # the status in words, where it is not a correlation time (an AR(1) model)

    def __post_init__(self) -> None:
        if not 0 < self.level < 1:
            raise ValueError(f"IntervalNote: level {self.level!r} must lie in (0, 1)")

    @property
    def within(self) -> bool | None:
        """Whether the fit lies in the calibrated range (None: no range to lie in)."""
        if self.calibrated_to is None:
            return None
        if self.tau_int is None:
            return True
        return self.window_closed and self.tau_int <= self.calibrated_to

    @property
    def status(self) -> str:
        """``"calibrated (τ_int 8.1 ≤ 66 rows)"``, ``"BEYOND calibration (...)"`` or ``"not
        calibrated for correlated residuals"``."""
        if self.claim:
            return self.claim
        if self.calibrated_to is None:
            return "not calibrated for correlated residuals"
        if self.tau_int is None:
            return f"calibrated for τ_int ≤ {self.calibrated_to:g} rows"
        bound = "≥ " if not self.window_closed else ""
        if self.within:
            return f"calibrated (τ_int {self.tau_int:.3g} ≤ {self.calibrated_to:g} rows)"
        return f"BEYOND calibration (τ_int {bound}{self.tau_int:.3g} > {self.calibrated_to:g} rows)"

    def columns(self) -> dict[str, str]:
        """The two columns a coefficient table gets."""
        return {"interval": f"{100 * self.level:g} % {self.method}", "calibration": self.status}
