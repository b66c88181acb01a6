"""The SINDy force model: F_m = Theta(x, v, P) xi, sparse, with per-term inclusion and intervals.

Fitting, on the rows given (sliding rows of the training logs in the pipeline):

1. rows with ``|v| < stick_speed`` are left out: while the block sticks, static friction takes
   whatever value balances the other forces, so the reconstructed F_m there is not a function of
   (x, v, P), and the smooth friction column tanh(v/v0) is indeterminate at v = 0 -- such rows
   pull spurious terms into the fit. Just above the pipeline's dead band (2 mm/s), around every
   stick-slip transition, the smoothed velocity and the friction sign in the reconstruction are
   still unreliable: the default 0.01 m/s was needed to recover the true terms from thesis-level
   sensor noise in 8/8 simulated logs (7/8 at 5 mm/s, 6/8 at 2 mm/s; benchmarks/bench_sindy.py);
2. the library (:class:`~hmid.models.sindy._library.FeatureLibrary`) is evaluated and each column
   divided by its RMS over the rows, the target by its standard deviation, so a coefficient of
   the normalised problem is a term's RMS contribution as a fraction of the spread of F_m, and
   the threshold reads the same way ("drop terms worth less than 1 % of the force's spread");
3. the threshold is a number, or chosen by blocked cross-validation on these rows
   (:func:`~hmid.models.sindy._sparse.threshold_path`, one-standard-error rule);
4. a blocked bootstrap of pysindy's STLSQ at that threshold gives each term's inclusion
   probability ("is this term in the model?"); the support is chosen by the same CV among those
   the path and the ensemble keep (:mod:`~hmid.models.sindy._select`), the model is the OLS
   refit on it (STLSQ's last step);
5. each selected coefficient gets an interval (``intervals=``, see
   :mod:`~hmid.models.sindy._intervals`): by default the OLS refit's, with the covariance from
   the residual's autocovariance, as the polynomial family's -- **conditional on the selected
   support**; ``"bootstrap"`` gives the ensemble's percentile intervals instead (the old default:
   wide wherever resamples pick other supports).

Neither interval knows about bias in the derivative, the force reconstruction or a term missing
from the library: they may be narrow and still miss the truth.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

from hmid._blas import one_blas_thread
from hmid.errors import ConfigError, SignalError
from hmid.intervals import IntervalNote
from hmid.models.base import (
    Coefficient,
    FitSummary,
    ForceModel,
    check_frame,
    check_target,
    fit_statistics,
)
from hmid.models.sindy._intervals import (
    INTERVALS,
    describe,
    note,
    percentile_intervals,
    support_intervals,
)
from hmid.models.sindy._library import Feature, FeatureLibrary, ForceMap, canonical_name
from hmid.models.sindy._select import SUPPORT, refit, support_choice
from hmid.models.sindy._sparse import (
    ThresholdPath,
    bagging,
    block_stats,
    combine,
    stlsq,
    threshold_path,
)

#: Fewest rows (after leaving out stuck rows) a fit accepts.
MIN_ROWS = 50
#: Fewest blocks for cross-validation and the bootstrap.
MIN_BLOCKS = 4
#: Inclusion probabilities that leave a term in doubt (neither clearly in nor clearly out).
DOUBT = (0.2, 0.8)


class SINDyForceModel(ForceModel):
    """Sparse force map F_m(x, v, P) by pysindy's STLSQ; see the module docstring.

    ``fit(X, y)`` reads x, v, P and, when present, ``log`` and ``t`` (blocks of
    ``block_seconds`` within each log; without ``t`` the rows form 50 equal blocks in order).
    ``support`` is how a cross-validated threshold's support is chosen (``"cv"`` or
    ``"threshold"``, see the module docstring; a fixed threshold keeps STLSQ's); ``intervals``
    is the method of the coefficients' ``confidence`` intervals: ``"autocov"`` (post-selection
    OLS, conditional on the selected support) or ``"bootstrap"``.

    Fitted attributes, in library order: ``coef_`` (0 for terms left out), ``std_err_`` and
    ``ci_`` (n_terms x 2) of the chosen method (NaN for terms left out under ``"autocov"``),
    ``inclusion_`` and ``ensemble_coef_`` (the bootstrap), ``tau_int_`` and ``acf_window_``
    (the selected model's residual correlation), ``df_`` (of the t intervals; None for
    ``"bootstrap"``), ``threshold_``, ``path_``, ``choice_`` (the candidate supports; None for
    ``support="threshold"``), ``features_``, ``coefficients_``, ``summary_``.
    """

    family = "sindy"

    def __init__(
        self,
        variables: tuple[str, ...] = ("x", "v", "P"),
        degree: int = 3,
        max_degree: Mapping[str, int] | None = None,
        friction_term: bool = True,
        v0: float = 1e-3,
        stick_speed: float = 1e-2,
        keep: tuple[str, ...] = ("x", "P"),
        threshold: float | str = "cv",
        folds: int = 5,
        path_points: int = 30,
        rule: str = "one_se",
        support: str = "cv",
        ridge: float = 0.0,
        n_models: int = 50,
        block_seconds: float = 0.25,
        confidence: float = 0.95,
        intervals: str = "autocov",
        seed: int = 0,
        name: str = "sindy",
    ) -> None:
        if not (threshold == "cv" or (isinstance(threshold, int | float) and threshold >= 0)):
            raise ConfigError(f"threshold must be 'cv' or a number >= 0, got {threshold!r}")
        if rule not in ("one_se", "min"):
            raise ConfigError(f"rule must be 'one_se' or 'min', got {rule!r}")
        if support not in SUPPORT:
            raise ConfigError(f"support must be one of {', '.join(SUPPORT)}, got {support!r}")
        if not (isinstance(folds, int) and folds >= 2):
            raise ConfigError(f"folds must be an integer >= 2, got {folds!r}")
        if not (isinstance(n_models, int) and n_models >= 2):
            raise ConfigError(f"n_models must be an integer >= 2, got {n_models!r}")
        if not (0.5 < confidence < 1):
            raise ConfigError(f"confidence must lie in (0.5, 1), got {confidence!r}")
        if intervals not in INTERVALS:
            raise ConfigError(f"intervals must be one of {', '.join(INTERVALS)}, got {intervals!r}")
        for key, value in (("stick_speed", stick_speed), ("ridge", ridge)):
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"{key} must be a finite number >= 0, got {value!r}")
        if not (math.isfinite(block_seconds) and block_seconds > 0):
            raise ConfigError(f"block_seconds must be > 0, got {block_seconds!r}")
        # validates variables, degree, max_degree, v0 and keep with one-line messages
        library = FeatureLibrary(variables, degree, max_degree, friction_term, v0)
        candidates = library.candidate_names()
        for term in keep:
            if canonical_name(term) not in candidates:
                raise ConfigError(
                    f"keep names {term!r}, which is not a library term; terms: "
                    f"{', '.join(candidates)}"
                )
        self.variables = tuple(variables)
        self.degree = degree
        self.max_degree = None if max_degree is None else dict(max_degree)
        self.friction_term = friction_term
        self.v0 = v0
        self.stick_speed = stick_speed
        self.keep = tuple(keep)
        self.threshold = threshold
        self.folds = folds
        self.path_points = path_points
        self.rule = rule
        self.support = support
        self.ridge = ridge
        self.n_models = n_models
        self.block_seconds = block_seconds
        self.confidence = confidence
        self.intervals = intervals
        self.seed = seed
        self.name = name

    @property
    def required_columns(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys((*self.variables, "v")))

    # -- fitting ---------------------------------------------------------------------------------
    def fit(self, X: pd.DataFrame, y: np.ndarray) -> SINDyForceModel:
        source = f"{type(self).__name__}.fit"
        columns = check_frame(X, self.required_columns, source)
        target = check_target(y, len(X), source)
        if "t" in X.columns:
            t = check_frame(X, ("t",), source)["t"]
            logs = X["log"].astype(str).to_numpy() if "log" in X.columns else np.zeros(len(X))
            blocks = _time_blocks(logs, t, self.block_seconds)
        else:
            blocks = (np.arange(len(X)) * 50) // max(len(X), 1)
        self._fit_blocks(columns, target, blocks)
        return self

    def _fit(self, X: Mapping[str, np.ndarray], y: np.ndarray) -> None:
        self._fit_blocks(X, y, (np.arange(len(y)) * 50) // max(len(y), 1))

    def _fit_blocks(self, X: Mapping[str, np.ndarray], y: np.ndarray, blocks: np.ndarray) -> None:
        # hundreds of factorisations of ~18-column matrices: BLAS threads only add overhead
        # (x40 on a busy 2-core machine); the limit is restored on exit
        with one_blas_thread():
            self._fit_blocks_serial(X, y, blocks)

    def _fit_blocks_serial(
        self, X: Mapping[str, np.ndarray], y: np.ndarray, blocks: np.ndarray
    ) -> None:
        source = f"{type(self).__name__}.fit"
        if y.size < MIN_ROWS:
            raise SignalError(
                f"{source}: {y.size} rows cannot fit a sparse model; pass at least {MIN_ROWS}"
            )
        sliding = np.abs(X["v"]) >= self.stick_speed
        self.n_stuck_ = int((~sliding).sum())
        if sliding.sum() < MIN_ROWS:
            raise SignalError(
                f"{source}: only {int(sliding.sum())} rows have |v| >= stick_speed="
                f"{self.stick_speed} m/s; a fit needs at least {MIN_ROWS} sliding rows"
            )
        X = {k: np.asarray(v)[sliding] for k, v in X.items()}
        y, blocks = y[sliding], np.unique(blocks[sliding], return_inverse=True)[1]
        notes = []
        if blocks.max() + 1 < MIN_BLOCKS:
            notes.append(
                f"the rows span only {blocks.max() + 1} blocks of {self.block_seconds:g} s: "
                f"resampled as {MIN_ROWS} equal row blocks instead (too short for the bootstrap "
                "to respect autocorrelation)"
            )
            blocks = (np.arange(y.size) * MIN_ROWS) // y.size
        library = FeatureLibrary(
            self.variables, self.degree, self.max_degree, self.friction_term, self.v0
        )
        design = library.fit_transform(X)
        rms = np.sqrt(np.mean(design**2, axis=0))
        rms[rms == 0] = 1.0
        y_scale = float(np.std(y)) or 1.0
        Z = design / rms
        stats = block_stats(Z, y / y_scale, blocks)
        kept = {canonical_name(k) for k in self.keep}
        keep = np.array([f.name in kept for f in library.features_])
        alpha = self.ridge * len(y)
        if self.threshold == "cv":
            path = threshold_path(
                stats, points=self.path_points, folds=min(self.folds, stats.n_blocks),
                rule=self.rule, alpha=alpha, keep=keep,
            )  # fmt: skip
            threshold = path.chosen
        else:
            path, threshold = None, float(self.threshold)
        whole = combine(stats, np.ones(stats.n_blocks))  # the R factor of [Z | y]
        xi = stlsq(whole, threshold, alpha, keep=keep)
        rng = np.random.default_rng(self.seed)
        ensemble = bagging(stats, threshold, self.n_models, rng, alpha=alpha, keep=keep)
        choice = None  # a fixed threshold, or support="threshold": STLSQ's support
        if self.support == "cv" and path is not None:
            choice = support_choice(stats, min(self.folds, stats.n_blocks), path, ensemble,
                                    self.rule, alpha)  # fmt: skip
            xi = xi if choice is None else refit(whole, choice.supports[choice.chosen], alpha)
        to_physical = y_scale / rms * np.array([f.factor for f in library.features_])
        self.library_ = library
        self.features_: tuple[Feature, ...] = library.features_
        self.threshold_ = threshold
        self.kept_ = keep
        self.path_: ThresholdPath | None = path
        self.choice_ = choice
        self.coef_ = xi * to_physical
        self.normalized_coef_ = xi
        self.ensemble_coef_ = ensemble * to_physical
        self.inclusion_ = np.mean(ensemble != 0, axis=0)
        # the residual's correlation is reported for either method (a diagnostic of the fit)
        post = support_intervals(Z, y / y_scale, xi, self.confidence)
        self.tau_int_, self.acf_window_ = post.tau_int, post.window
        if self.intervals == "autocov":
            scale = np.abs(to_physical)
            self.std_err_ = post.std_err * scale
            self.ci_ = np.sort(post.ci * to_physical[:, None], axis=1)
            self.df_ = post.df
        else:
            self.std_err_, self.ci_ = percentile_intervals(self.ensemble_coef_, self.confidence)
            self.df_ = None
        self.n_blocks_ = stats.n_blocks
        self.coefficients_ = tuple(
            Coefficient(
                f"C{k}", f.name, float(c), float(se), float(lo), float(hi), f.unit, float("nan")
            )
            for k, (f, c, se, (lo, hi)) in enumerate(
                zip(self.features_, self.coef_, self.std_err_, self.ci_, strict=True)
            )
            if c != 0
        )
        fitted = design @ (xi * y_scale / rms)
        n_params = int(np.count_nonzero(xi))
        warnings_ = notes
        if self.n_stuck_:
            warnings_.append(
                f"{self.n_stuck_} rows with |v| < {self.stick_speed} m/s (block stuck or about to: "
                "static friction indeterminate, velocity sign unreliable) were left out of the fit"
            )
        if library.dropped_:
            warnings_.append(f"duplicate library columns dropped: {', '.join(library.dropped_)}")
        if n_params == 0:
            warnings_.append(f"threshold {threshold:.3g} removed every term; F_m = 0")
        doubt = [
            f"{f.pretty} ({p:.2f})"
            for f, p, k in zip(self.features_, self.inclusion_, keep, strict=True)
            if DOUBT[0] <= p < DOUBT[1] and not k
        ]
        if doubt and self.intervals == "autocov":
            warnings_.append(
                f"support in doubt: {', '.join(doubt)} kept by {DOUBT[0]:g}-{DOUBT[1]:g} of the "
                "bootstrap fits; the coefficient intervals are conditional on the selected "
                "support and miss the truth where another support is the right one"
            )
        if self.acf_window_ is None:
            warnings_.append(
                f"the residual stays correlated beyond the lags examined (a tenth of the rows; "
                f"correlation time >= {self.tau_int_:.0f} rows): the coefficient intervals are "
                "likely too narrow; the library probably misses slow structure, or the log is "
                "too short"
            )
        self.summary_ = FitSummary(
            family=self.family,
            name=self.name,
            n_obs=len(y),
            n_params=n_params,
            **fit_statistics(y, fitted, max(n_params, 1)),
            # R's leading block has Z's singular values: no SVD of the whole design
            condition_number=float(np.linalg.cond(whole[: Z.shape[1], : Z.shape[1]])),
            condition_number_unscaled=None,
            warnings=tuple(warnings_),
        )

    def _predict(self, X: Mapping[str, np.ndarray]) -> np.ndarray:
        scaled = self.coef_ / np.array([f.factor for f in self.features_])
        return self.library_.transform(X) @ scaled

    # -- results ---------------------------------------------------------------------------------
    def force_map(self) -> ForceMap:
        """The fitted F(x, v, P) as a fast scalar function (for integration)."""
        self._check_fitted()
        return ForceMap(self.features_, self.coef_, self.v0)

    @property
    def selected(self) -> tuple[str, ...]:
        """Names of the terms with a non-zero coefficient."""
        self._check_fitted()
        return tuple(f.name for f, c in zip(self.features_, self.coef_, strict=True) if c != 0)

    def coefficient_table(self) -> pd.DataFrame:
        """Every library term: value (0 if not selected), unit, standard error and interval of
        the ``intervals`` method (level and method in the ``interval`` column), bootstrap
        inclusion."""
        self._check_fitted()
        level = f"{100 * self.confidence:g}%"
        method = np.full(self.coef_.size, self.interval_note().columns()["interval"], dtype=object)
        if self.intervals == "autocov":
            method[self.coef_ == 0] = "none (left out)"
        frame = pd.DataFrame(
            {
                "term": [f.pretty for f in self.features_],
                "value": self.coef_,
                "unit": [f.unit for f in self.features_],
                "std_err": self.std_err_,
                f"ci_low ({level})": self.ci_[:, 0],
                f"ci_high ({level})": self.ci_[:, 1],
                "interval": method,
                "inclusion": self.inclusion_,
                "selected": self.coef_ != 0,
                "kept by config": self.kept_,
            },
            index=pd.Index([f"C{k}" for k in range(len(self.features_))], name="name"),
        )
        return frame

    def interval_note(self) -> IntervalNote:
        """What the coefficient intervals are, for the table's columns."""
        self._check_fitted()
        return note(self.intervals, self.confidence, self.tau_int_, self.acf_window_)

    def interval_method(self) -> str:
        """One line for reports: the intervals' level, method and calibration for this fit."""
        self._check_fitted()
        return describe(
            self.intervals, self.confidence, self.n_models, self.tau_int_, self.acf_window_,
            self.df_,
        )  # fmt: skip

    def equation(self, digits: int = 4) -> str:
        """``'F_m = 0.0002 [N/Pa]·P - 3000 [N/m]·x - 2e+06 [N/m³]·x³'`` (selected terms only)."""
        self._check_fitted()
        parts = []
        for feature, c in zip(self.features_, self.coef_, strict=True):
            if c == 0:
                continue
            text = f"{abs(c):.{digits}g} [{feature.unit}]"
            if feature.term is None:
                text += f"·tanh(v / {self.v0:g} m/s)"
            elif feature.term.powers:
                text += f"·{feature.pretty}"
            sign = "-" if c < 0 else ("" if not parts else "+")
            parts.append(f"{sign}{text}" if not parts else f"{sign} {text}")
        return "F_m = " + (" ".join(parts) if parts else "0")


def _time_blocks(logs: np.ndarray, t: np.ndarray, seconds: float) -> np.ndarray:
    """Consecutive block numbers: a new block at each log change or every ``seconds`` of t."""
    new_log = np.r_[True, logs[1:] != logs[:-1]]
    start = np.maximum.accumulate(np.where(new_log, np.arange(len(t)), 0))
    index = np.floor((t - t[start]) / seconds)
    change = new_log | np.r_[True, index[1:] != index[:-1]]
    return np.cumsum(change) - 1
