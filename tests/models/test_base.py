"""The fit contract, checked on every model family, and the shared summary types."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hmid.errors import HmidError, SignalError
from hmid.models import (
    Coefficient,
    FitStatistics,
    ForceModel,
    NotFittedError,
    PolynomialModel,
    fit_statistics,
    fit_table,
)

FAMILIES = [
    lambda: PolynomialModel("cubic_xvP"),
    lambda: PolynomialModel("quadratic_xv"),
    lambda: PolynomialModel(("1", "x", "v*P"), confidence=0.9, scale=False),
]


def data(n: int = 80, seed: int = 0) -> tuple[pd.DataFrame, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = pd.DataFrame(
        {
            "t": np.arange(n) * 1e-3,
            "x": rng.uniform(0, 0.015, n),
            "v": rng.uniform(-0.1, 0.1, n),
            "P": rng.uniform(3e4, 2.5e5, n),
        }
    )
    y = 2.0 + 300.0 * X["x"].to_numpy() + 5.0 * X["v"].to_numpy() + rng.normal(0, 0.01, n)
    return X, y


@pytest.fixture(params=range(len(FAMILIES)), ids=["cubic_xvP", "quadratic_xv", "custom"])
def model(request) -> ForceModel:
    return FAMILIES[request.param]()


def test_fit_returns_self_sets_trailing_underscore_attributes_and_predicts(model) -> None:
    X, y = data()
    before = dict(vars(model))
    assert not model.is_fitted
    assert model.fit(X, y) is model
    assert model.is_fitted
    added = set(vars(model)) - set(before)
    assert added and all(name.endswith("_") for name in added)
    prediction = model.predict(X)
    assert prediction.shape == (len(X),) and np.isfinite(prediction).all()
    summary = model.summary_
    assert isinstance(summary, FitStatistics) and summary.n_obs == len(X)
    assert all(isinstance(c, Coefficient) for c in model.coefficients_)
    assert len(model.coefficients_) == summary.n_params


def test_predict_before_fit_raises_not_fitted(model) -> None:
    X, _ = data()
    with pytest.raises(NotFittedError, match="not fitted yet; call fit"):
        model.predict(X)
    with pytest.raises(NotFittedError):
        fit_table([model])
    assert issubclass(NotFittedError, HmidError)


def test_missing_column_names_it_on_one_line(model) -> None:
    X, y = data()
    for column in model.required_columns:
        with pytest.raises(SignalError, match=f"column '{column}': missing") as info:
            model.fit(X.drop(columns=column), y)
        assert "\n" not in str(info.value)
    model.fit(X, y)
    column = model.required_columns[-1]
    with pytest.raises(SignalError, match=f"predict: column '{column}': missing"):
        model.predict(X.drop(columns=column))


def test_non_finite_input_names_column_and_row(model) -> None:
    X, y = data()
    column = model.required_columns[0]
    X.loc[17, column] = np.nan
    with pytest.raises(SignalError, match=f"fit: column '{column}' row 17: value nan") as info:
        model.fit(X, y)
    assert "\n" not in str(info.value)
    X, y = data()
    y[5] = np.inf
    with pytest.raises(SignalError, match="column 'y' row 5: value inf is not finite"):
        model.fit(X, y)
    X["t"] = np.nan  # columns the model does not read are not checked
    model.fit(X, y=data()[1])


def test_bad_shapes_and_types_are_one_line_errors(model) -> None:
    X, y = data()
    with pytest.raises(SignalError, match="y has 79 values but X has 80 rows"):
        model.fit(X, y[:-1])
    with pytest.raises(SignalError, match="X must be a pandas DataFrame"):
        model.fit(X.to_numpy(), y)
    with pytest.raises(SignalError, match="y must be 1-D"):
        model.fit(X, y[:, None])
    with pytest.raises(SignalError, match="not numeric"):
        model.fit(X.assign(x="a"), y)
    with pytest.raises(SignalError, match="3 rows cannot fit"):  # every family here has >= 3
        model.fit(X.iloc[:3], y[:3])


def test_hyper_parameters_are_frozen_and_reported(model) -> None:
    params = model.get_params()
    assert set(params) == {"terms", "confidence", "scale", "errors", "units", "target_unit"}
    assert repr(model).startswith(f"{type(model).__name__}(terms=")
    with pytest.raises(AttributeError, match="fixed at construction"):
        model.confidence = 0.5
    with pytest.raises(AttributeError, match="no hyper-parameter 'alpha'"):
        model.alpha = 1.0
    X, y = data()
    model.fit(X, y)
    assert model.get_params() == params  # fit does not touch hyper-parameters


def test_fit_statistics_match_statsmodels_for_ols_with_intercept() -> None:
    from statsmodels.regression.linear_model import OLS

    X, y = data(n=60, seed=3)
    exog = np.column_stack([np.ones(len(X)), X["x"], X["v"]])
    result = OLS(y, exog).fit()
    stats = fit_statistics(y, result.fittedvalues, 3)
    assert stats["r2"] == pytest.approx(result.rsquared, rel=1e-12)
    assert stats["r2_adj"] == pytest.approx(result.rsquared_adj, rel=1e-12)
    assert stats["aic"] == pytest.approx(result.aic, rel=1e-12)
    assert stats["bic"] == pytest.approx(result.bic, rel=1e-12)
    assert stats["rmse"] == pytest.approx(np.sqrt(result.ssr / len(y)), rel=1e-12)


def test_summary_types_convert_to_plain_dicts() -> None:
    X, y = data()
    model = PolynomialModel("quadratic_xv").fit(X, y)
    summary = model.summary_.to_dict()
    assert summary["family"] == "polynomial" and summary["name"] == "quadratic_xv"
    assert summary["n_params"] == 6 and isinstance(summary["warnings"], list)
    first = model.coefficients_[0].to_dict()
    assert list(first) == [
        *("name", "term", "value", "std_err", "ci_low", "ci_high", "unit", "p_value")
    ]
    assert first["name"] == "C0" and first["unit"] == "N"
    with pytest.raises(AttributeError):
        model.summary_.r2 = 1.0  # frozen
