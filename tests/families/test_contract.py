"""One contract, run over every registered family (as scikit-learn's parametrize_with_checks):
a valid example config fits on the same rows, predicts every row of either role, survives the
stage cache, reports what it found, and states its terms so that the loop can refit it."""

import json
import pickle

import numpy as np
import pandas as pd
import pytest

from hmid.balance import Structure, profile
from hmid.families import FAMILIES, FigureSpec, FitContext, FitData, FittedModel
from hmid.metrics import score


@pytest.fixture(scope="module")
def fits(ch4_split):
    config, split, friction, root = ch4_split
    signals = split.signals
    hidden = signals.with_columns(target=np.where(signals.train, signals.target, np.nan))
    data = FitData(hidden, config.rig)
    out = {}
    for name, cls in FAMILIES.items():
        spec = cls.example(config.rig)
        spec.check(config.rig)
        out[name] = (spec, spec.fit(data, FitContext(5, root / name, friction)))
    return out


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_family_honours_the_fit_contract(family, fits, ch4_split, tmp_path):
    config, split, _, _ = ch4_split
    spec, fitted = fits[family]
    assert type(spec).model_validate(spec.model_dump(mode="json")) == spec  # config round-trip
    assert [m.name for m in fitted] == spec.model_names() and fitted
    train, held = (
        FitData(split.signals, config.rig),
        FitData(split.signals, config.rig, "validation"),
    )
    for model in fitted:
        assert isinstance(model.model, FittedModel) and model.family == family
        for data in (train, held):
            y = model.predict(data)
            assert y.shape == (int(data.rows.sum()),) and np.isfinite(y).all()
        json.dumps(model.fit_summary.to_dict())  # metrics.json
        assert len(model.coefficients) > 0 and model.equation
        # every interval says what it is: level, method, calibration status
        table = model.coefficient_table()
        assert model.interval is not None and {"interval", "calibration"} <= set(table.columns)
        stated = table["interval"].str.startswith(f"{100 * model.interval.level:g} %")
        assert stated.any() and (stated | table["interval"].str.startswith("none")).all()
        clone = pickle.loads(pickle.dumps(model))  # the stage cache pickles fitted models
        np.testing.assert_array_equal(clone.predict(held), model.predict(held))
        band = model.predict_interval(held)
        if band is not None:
            assert np.all(band[0] <= band[1])
        extras = model.model.report_extras()
        for figure in [] if extras is None else extras.figures:
            assert isinstance(figure, FigureSpec) and figure.caption
            figure = pickle.loads(pickle.dumps(figure))  # as a worker draws it
            figure.draw(*figure.args, tmp_path / figure.file)
            assert (tmp_path / figure.file).is_file()


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_family_states_terms_the_loop_can_refit(family, fits, ch4_split):
    """Refitted by least squares (profiled parameters re-profiled), a model's own terms do
    about as well on held-out rows as the family's fit: the loop's 'before' and its nested
    tests describe the same model."""
    config, split, _, _ = ch4_split
    held = FitData(split.signals, config.rig, "validation")
    for model in fits[family][1]:
        structure = model.model.structure()
        assert isinstance(structure, Structure) and structure.terms
        signals = split.signals.trim(*structure.margins)
        refit = profile(structure, signals)
        own = score(held.y, model.predict(held)).rmse
        again = refit.scores(signals.validation).rmse
        assert again <= 1.15 * own + 0.005, (model.name, own, again)


@pytest.mark.parametrize(
    "family", sorted(n for n, c in FAMILIES.items() if c.reads_training_target_only)
)
def test_a_family_that_reads_only_training_targets_never_sees_the_others(family, fits, ch4_split):
    """The fit stage hands such a family the signals with the held-out target as it is (not
    blanked): any other value there must leave its fit unchanged."""
    config, split, friction, root = ch4_split
    spec, fitted = fits[family]
    signals = split.signals
    wild = signals.with_columns(target=np.where(signals.train, signals.target, 1e9))
    again = spec.fit(FitData(wild, config.rig), FitContext(5, root / family, friction))
    for model, other in zip(fitted, again, strict=True):
        pd.testing.assert_frame_equal(model.coefficients, other.coefficients)


def test_a_balance_carries_the_covariance_its_intervals_read(fits):
    """The model file's covariance (what a free run's band draws the coefficients from), in
    the columns' order: its diagonal gives the table's standard errors."""
    _, fitted = fits["balance"]
    model = fitted[0].model
    se = fitted[0].coefficients.set_index("parameter")["std. error"]
    assert model.covariance.shape == (len(model.names),) * 2
    np.testing.assert_allclose(np.sqrt(np.diag(model.covariance)), se.loc[list(model.names)],
                               rtol=1e-12)  # fmt: skip


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_model_carries_the_uncertainty_its_band_draws_from(family, fits):
    """A free run's band draws the coefficients from the posterior where the family has one,
    else from the model file's covariance: one row and column per term of the structure, with
    the intervals' own standard errors on its diagonal."""
    _, fitted = fits[family]
    for model in fitted:
        if getattr(model.model, "posterior_draws", None) is not None:
            continue
        cov = model.model.covariance
        n = len(model.model.structure().terms)
        assert cov.shape == (n, n) and np.allclose(cov, cov.T) and np.all(np.diag(cov) > 0)
        if family == "sindy":
            force = model.model.force
            selected = force.std_err_[force.coef_ != 0]
            np.testing.assert_allclose(np.sqrt(np.diag(cov)), selected, rtol=1e-12)
