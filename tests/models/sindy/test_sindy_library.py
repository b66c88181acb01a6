"""The feature library: the design built once for fit and transform, duplicate columns dropped."""

import numpy as np
import pytest

from hmid.models.sindy._library import FeatureLibrary


def _columns(n=5000, seed=0, constant_pressure=False):
    rng = np.random.default_rng(seed)
    x, v = rng.uniform(0.0, 0.05, n), rng.normal(0, 0.1, n)
    P = np.full(n, 2e5) if constant_pressure else rng.uniform(0, 3e5, n)
    return {"x": x, "v": v, "P": P}


def test_fit_transform_is_fit_then_transform():
    columns = _columns()
    design = FeatureLibrary().fit_transform(columns)
    np.testing.assert_array_equal(design, FeatureLibrary().fit(columns).transform(columns))


def test_a_constant_channel_drops_every_column_it_duplicates():
    """Scaled, a constant P is 1: P repeats the bias, x·P repeats x and v·P repeats v."""
    library = FeatureLibrary(degree=2).fit(_columns(constant_pressure=True))
    assert set(library.dropped_) == {"P", "x*P", "v*P"}
    assert "P" not in library.names and {"1", "x", "v", "x^2"} <= set(library.names)
    varied = FeatureLibrary(degree=2).fit(_columns())
    assert varied.dropped_ == ()
    # P at its maximum (scaled: 1, the bias) on the rows the duplicate check probes first, and
    # below it elsewhere: alike there, different whole, so kept
    columns = _columns()
    columns["P"] = np.where(np.arange(5000) % 78 == 0, 3e5, 0.9 * columns["P"])
    assert FeatureLibrary(degree=2).fit(columns).dropped_ == ()


@pytest.mark.parametrize(
    "variables, degree, friction",
    [(("x", "v", "P"), 3, True), (("x", "v"), 2, False), (("x",), 1, True), (("v", "P"), 5, True)],
)
def test_the_design_is_pysindys_own_transform(variables, degree, friction):
    rng = np.random.default_rng(degree)
    n = 500
    columns = {
        "x": rng.normal(0.05, 0.01, n),
        "v": rng.normal(0, 0.1, n),
        "P": rng.normal(2e5, 3e4, n),
    }
    library = FeatureLibrary(variables, degree=degree, friction_term=friction)
    design = library.fit_transform(columns)
    scaled = [columns[v] / library.scales_[v] for v in variables]
    if friction:
        scaled.append(columns["v"] / library.v0)
    inputs = np.column_stack(scaled)
    theirs = np.asarray(library.pysindy_library(inputs).transform(inputs))
    np.testing.assert_array_equal(design, theirs[:, library.columns_])


def test_a_fitted_library_transforms_and_unpickles_without_pysindy():
    """A fitted model crosses processes (a worker's fit, the stage cache): it must not make
    the process that reads it import pysindy (about a second)."""
    import pickle
    import subprocess
    import sys

    columns = _columns(n=200)
    library = FeatureLibrary().fit(columns)
    code = (
        "import pickle, sys; lib = pickle.loads(sys.stdin.buffer.read()); "
        "lib.transform({k: lib.scales_[k] * __import__('numpy').ones(3) for k in 'xvP'}); "
        "print('pysindy' in sys.modules, 'sklearn' in sys.modules)"
    )
    found = subprocess.run(
        [sys.executable, "-c", code], input=pickle.dumps(library), capture_output=True, check=True
    )
    assert found.stdout.split() == [b"False", b"False"]
