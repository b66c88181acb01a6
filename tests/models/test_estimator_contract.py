"""The estimator contract, checked on every :class:`ForceModel` subclass (scikit-learn's
``parametrize_with_checks``): the subclasses are found by importing every module of
:mod:`hmid.models`, not listed here, and each is built by its ``example()``.

fit returns self; fitted attributes end in ``_``; predict before fit raises NotFittedError;
non-finite inputs are rejected at the boundary, naming column and row; predictions are finite,
one per row; a fitted model pickles and predicts the same; fit leaves the hyperparameters as
they were.
"""

from __future__ import annotations

import copy
import importlib
import inspect
import pickle
import pkgutil

import numpy as np
import pandas as pd
import pytest

import hmid.models
from hmid.errors import SignalError
from hmid.models import ForceModel, NotFittedError


def _subclasses(cls: type) -> set[type]:
    out = set()
    for sub in cls.__subclasses__():
        out |= {sub, *_subclasses(sub)}
    return out


def _force_models() -> list[type[ForceModel]]:
    for info in pkgutil.walk_packages(hmid.models.__path__, "hmid.models."):
        importlib.import_module(info.name)
    found = {
        c
        for c in _subclasses(ForceModel)
        if c.__module__.startswith("hmid.") and not inspect.isabstract(c)
    }
    return sorted(found, key=lambda c: f"{c.__module__}.{c.__qualname__}")


MODELS = _force_models()


def test_every_family_is_found():
    assert {c.family for c in MODELS} >= {"polynomial", "sindy"}


def data(n: int = 2000, seed: int = 0) -> tuple[pd.DataFrame, np.ndarray]:
    """2 s of a sliding muscle at 1 kHz: x, v, P and a force with a spring, a pressure drive
    and friction (every row slides: |v| > 0.01 m/s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    phase = 2 * np.pi * 1.3 * t
    x = 0.01 + 0.005 * np.sin(phase)
    v = 0.005 * 2 * np.pi * 1.3 * np.cos(phase)
    v = np.where(np.abs(v) < 0.012, np.copysign(0.012, v), v)
    P = 1e5 + 5e4 * np.sin(2 * np.pi * 0.7 * t + 1.0)
    X = pd.DataFrame({"log": "a", "t": t, "x": x, "v": v, "P": P})
    y = 2e-4 * P - 3000 * x + 0.5 * np.tanh(v / 1e-3) + rng.normal(0, 0.01, n)
    return X, y


@pytest.fixture(scope="module")
def rows():
    return data()


@pytest.fixture(scope="module", params=MODELS, ids=lambda c: c.__name__)
def fitted(request, rows):
    """(unfitted example, its hyperparameters before fit, the same model fitted)."""
    model = request.param.example()
    params = copy.deepcopy(model.get_params())
    before = set(vars(model))
    returned = model.fit(*rows)
    return model, params, before, returned


def test_fit_returns_self(fitted):
    model, _, _, returned = fitted
    assert returned is model and model.is_fitted


def test_fitted_attributes_end_in_underscore(fitted):
    model, _, before, _ = fitted
    added = {name for name in set(vars(model)) - before if not name.startswith("_")}
    assert added, "fit set no attribute"
    assert all(name.endswith("_") for name in added), sorted(added)
    assert "summary_" in added


def test_fit_leaves_the_hyperparameters(fitted):
    model, params, _, _ = fitted
    assert model.get_params() == params


def test_predictions_are_finite_one_per_row(fitted, rows):
    model = fitted[0]
    X, _ = rows
    prediction = model.predict(X)
    assert isinstance(prediction, np.ndarray) and prediction.shape == (len(X),)
    assert np.isfinite(prediction).all()


def test_pickling_round_trips(fitted, rows):
    model = fitted[0]
    X, _ = rows
    copy_ = pickle.loads(pickle.dumps(model))
    assert type(copy_) is type(model) and copy_.get_params() == model.get_params()
    np.testing.assert_array_equal(copy_.predict(X), model.predict(X))


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
def test_predict_before_fit_raises_not_fitted(cls, rows):
    with pytest.raises(NotFittedError, match="not fitted"):
        cls.example().predict(rows[0])


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_inputs_are_rejected_naming_column_and_row(cls, bad, rows):
    X, y = rows
    model = cls.example()
    for column in model.required_columns:
        broken = X.copy()
        broken.loc[7, column] = bad
        with pytest.raises(SignalError, match=f"column '{column}' row 7: value"):
            model.fit(broken, y)
    target = y.copy()
    target[7] = bad
    with pytest.raises(SignalError, match="column 'y' row 7: value"):
        model.fit(X, target)


def test_non_finite_rows_are_rejected_by_predict(fitted, rows):
    model = fitted[0]
    X, _ = rows
    broken = X.copy()
    broken.loc[3, model.required_columns[0]] = np.nan
    with pytest.raises(SignalError, match="row 3: value nan is not finite"):
        model.predict(broken)
