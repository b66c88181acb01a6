"""The polynomial family on a simulated Ch. 4 experiment: its intervals name their method."""

import numpy as np

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
        assert tuple(fitted.notes[1:]) == tuple(fitted.fit_summary["warnings"])
        # the pipeline's smoothed residuals are correlated: only OLS intervals are called narrow
        narrow = any("too narrow" in note for note in fitted.notes)
        assert narrow == (errors == "ols"), fitted.notes
