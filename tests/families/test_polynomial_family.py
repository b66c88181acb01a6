"""The polynomial family on a simulated Ch. 4 experiment: its intervals name their method."""

import numpy as np
import pytest

from hmid.families import FitContext, FitData
from hmid.families.polynomial import PolynomialSpec


def test_default_intervals_are_autocov_and_every_fit_names_its_method(ch4_split):
    config, split, friction, root = ch4_split
    data = FitData(split.signals, config.rig)
    assert PolynomialSpec().errors == "autocov"
    for errors, says in (("autocov", "residual's autocovariance"), ("ols", "independent errors")):
        spec = PolynomialSpec(variants=("quadratic_xv",), errors=errors)
        (fitted,) = spec.fit(data, FitContext(5, root / f"poly-{errors}", friction))
        assert fitted.notes[0].startswith("95 % intervals: ") and says in fitted.notes[0]
        assert np.all(np.isfinite(fitted.coefficients["std_err"]))
        assert tuple(fitted.notes[1:]) == fitted.fit_summary.warnings
        # the pipeline's smoothed residuals are correlated: only OLS intervals are called narrow
        narrow = any("too narrow" in note for note in fitted.notes)
        assert narrow == (errors == "ols"), fitted.notes


def test_a_cubic_term_is_the_smoothed_cube_of_the_unsmoothed_position(ch4_split):
    """The smoothed force holds S[c x³]; the family's x³ column must be S[x_raw³], not (S x)³,
    whose difference (≈ 3x·var(x) within the kernel) would bias c and leave structure even in v
    for the loop to misname. A target built exactly so is fitted exactly."""
    from hmid.balance.signals import raw
    from hmid.families.polynomial import CustomTerms

    config, split, friction, root = ch4_split
    signals = split.signals
    x = signals["x"]
    target = 2e6 * signals.smooth(signals[raw("x")] ** 3) - 3000.0 * x + 5.0
    data = FitData(signals.with_columns(target=target), config.rig)
    spec = PolynomialSpec(variants=(), custom=(CustomTerms(name="x3", variables=("x",)),))
    (fitted,) = spec.fit(data, FitContext(5, root / "poly-cube", friction))
    table = fitted.coefficients.set_index("term")
    sign = data.slot_sign
    assert sign * table.loc["x^3", "value"] == pytest.approx(2e6, rel=1e-6)
    assert sign * table.loc["x", "value"] == pytest.approx(-3000.0, rel=1e-6)
    residual = data.y - fitted.predict(data)
    assert np.max(np.abs(residual)) < 1e-6
