"""What a printed interval is: its level, its method, and whether a calibration benchmark covers
the fit it came from.

Every family's intervals are calibrated by a benchmark (``benchmarks/bench_calibration_*.py``)
for residuals correlated up to some integrated autocorrelation time; a fit whose own residual is
correlated for longer lies beyond that evidence, and a method that assumes independent errors is
not calibrated for correlated ones at all. A fit can also lie beyond its benchmark by having too
few rows for its terms: a cubic polynomial's 16 coefficients on 3,000 rows correlated for 66 leave
under 3 effectively independent rows per coefficient, where a lag window cannot be read. Where a
family gives its rows and terms, :class:`IntervalNote` checks that too (against the fewest
effective rows per term its benchmark covered at nominal), with the correlation time corrected for
the fit's projection (:func:`hmid.stats.fitted_correlation`; the residual's own reads it short).
It says which, as two table columns (``interval``, ``calibration``) that the report adds to every
coefficient table.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class IntervalNote:
    """``level`` (e.g. 0.95) intervals by ``method``; ``tau_int``: the fit's residual correlation
    time in rows (None: not measured); ``calibrated_to``: the largest correlation time at which
    ``benchmark`` measured nominal coverage (None: the method is not calibrated for correlated
    residuals); ``window_closed``: whether the residual's autocorrelation window closed (if not,
    ``tau_int`` is only a lower bound); ``n_rows`` and ``n_terms``: the fit's rows and
    coefficients, and ``calibrated_per_term`` the fewest effective rows per term,
    ``n_rows / tau_int / n_terms``, at which ``benchmark`` measured nominal coverage (None: not
    checked)."""

    level: float
    method: str
    tau_int: float | None = None
    calibrated_to: float | None = None
    benchmark: str = ""
    window_closed: bool = True
    claim: str = ""  # the status in words, where it is not a correlation time (an AR(1) model)
    n_rows: int | None = None
    n_terms: int | None = None
    calibrated_per_term: float | None = None

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
        enough = self.per_term is None or self.per_term >= (self.calibrated_per_term or 0.0)
        return self.window_closed and self.tau_int <= self.calibrated_to and enough

    @property
    def per_term(self) -> float | None:
        """Effectively independent rows per coefficient, ``n_rows / tau_int / n_terms`` (None
        where not checked)."""
        if None in (self.n_rows, self.n_terms, self.tau_int, self.calibrated_per_term):
            return None
        return self.n_rows / self.tau_int / self.n_terms  # type: ignore[operator]

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
        rows = self._rows_text()
        if self.within:
            return f"calibrated (τ_int {self.tau_int:.3g} ≤ {self.calibrated_to:g} rows{rows})"
        if self.window_closed and self.tau_int <= self.calibrated_to:
            return f"BEYOND calibration (τ_int {self.tau_int:.3g} rows{rows})"
        beyond = f"{bound}{self.tau_int:.3g} > {self.calibrated_to:g}"
        return f"BEYOND calibration (τ_int {beyond} rows{rows})"

    def _rows_text(self) -> str:
        """``"; 9.4 ≥ 3 effective rows per term"`` where rows and terms are checked."""
        per_term = self.per_term
        if per_term is None:
            return ""
        floor = self.calibrated_per_term or 0.0
        sign = "≥" if per_term >= floor else "<"
        return f"; {per_term:.3g} {sign} {floor:g} effective rows per term"

    def columns(self) -> dict[str, str]:
        """The two columns a coefficient table gets."""
        return {"interval": f"{100 * self.level:g} % {self.method}", "calibration": self.status}
