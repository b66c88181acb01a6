"""Multivariate polynomial force models F_m = sum_k C_k x^i v^j P^l, fitted by OLS (thesis Ch. 4).

The regression is least squares (a QR by blocks of rows, :mod:`hmid.models._lstsq`: a long log's
design is held once) on *scaled* features: every variable is divided by its
largest absolute value on the training rows, so each regressor lies in [-1, 1]. In physical units
the cubic-with-pressure design mixes columns from x³ ~ 1e-6 m³ to P ~ 1e5 Pa and its condition
number is ~1e12; scaled it is ~1e2. Scaling is a diagonal change of basis, so coefficients, standard
errors and confidence bounds map back to physical units exactly: the coefficient of x^i v^j P^l is
the scaled one divided by ``sx^i sv^j sP^l`` (t statistics and p-values are unchanged).

Standard errors and intervals (``errors=``) are for errors correlated in row order, as the
residuals of a smoothed 1 kHz log are:

- ``"autocov"`` (default): the OLS estimates with the covariance ``(X'X)^-1 X' S X (X'X)^-1``,
  ``S`` the Toeplitz matrix of the residual's autocovariance up to Sokal's window (the first lag
  ``M >= 5 tau(M)``, as for MCMC chains), each lag given back what the fit's projection took
  (:func:`hmid.stats.fitted_correlation`: on 3,000 rows 16 terms take about a third of the
  errors' long-run variance within the window, and the raw residual read tau_int 10 for 19), and
  t intervals on ``n_eff - p`` degrees of freedom (n_eff = n / tau_int).
  It assumes stationary errors independent of the regressors (not heteroscedastic ones); it then
  needs one autocovariance, of the residual, instead of HAC's kernel over the products of
  regressors and residual, whose Bartlett weights bias it low unless the window is many
  correlation times long. Rows of several logs are joined as one series: a join adds a few wrong
  lag products, negligible on logs much longer than the window. Measured by
  ``benchmarks/bench_calibration_polynomial.py`` (16-term cubic, simulated 1 kHz trajectories of
  20 s and of 3 s, the rig's and slow sinusoids): 95 % intervals cover 0.93-0.97 under white,
  AR(1) phi 0.5-0.97 (correlation times up to 66 rows) and moving-average-smoothed noise (see
  docs/intervals.md). The label (:meth:`interval_note`) also counts the effectively independent
  rows per term, n / tau_int / p: below :data:`POLYNOMIAL_CALIBRATED_PER_TERM` it says BEYOND.
- ``"ols"``: independent errors; on correlated residuals far too narrow (coverage 0.32-0.74).
- ``"hac"``: Newey-West with the lag window of :func:`hac_lags` (coverage 0.90-0.94: its Bartlett
  kernel over a window of a few correlation times is biased low; a pass over the rows per lag).

Every fit reports diagnostics in ``summary_.warnings`` rather than staying silent:

- the (scaled) design's condition number above :data:`CONDITION_LIMIT` (1e3, the level at which
  statsmodels itself flags strong multicollinearity; about log10(cond) digits are lost);
- a rank-deficient design (some coefficients are not identifiable);
- residuals autocorrelated in the row order given (Durbin-Watson below :data:`DURBIN_WATSON_LIMIT`):
  with ``errors="ols"`` the intervals are too narrow; with the default they account for it, and
  the warning says how long the correlation lasts (much longer than the smoothing window hints at
  structure the terms miss);
- a residual correlation that does not die out within a tenth of the rows: no interval method
  can estimate it from this log.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

from hmid.balance.monomial import Monomial, variable_order
from hmid.errors import ConfigError, SignalError, where
from hmid.intervals import IntervalNote
from hmid.models._design import row_design
from hmid.models._lstsq import QR_BLOCK, RowBlocks, tall_lstsq
from hmid.models.base import (
    Coefficient,
    FitStatistics,
    ForceModel,
    check_target,
    fit_statistics,
    fit_table,
)
from hmid.models.terms import (
    VARIANTS,
    coefficient_unit,
    polynomial_terms,
    resolve_terms,
    variable_unit,
)
from hmid.stats import (
    FittedCorrelation,
    autocov_covariance,
    fitted_correlation,
    hac_covariance,
    hac_lags,
)

__all__ = [
    "CONDITION_LIMIT",
    "DURBIN_WATSON_LIMIT",
    "ERRORS",
    "VARIANTS",
    "PolynomialModel",
    "fit_table",
    "polynomial_terms",
]

#: Condition number of the fitted design above which a fit carries a warning.
CONDITION_LIMIT = 1e3
#: Durbin-Watson statistic of the residuals below which a fit carries a warning (2 = independent).
DURBIN_WATSON_LIMIT = 1.5
#: Interval methods (``errors=``), the default first; see the module docstring.
ERRORS = ("autocov", "ols", "hac")
#: The longest residual correlation time (samples) at which the default intervals were measured
#: calibrated (AR(1) phi = 0.97 in benchmarks/bench_calibration_polynomial.py).
POLYNOMIAL_CALIBRATED_TAU = 66.0
#: The fewest effectively independent rows per term, n / tau_int / p, at which they were measured
#: calibrated (AR(1) phi = 0.9 on 3 s, 3,000 rows, of the same benchmark).
POLYNOMIAL_CALIBRATED_PER_TERM = 8.0
#: Unit of the target, the muscle force.
FORCE_UNIT = "N"


class PolynomialModel(ForceModel):
    """F_m as a polynomial in x [m], v [m/s], P [Pa] (y in N), fitted by statsmodels OLS; other
    variables with their SI ``units`` (a mapping), a target in ``target_unit``.

    ``terms`` is a variant name (``'quadratic_xv'``, ``'cubic_xv'``, ``'quadratic_xvP'``,
    ``'cubic_xvP'``) or a tuple of :class:`~hmid.balance.monomial.Monomial` (or term names like
    ``'x^2*v'``), e.g. from :func:`polynomial_terms`. ``confidence`` is the level of the reported
    confidence intervals, ``errors`` their method (``'autocov'``, ``'ols'`` or ``'hac'``, see the
    module docstring).
    ``scale=False`` fits in physical units (for comparison only: it is badly conditioned).

    Fitted attributes, in physical units and term order: ``coef_``, ``bse_`` (standard errors),
    ``conf_int_`` (n_terms x 2), ``pvalues_``, ``term_names_``, ``coefficients_`` (tuple of
    :class:`Coefficient`), ``summary_`` (:class:`FitStatistics`); also ``params_`` (the coefficients
    of the *scaled* features), ``scales_`` (the divisor of each
    variable), ``condition_number_`` (scaled design), ``condition_number_unscaled_``,
    ``durbin_watson_``, ``tau_int_`` (the residual's integrated autocorrelation time in rows),
    ``acf_window_`` (Sokal's window in lags, ``None`` if the correlation outlasts the lags
    examined) and ``df_`` (degrees of freedom of the t intervals; ``None``: normal, for HAC).
    """

    family = "polynomial"

    def __init__(
        self,
        terms: tuple[Monomial | str, ...] | str,
        confidence: float = 0.95,
        scale: bool = True,
        errors: str = "autocov",
        units: Mapping[str, str] | None = None,
        target_unit: str = FORCE_UNIT,
    ) -> None:
        self._terms = resolve_terms(terms)
        for variable in {v for term in self._terms for v in term.variables}:
            variable_unit(variable, units)  # raises ConfigError for a variable without a unit
        if isinstance(confidence, bool) or not isinstance(confidence, int | float):
            raise ConfigError(f"confidence must be a number in (0, 1), got {confidence!r}")
        if not 0.0 < confidence < 1.0:
            raise ConfigError(f"confidence must lie strictly between 0 and 1, got {confidence!r}")
        if not isinstance(scale, bool):
            raise ConfigError(f"scale must be True or False, got {scale!r}")
        if errors not in ERRORS:
            raise ConfigError(f"errors must be one of {', '.join(ERRORS)}, got {errors!r}")
        self.terms = terms if isinstance(terms, str) else self._terms
        self.confidence = float(confidence)
        self.scale = scale
        self.errors = errors
        self.units = None if units is None else dict(units)
        self.target_unit = target_unit

    @classmethod
    def example(cls) -> PolynomialModel:
        return cls("cubic_xvP")

    @property
    def name(self) -> str:
        """The variant name, or ``'custom'`` for an explicit term tuple."""
        return self.terms if isinstance(self.terms, str) else "custom"

    @property
    def term_set(self) -> tuple[Monomial, ...]:
        return self._terms

    @property
    def required_columns(self) -> tuple[str, ...]:
        return tuple(
            sorted({v for term in self._terms for v in term.variables}, key=variable_order)
        )

    def fit(self, X: pd.DataFrame | None, y: np.ndarray, monomials=None) -> PolynomialModel:
        """As :meth:`ForceModel.fit`; ``monomials`` optionally gives a term's column by its name
        (e.g. ``"x^3"``: the smoothed cube of the unsmoothed x, where ``X`` and ``y`` are
        smoothed), used instead of the product of ``X``'s columns.

        ``X`` None: ``monomials`` gives every term with variables, and each variable, on any
        block of rows (``monomials.block(name)(rows)``, ``rows`` a slice of ``len(y)`` rows):
        a long log's variables are then read block by block, never copied whole."""
        self._monomials = monomials or {}  # a mapping; its columns may be computed on demand
        try:
            if X is None:
                source = f"{type(self).__name__}.fit"
                self._fit(self._given_columns(len(y), source), check_target(y, len(y), source))
                return self
            return super().fit(X, y)
        finally:
            del self._monomials  # an argument, not fitted state

    def predict(self, X: pd.DataFrame | None, monomials=None, n: int | None = None) -> np.ndarray:
        """As :meth:`ForceModel.predict`, with the ``monomials`` of :meth:`fit`; ``X`` None: on
        ``n`` rows, every term with variables from ``monomials`` (as in :meth:`fit`)."""
        self._monomials = monomials or {}  # a mapping; its columns may be computed on demand
        try:
            if X is None:
                self._check_fitted()
                if n is None:
                    raise SignalError(f"{type(self).__name__}.predict: without X, give n (rows)")
                source = f"{type(self).__name__}.predict"
                return self._predict(self._given_columns(n, source, scales=False))
            return super().predict(X)
        finally:
            del self._monomials

    def _given_columns(self, n: int, source: str, scales: bool = True) -> _GivenColumns:
        """The variables as :meth:`fit` reads them without ``X``: each checked finite (and its
        scale found, for a fit) block by block."""
        block = getattr(self._monomials, "block", None)
        missing = [t.name for t in self._terms if t.powers and t.name not in self._monomials]
        if block is None or missing:
            raise SignalError(
                f"{source}: without X, monomials must give every term with variables by blocks "
                f"of rows (a block(name) method); missing: {missing or 'block'}"
            )
        found = {}
        for variable in self.required_columns:
            column, top = block(variable), 0.0
            for lo in range(0, n, QR_BLOCK):
                values = column(slice(lo, min(lo + QR_BLOCK, n)))
                finite = np.isfinite(values)
                if not finite.all():
                    row = lo + int(np.argmin(finite))
                    raise SignalError(
                        f"{where(source, variable, row)}value {values[row - lo]} is not finite; "
                        "drop or interpolate non-finite samples first"
                    )
                if scales:  # as _scale_of on the whole column: a maximum is exact by blocks
                    top = max(top, float(np.max(np.abs(values))))
            found[variable] = top if top > 0 else 1.0
        return _GivenColumns(n, found)

    def _scales(self, X: Mapping[str, np.ndarray]) -> dict[str, float]:
        if isinstance(X, _GivenColumns):
            return {v: scale if self.scale else 1.0 for v, scale in X.scales.items()}
        return {v: _scale_of(X[v]) if self.scale else 1.0 for v in X}

    def _design(self, X: Mapping[str, np.ndarray], scales: Mapping[str, float]) -> RowBlocks:
        n = X.n if isinstance(X, _GivenColumns) else None
        return row_design(self._terms, X, scales, getattr(self, "_monomials", {}), n)

    def _fit(self, X: Mapping[str, np.ndarray], y: np.ndarray) -> None:
        from statsmodels.stats.stattools import durbin_watson

        n, p = y.size, len(self._terms)
        if n <= p:
            raise SignalError(
                f"PolynomialModel.fit: {n} rows cannot fit {p} terms; pass more rows than terms"
            )
        scales = self._scales(X)
        exog = self._design(X, scales)
        factor = np.array([term.scale_factor(scales) for term in self._terms])
        # least squares by blocks of rows: a long log's design is held once, not thrice
        solved = tall_lstsq(exog, y)
        params, resid, rank = solved.params, solved.resid, solved.rank
        cond = solved.condition_number()
        self.condition_number_unscaled_ = solved.condition_number(factor) if self.scale else cond
        # the residual's autocovariance with what the fit's projection took back (hmid.stats):
        # on a short log with many terms the raw one reads the correlation far too short
        bread = solved.bread()
        corr = fitted_correlation(resid, exog, bread)
        self.acf_window_, self.tau_int_, self.raw_tau_int_ = (
            corr.window,
            corr.tau_int,
            corr.raw_tau_int,
        )
        cov, df = self._covariance(exog, y, solved, corr, bread)
        del exog
        bse = np.sqrt(np.diag(cov))
        self.pvalues_, half = self._tests(params, bse, df)
        self.df_ = df
        self.params_ = params  # on the scaled design
        self.scales_ = dict(scales)  # a plain dict: fitted models are pickled by the stage cache
        self.term_names_ = tuple(term.name for term in self._terms)
        self.coef_ = params / factor
        self.cov_ = cov / np.outer(factor, factor)  # in physical units, as coef_
        self.bse_ = bse / factor
        self.conf_int_ = np.column_stack([params - half, params + half]) / factor[:, None]
        self.condition_number_ = cond
        self.durbin_watson_ = float(durbin_watson(resid))
        self.coefficients_ = self._coefficients()
        fit_stats = fit_statistics(y, y - resid, p)
        self.summary_ = FitStatistics(
            family=self.family,
            name=self.name,
            n_obs=n,
            n_params=p,
            condition_number=self.condition_number_,
            condition_number_unscaled=self.condition_number_unscaled_,
            warnings=self._diagnose(rank, p, n),
            **fit_stats,
        )

    def _covariance(self, exog, y: np.ndarray, solved, corr: FittedCorrelation, bread):
        """``(cov, df)`` of the parameters on the scaled design, as ``errors`` says: the
        residual's autocovariance corrected for the projection (df: n_eff - p), Newey-West (df
        None: normal intervals) or i.i.d. OLS."""
        n, p = y.size, len(self._terms)
        resid = solved.resid
        self.hac_lags_ = None
        if self.errors == "autocov":
            cov = autocov_covariance(exog, corr.gamma, bread, spectrum=corr.spectrum)
            df = float(min(n - p, corr.dof(p)))
        elif self.errors == "hac":
            self.hac_lags_ = hac_lags(resid)
            cov, df = (
                hac_covariance(np.asarray(exog), y, self.hac_lags_, Monomial() in self._terms),
                None,
            )
        else:
            df = float(n - solved.rank)
            cov = bread * float(resid @ resid) / df
        return cov, df

    def _tests(self, params: np.ndarray, bse: np.ndarray, df: float | None):
        """``(p-values, interval half-widths)`` of the parameters, Student-t on ``df``."""
        from scipy import stats

        with np.errstate(divide="ignore", invalid="ignore"):
            tvalues = params / bse
        if df is None:  # HAC: normal, as statsmodels reports it
            p_values = 2 * stats.norm.sf(np.abs(tvalues))
            half = stats.norm.ppf(0.5 + self.confidence / 2) * bse
        else:
            p_values = 2 * stats.t.sf(np.abs(tvalues), df)
            half = stats.t.ppf(0.5 + self.confidence / 2, df) * bse
        return p_values, half

    def _coefficients(self) -> tuple[Coefficient, ...]:
        """The fitted coefficients in physical units, one per term, with their intervals."""
        return tuple(
            Coefficient(
                name=f"C{k}",
                term=term.name,
                value=float(self.coef_[k]),
                std_err=float(self.bse_[k]),
                ci_low=float(self.conf_int_[k, 0]),
                ci_high=float(self.conf_int_[k, 1]),
                unit=coefficient_unit(term, self.target_unit, self.units),
                p_value=float(self.pvalues_[k]),
            )
            for k, term in enumerate(self._terms)
        )

    def _diagnose(self, rank: int, p: int, n_obs: int) -> tuple[str, ...]:
        found = []
        cond = self.condition_number_
        if not cond <= CONDITION_LIMIT:
            which = "scaled" if self.scale else "unscaled (physical-unit)"
            advice = "fit with scale=True" if not self.scale else "drop terms or widen the data"
            found.append(
                f"ill-conditioned design: condition number {cond:.3g} of the {which} design "
                f"exceeds {CONDITION_LIMIT:g}; about {math.log10(cond):.0f} digits of the "
                f"coefficients are lost to collinearity ({advice})"
            )
        if rank < p:
            found.append(
                f"rank-deficient design: rank {rank} < {p} terms; some coefficients are not "
                "identifiable from these rows (e.g. a variable that does not vary)"
            )
        if self.acf_window_ is None:
            found.append(
                f"the residual stays correlated beyond the lags examined (a tenth of the rows; "
                f"correlation time >= {self.tau_int_:.0f} rows): no interval method can estimate "
                "that from this log, and the intervals are likely too narrow; the terms probably "
                "miss slow structure, or the log is too short"
            )
        if self.durbin_watson_ < DURBIN_WATSON_LIMIT:
            where = (
                f"residuals autocorrelated in row order (Durbin-Watson {self.durbin_watson_:.2f}, "
                f"correlation time {self.tau_int_:.3g} rows)"
            )
            if self.errors == "autocov":
                found.append(
                    f"{where}: the intervals account for it through the residual's autocovariance "
                    f"(about {n_obs / self.tau_int_:.0f} effectively independent rows); a "
                    "correlation much longer than the smoothing window hints at missed structure"
                )
            elif self.errors == "hac":
                found.append(
                    f"{where}: standard errors and intervals are Newey-West (HAC, "
                    f"{self.hac_lags_} lags)"
                )
            else:
                found.append(
                    f"{where} < {DURBIN_WATSON_LIMIT}: OLS standard errors and confidence "
                    "intervals are too narrow; use errors: autocov (the default)"
                )
        return tuple(found)

    def _predict(self, X: Mapping[str, np.ndarray]) -> np.ndarray:
        return self._design(X, self.scales_) @ self.params_  # by blocks of rows

    # -- reporting ------------------------------------------------------------------------------
    def coefficient_table(self) -> pd.DataFrame:
        """One row per coefficient (C0, C1, ...): term, value, unit, std. error, CI, p-value."""
        self._check_fitted()
        frame = pd.DataFrame([c.to_dict() for c in self.coefficients_]).set_index("name")
        level = f"{100 * self.confidence:g}%"
        low, high = f"ci_low ({level})", f"ci_high ({level})"
        frame = frame.rename(columns={"ci_low": low, "ci_high": high})
        return frame[["term", "value", "unit", "std_err", low, high, "p_value"]]

    def equation(self, digits: int = 4) -> str:
        """``'F_m = -6.426 [N] + 41.74 [N/m]·x - 52.31 [N·s/m]·v + ...'`` on one line."""
        self._check_fitted()
        parts = []
        for k, (term, c) in enumerate(zip(self._terms, self.coefficients_, strict=True)):
            text = f"{abs(c.value):.{digits}g} [{c.unit}]"
            text += f"·{term.pretty}" if term.powers else ""
            sign = "-" if c.value < 0 else ("" if k == 0 else "+")
            parts.append(f"{sign}{text}" if k == 0 else f"{sign} {text}")
        return "F_m = " + " ".join(parts)

    def interval_note(self) -> IntervalNote:
        """What the intervals are, for the coefficient table's columns."""
        self._check_fitted()
        if self.errors == "ols":
            return IntervalNote(self.confidence, "OLS (independent errors)", self.tau_int_)
        if self.errors == "hac":
            method, claim = f"Newey-West HAC ({self.hac_lags_} lags)", "measured 0.90-0.94"
            return IntervalNote(self.confidence, method, self.tau_int_, claim=claim)
        return IntervalNote(
            self.confidence, "OLS + autocovariance sandwich", self.tau_int_,
            POLYNOMIAL_CALIBRATED_TAU, "benchmarks/bench_calibration_polynomial.py",
            self.acf_window_ is not None, n_rows=self.summary_.n_obs,
            n_terms=self.summary_.n_params, calibrated_per_term=POLYNOMIAL_CALIBRATED_PER_TERM,
        )  # fmt: skip

    def interval_method(self) -> str:
        """One line for reports: the intervals' level, method and calibration for this fit."""
        self._check_fitted()
        level = f"{100 * self.confidence:g} % intervals"
        tau = f"residual correlation time {self.tau_int_:.3g} rows"
        if self.errors == "ols":
            return (
                f"{level}: OLS, independent errors assumed ({tau}); not calibrated for correlated "
                "residuals (use errors: autocov, the default)"
            )
        if self.errors == "hac":
            return (
                f"{level}: Newey-West HAC, {self.hac_lags_} lags ({tau}); measured 0.90-0.94 "
                "coverage on correlated noise, a little short of nominal"
            )
        lags = "the lags examined" if self.acf_window_ is None else f"±{self.acf_window_} lags"
        note = self.interval_note()
        status = "within" if note.within else "BEYOND"
        per_term = note.per_term if note.per_term is not None else float("nan")
        return (
            f"{level}: OLS estimates, covariance from the residual's autocovariance over {lags} "
            f"(corrected for the fit's projection), t with {self.df_:.0f} df; calibrated for "
            f"residual correlation times up to {POLYNOMIAL_CALIBRATED_TAU:g} rows and at least "
            f"{POLYNOMIAL_CALIBRATED_PER_TERM:g} effective rows per term "
            "(benchmarks/bench_calibration_polynomial.py); this fit: "
            f"{self.tau_int_:.3g} rows (the residual's own reads {self.raw_tau_int_:.3g}), "
            f"{per_term:.3g} effective rows per term, {status} that range"
        )


class _GivenColumns(dict):
    """No variable's column (they come from the monomials by blocks, :meth:`PolynomialModel.fit`
    without ``X``): the row count ``n`` and each variable's scale (1 where it is all zero)."""

    def __init__(self, n: int, scales: Mapping[str, float]) -> None:
        super().__init__()
        self.n, self.scales = n, dict(scales)


def _scale_of(values: np.ndarray) -> float:
    """Divisor of a variable: its largest absolute value (1 for an all-zero column)."""
    scale = float(np.max(np.abs(values))) if values.size else 0.0
    return scale if scale > 0 else 1.0
