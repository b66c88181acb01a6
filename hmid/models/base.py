"""The fit contract every force-model family follows, and the summaries every family returns.

A family (polynomial, SINDy, SLS, ...) subclasses :class:`ForceModel`, scikit-learn style:

- ``__init__`` only validates and stores hyper-parameters; they cannot be re-assigned afterwards
  (make a new model instead), so a fitted model always matches its ``repr``.
- ``fit(X, y)`` checks its inputs at the boundary, computes, sets attributes whose names end in
  ``_`` and returns ``self``.
- ``predict(X)`` raises :class:`NotFittedError` before ``fit``.

``tests/models/test_estimator_contract.py`` checks these on every subclass (found, not
listed), each built by its :meth:`ForceModel.example`.

``X`` is a :class:`pandas.DataFrame` with (at least) the columns the model needs, in SI units;
``y`` is the muscle force in N, one value per row of ``X``. Every bad input raises a one-line
:class:`~hmid.errors.SignalError` naming the column (and the row, counted from 0 in the order
given, for non-finite values).

Every fitted family exposes ``summary_``, a :class:`FitStatistics` whose statistics are computed the
same way for all families (:func:`fit_statistics`), so a comparison stage can treat them alike.
"""

from __future__ import annotations

import inspect
import math
from abc import ABC, abstractmethod
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from typing import Any, ClassVar, Self, TypedDict

import numpy as np
import pandas as pd

from hmid.errors import HmidError, SignalError, where


class NotFittedError(HmidError, ValueError, AttributeError):
    """A model was used (``predict``, tables, ...) before ``fit`` was called."""


@dataclass(frozen=True)
class Coefficient:
    """One fitted coefficient in physical units, with its uncertainty.

    ``ci_low``/``ci_high`` bound the confidence interval at the model's ``confidence`` level;
    ``unit`` is the coefficient's unit (e.g. ``'N·s/m'``) and ``term`` the regressor it multiplies.
    """

    name: str
    term: str
    value: float
    std_err: float
    ci_low: float
    ci_high: float
    unit: str
    p_value: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class FitStatistics:
    """Goodness of fit of one fitted model, comparable across families.

    ``r2`` is ``1 - SSR/SST`` with SST about the mean of ``y``; ``r2_adj`` corrects it for
    ``n_params``; ``rmse`` is ``sqrt(SSR/n_obs)`` (the same definition as a held-out RMSE);
    ``aic``/``bic`` use the Gaussian log-likelihood at the ML noise variance (as statsmodels does).
    ``condition_number`` is that of the design the model was fitted on (after any feature scaling),
    ``condition_number_unscaled`` that of the design in physical units where the family rescales;
    None where a family has no linear design. ``warnings`` lists every diagnostic the fit raised.
    """

    family: str
    name: str
    n_obs: int
    n_params: int
    r2: float
    r2_adj: float
    rmse: float
    aic: float
    bic: float
    condition_number: float | None = None
    condition_number_unscaled: float | None = None
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["warnings"] = list(self.warnings)
        return out


class GoodnessOfFit(TypedDict):
    """What :func:`fit_statistics` returns (FitStatistics' fields of the same names)."""

    r2: float
    r2_adj: float
    rmse: float
    aic: float
    bic: float


def fit_statistics(y: np.ndarray, y_hat: np.ndarray, n_params: int) -> GoodnessOfFit:
    """``r2``, ``r2_adj``, ``rmse``, ``aic`` and ``bic`` of predictions ``y_hat`` of ``y``.

    ``n_params`` counts every fitted parameter (the intercept included). AIC and BIC are
    ``-2 llf + 2 k`` and ``-2 llf + k log n`` with the Gaussian log-likelihood at the ML variance
    ``SSR/n``: for OLS with an intercept they equal statsmodels' ``aic``/``bic``.
    """
    y = np.asarray(y, dtype="float64")
    resid = y - np.asarray(y_hat, dtype="float64")
    n = y.size
    ssr = float(resid @ resid)
    del resid  # a long log's rows: one temporary of y's length at a time, squared in place
    deviation = y - y.mean()
    sst = float(np.sum(np.square(deviation, out=deviation)))
    del deviation
    r2 = 1.0 - ssr / sst if sst > 0 else float("nan")
    dof = n - n_params
    r2_adj = 1.0 - (1.0 - r2) * (n - 1) / dof if dof > 0 else float("nan")
    llf = -0.5 * n * (math.log(2 * math.pi) + math.log(ssr / n) + 1.0) if ssr > 0 else math.inf
    return {
        "r2": r2,
        "r2_adj": r2_adj,
        "rmse": math.sqrt(ssr / n),
        "aic": -2.0 * llf + 2.0 * n_params,
        "bic": -2.0 * llf + math.log(n) * n_params,
    }


def check_frame(X: object, columns: tuple[str, ...], source: str) -> dict[str, np.ndarray]:
    """The ``columns`` of ``X`` as finite float64 arrays (other columns are ignored)."""
    if not isinstance(X, pd.DataFrame):
        raise SignalError(
            f"{source}: X must be a pandas DataFrame with columns {list(columns)}, "
            f"got {type(X).__name__} (use Log.to_frame() for a log)"
        )
    out = {}
    for column in columns:
        if column not in X.columns:
            raise SignalError(
                f"{where(source, column)}missing; the model needs columns {list(columns)}, "
                f"X has {[str(c) for c in X.columns]}"
            )
        try:
            values = X[column].to_numpy(dtype="float64")
        except (TypeError, ValueError):
            raise SignalError(
                f"{where(source, column)}not numeric (dtype {X[column].dtype}); "
                "convert it to float before fitting"
            ) from None
        if values.ndim != 1:  # duplicated column names give a 2-D block
            raise SignalError(f"{where(source, column)}appears more than once in X")
        out[column] = _finite(values, source, column)
    return out


def check_target(y: object, n: int, source: str) -> np.ndarray:
    """``y`` as a finite 1-D float64 array of length ``n``."""
    try:
        arr = np.asarray(y, dtype="float64")
    except (TypeError, ValueError):
        raise SignalError(f"{source}: y must be numeric, got {type(y).__name__}") from None
    if arr.ndim != 1:
        raise SignalError(f"{source}: y must be 1-D (one force per row of X), not {arr.shape}")
    if arr.size != n:
        raise SignalError(f"{source}: y has {arr.size} values but X has {n} rows; pass one per row")
    return _finite(arr, source, "y")


def _finite(values: np.ndarray, source: str, column: str) -> np.ndarray:
    finite = np.isfinite(values)
    if not finite.all():
        row = int(np.argmin(finite))
        raise SignalError(
            f"{where(source, column, row)}value {values[row]} is not finite; "
            "drop or interpolate non-finite samples first"
        )
    return values


class ForceModel(ABC):
    """Base class of the model families of F_m = f(x, v, P, ...); see the module docstring.

    Subclasses set ``family``, take their hyper-parameters as ``__init__`` arguments (stored under
    the same names; derived values may go to ``_private`` attributes), and implement
    :attr:`required_columns`, :meth:`_fit` (which sets the ``*_`` attributes, ``summary_``
    included) and :meth:`_predict`.
    """

    family: ClassVar[str] = "force model"
    summary_: FitStatistics  # set by _fit; its presence in __dict__ is what is_fitted reads

    @classmethod
    def example(cls) -> Self:
        """A cheap, valid, unfitted instance (for the contract tests and documentation)."""
        return cls()

    # -- hyper-parameters -----------------------------------------------------------------------
    @classmethod
    def _param_names(cls) -> tuple[str, ...]:
        signature = inspect.signature(cls.__init__)
        return tuple(
            name
            for name, p in signature.parameters.items()
            if name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        )

    def __setattr__(self, name: str, value: object) -> None:
        if name.endswith("_") or name.startswith("_"):
            object.__setattr__(self, name, value)
        elif name in self._param_names() and name not in self.__dict__:
            object.__setattr__(self, name, value)
        elif name in self._param_names():
            raise AttributeError(
                f"{type(self).__name__}.{name} is a hyper-parameter fixed at construction; "
                "create a new model with the value you want"
            )
        else:
            raise AttributeError(
                f"{type(self).__name__} has no hyper-parameter {name!r}; its hyper-parameters "
                f"are {list(self._param_names())} and fitted attributes end in '_'"
            )

    def get_params(self) -> dict[str, Any]:
        """The hyper-parameters, by name, as given to ``__init__``."""
        return {name: getattr(self, name) for name in self._param_names()}

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({params})"

    # -- the contract ---------------------------------------------------------------------------
    @property
    @abstractmethod
    def required_columns(self) -> tuple[str, ...]:
        """The columns of ``X`` that ``fit`` and ``predict`` read."""

    @abstractmethod
    def _fit(self, X: Mapping[str, np.ndarray], y: np.ndarray) -> None:
        """Fit on checked inputs; set the fitted ``*_`` attributes, ``summary_`` included."""

    @abstractmethod
    def _predict(self, X: Mapping[str, np.ndarray]) -> np.ndarray:
        """Predictions for checked inputs."""

    def fit(self, X: pd.DataFrame, y: np.ndarray) -> Self:
        """Fit the model to rows ``X`` (SI units) and forces ``y`` (N); returns ``self``."""
        source = f"{type(self).__name__}.fit"
        columns = check_frame(X, self.required_columns, source)
        target = check_target(y, len(X), source)
        self._fit(columns, target)
        return self

    def predict(self, X: pd.DataFrame) -> np.ndarray:
        """The predicted muscle force (N) for each row of ``X``."""
        self._check_fitted()
        columns = check_frame(X, self.required_columns, f"{type(self).__name__}.predict")
        return self._predict(columns)

    @property
    def is_fitted(self) -> bool:
        return "summary_" in self.__dict__

    def _check_fitted(self) -> None:
        if not self.is_fitted:
            raise NotFittedError(
                f"this {type(self).__name__} is not fitted yet; call fit(X, y) first"
            )


def fit_table(models: Iterable[ForceModel]) -> pd.DataFrame:
    """Goodness of fit of fitted models side by side, like thesis Table 4.1 (one row each)."""
    rows = []
    for model in models:
        if not model.is_fitted:
            raise NotFittedError(f"fit_table: {model!r} is not fitted; fit it first")
        s = model.summary_
        rows.append(
            {
                "variant": s.name,
                "family": s.family,
                "n_params": s.n_params,
                "n_obs": s.n_obs,
                "r2": s.r2,
                "r2_adj": s.r2_adj,
                "rmse": s.rmse,
                "aic": s.aic,
                "bic": s.bic,
                "condition_number": s.condition_number,
                "condition_number_unscaled": s.condition_number_unscaled,
                "warnings": len(s.warnings),
            }
        )
    return pd.DataFrame(rows)
