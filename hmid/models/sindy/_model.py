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

from collections.abc import Mapping

import numpy as np
import pandas as pd

from hmid._blas import one_blas_thread
from hmid.errors import ConfigError, SignalError
from hmid.intervals import IntervalNote
from hmid.models.base import (
    Coefficient,
    FitStatistics,
    ForceModel,
    check_frame,
    check_target,
    fit_statistics,
)
from hmid.models.sindy._intervals import (
    describe,
    note,
    percentile_intervals,
    support_intervals,
)
from hmid.models.sindy._library import Feature, canonical_name
from hmid.models.sindy._select import refit, support_choice
from hmid.models.sindy._settings import CrossValidation, Ensemble, SINDySettings
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

    ``settings`` (:class:`~hmid.models.sindy.SINDySettings`, validated there and trusted here)
    holds every hyperparameter of the fit; ``seed`` seeds the bootstrap and ``name`` names the
    fitted model. ``fit(X, y)`` reads x, v, P and, when present, ``log`` and ``t`` (blocks of
    ``settings.ensemble.block_seconds`` within each log; without ``t`` the rows form 50 equal
    blocks in order). ``settings.support`` is how a cross-validated threshold's support is
    chosen (``"cv"`` or ``"threshold"``, see the module docstring; a fixed threshold keeps
    STLSQ's); ``settings.intervals`` is the method of the coefficients' intervals:
    ``"autocov"`` (post-selection OLS, conditional on the selected support) or ``"bootstrap"``.

    Fitted attributes, in library order: ``coef_`` (0 for terms left out), ``std_err_`` and
    ``ci_`` (n_terms x 2) of the chosen method (NaN for terms left out under ``"autocov"``),
    ``cov_`` (the selected terms' covariance, of the same method, in physical units),
    ``inclusion_`` and ``ensemble_coef_`` (the bootstrap), ``tau_int_`` and ``acf_window_``
    (the selected model's residual correlation), ``df_`` (of the t intervals; None for
    ``"bootstrap"``), ``threshold_``, ``path_``, ``choice_`` (the candidate supports; None for
    ``support="threshold"``), ``features_``, ``coefficients_``, ``summary_``.
    """

    family = "sindy"

    def __init__(
        self, settings: SINDySettings | None = None, *, seed: int = 0, name: str = "sindy"
    ) -> None:
        if settings is not None and not isinstance(settings, SINDySettings):
            raise ConfigError(
                f"settings must be a SINDySettings (validated hyperparameters), got "
                f"{type(settings).__name__}; e.g. SINDySettings(degree=2, keep=())"
            )
        self.settings = SINDySettings() if settings is None else settings
        self.seed = seed
        self.name = name

    @classmethod
    def example(cls) -> SINDyForceModel:
        """Few threshold points and bootstrap fits: a cheap fit."""
        return cls(SINDySettings(cv=CrossValidation(points=5), ensemble=Ensemble(models=10)))

    # read-only views of the settings that reports and the family read
    @property
    def v0(self) -> float:
        return self.settings.v0

    @property
    def stick_speed(self) -> float:
        return self.settings.stick_speed

    @property
    def confidence(self) -> float:
        return self.settings.ensemble.confidence

    @property
    def intervals(self) -> str:
        return self.settings.intervals

    @property
    def n_models(self) -> int:
        return self.settings.ensemble.models

    @property
    def block_seconds(self) -> float:
        return self.settings.ensemble.block_seconds

    @property
    def required_columns(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys((*self.settings.variables, "v")))

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
        X, y, blocks, notes = self._sliding_rows(X, y, blocks)
        library = self.settings.library()
        design = library.fit_transform(X)
        rms = np.sqrt(np.mean(design**2, axis=0))
        rms[rms == 0] = 1.0
        y_scale = float(np.std(y)) or 1.0
        Z = design / rms
        stats = block_stats(Z, y / y_scale, blocks)
        kept = {canonical_name(k) for k in self.settings.keep}
        keep = np.array([f.name in kept for f in library.features_])
        whole, xi, ensemble = self._select(stats, keep, self.settings.ridge * len(y))
        to_physical = y_scale / rms * np.array([f.factor for f in library.features_])
        self.library_ = library
        self.features_: tuple[Feature, ...] = library.features_
        self.kept_ = keep
        self.coef_ = xi * to_physical
        self.normalized_coef_ = xi
        self.ensemble_coef_ = ensemble * to_physical
        self.inclusion_ = np.mean(ensemble != 0, axis=0)
        self._intervals(Z, y / y_scale, xi, to_physical)
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
        self.summary_ = FitStatistics(
            family=self.family,
            name=self.name,
            n_obs=len(y),
            n_params=n_params,
            **fit_statistics(y, fitted, max(n_params, 1)),
            # R's leading block has Z's singular values: no SVD of the whole design
            condition_number=float(np.linalg.cond(whole[: Z.shape[1], : Z.shape[1]])),
            condition_number_unscaled=None,
            warnings=(*notes, *self._warnings(n_params)),
        )

    def _sliding_rows(self, X: Mapping[str, np.ndarray], y: np.ndarray, blocks: np.ndarray):
        """The rows with |v| >= stick_speed (step 1 of the module docstring), their blocks
        renumbered (or equal row blocks where too few), and a note if so."""
        source = f"{type(self).__name__}.fit"
        if y.size < MIN_ROWS:
            raise SignalError(
                f"{source}: {y.size} rows cannot fit a sparse model; pass at least {MIN_ROWS}"
            )
        stick_speed = self.settings.stick_speed
        sliding = np.abs(X["v"]) >= stick_speed
        self.n_stuck_ = int((~sliding).sum())
        if sliding.sum() < MIN_ROWS:
            raise SignalError(
                f"{source}: only {int(sliding.sum())} rows have |v| >= stick_speed="
                f"{stick_speed} m/s; a fit needs at least {MIN_ROWS} sliding rows"
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
        return X, y, blocks, notes

    def _select(self, stats, keep: np.ndarray, alpha: float):
        """The threshold (fixed or by CV), STLSQ at it, the bootstrap ensemble and the support
        (steps 3-4): sets ``threshold_``, ``path_``, ``choice_``; returns the R factor of the
        whole [Z | y], the normalised coefficients and the ensemble's."""
        settings, cv = self.settings, self.settings.cv
        folds = min(cv.folds, stats.n_blocks)
        if settings.threshold == "cv":
            path = threshold_path(stats, points=cv.points, folds=folds, rule=cv.rule, alpha=alpha,
                                  keep=keep)  # fmt: skip
            threshold = path.chosen
        else:
            path, threshold = None, float(settings.threshold)
        whole = combine(stats, np.ones(stats.n_blocks))  # the R factor of [Z | y]
        xi = stlsq(whole, threshold, alpha, keep=keep)
        rng = np.random.default_rng(self.seed)
        ensemble = bagging(stats, threshold, self.n_models, rng, alpha=alpha, keep=keep)
        choice = None  # a fixed threshold, or support="threshold": STLSQ's support
        if settings.support == "cv" and path is not None:
            choice = support_choice(stats, folds, path, ensemble, cv.rule, alpha)
            xi = xi if choice is None else refit(whole, choice.supports[choice.chosen], alpha)
        self.threshold_ = threshold
        self.path_: ThresholdPath | None = path
        self.choice_ = choice
        return whole, xi, ensemble

    def _intervals(self, Z, z, xi, to_physical) -> None:
        """The coefficients' intervals of the ``intervals`` method (step 5) and the residual's
        correlation (reported for either method: a diagnostic of the fit)."""
        post = support_intervals(Z, z, xi, self.confidence)
        self.tau_int_, self.acf_window_ = post.tau_int, post.window
        support = np.flatnonzero(xi)
        if self.intervals == "autocov":
            scale = np.abs(to_physical)
            self.std_err_ = post.std_err * scale
            self.ci_ = np.sort(post.ci * to_physical[:, None], axis=1)
            self.df_ = post.df
            self.cov_ = post.cov * np.outer(to_physical[support], to_physical[support])
        else:
            self.std_err_, self.ci_ = percentile_intervals(self.ensemble_coef_, self.confidence)
            self.df_ = None
            picked = self.ensemble_coef_[:, support]
            self.cov_ = (np.cov(picked, rowvar=False).reshape(support.size, support.size)
                         if support.size else np.zeros((0, 0)))  # fmt: skip

    def _warnings(self, n_params: int) -> list[str]:
        """What the fit says about itself: rows left out, columns dropped, doubtful support,
        a residual correlated beyond the lags examined."""
        out = []
        if self.n_stuck_:
            out.append(
                f"{self.n_stuck_} rows with |v| < {self.stick_speed} m/s (block stuck or about to: "
                "static friction indeterminate, velocity sign unreliable) were left out of the fit"
            )
        if self.library_.dropped_:
            out.append(f"duplicate library columns dropped: {', '.join(self.library_.dropped_)}")
        if n_params == 0:
            out.append(f"threshold {self.threshold_:.3g} removed every term; F_m = 0")
        doubt = [
            f"{f.pretty} ({p:.2f})"
            for f, p, k in zip(self.features_, self.inclusion_, self.kept_, strict=True)
            if DOUBT[0] <= p < DOUBT[1] and not k
        ]
        if doubt and self.intervals == "autocov":
            out.append(
                f"support in doubt: {', '.join(doubt)} kept by {DOUBT[0]:g}-{DOUBT[1]:g} of the "
                "bootstrap fits; the coefficient intervals are conditional on the selected "
                "support and miss the truth where another support is the right one"
            )
        if self.acf_window_ is None:
            out.append(
                f"the residual stays correlated beyond the lags examined (a tenth of the rows; "
                f"correlation time >= {self.tau_int_:.0f} rows): the coefficient intervals are "
                "likely too narrow; the library probably misses slow structure, or the log is "
                "too short"
            )
        return out

    def _predict(self, X: Mapping[str, np.ndarray]) -> np.ndarray:
        scaled = self.coef_ / np.array([f.factor for f in self.features_])
        return self.library_.transform(X) @ scaled

    # -- results ---------------------------------------------------------------------------------
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
        parts: list[str] = []
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
