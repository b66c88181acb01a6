"""The one list of libraries hmid imports where they are used rather than at a module's top.

``import hmid`` and ``hmid --help`` must start in a fraction of a second, and a command imports
only what its stages use; these libraries cost that start-up (wall time of ``python -c "import
LIB"`` on the 2-core CI-class machine, cold, 2026-11-27). Everywhere else imports go at the top.
An import inside a function is one of these, a module of hmid that imports one of these at its
top (directly or through other hmid modules), or the way out of an import cycle:
``tests/test_startup.py`` checks every such import against that rule.
"""

from __future__ import annotations

#: library -> measured import time (s)
DEFERRED: dict[str, float] = {
    "arviz": 1.70,
    "control": 1.41,
    "corner": 1.49,
    "dask": 0.39,
    "diffrax": 1.01,
    "distributed": 0.39,
    "emcee": 0.86,
    "equinox": 0.92,
    "h5netcdf": 0.11,
    "h5py": 0.17,
    "jax": 0.50,
    "lineax": 0.78,
    "matplotlib": 0.43,
    "numpyro": 1.04,
    "optimistix": 1.04,
    "pandas": 0.46,
    "pint": 0.33,
    "pyarrow": 0.17,
    "pysindy": 3.39,
    "scipy": 0.19,
    "sklearn": 1.08,
    "statsmodels": 1.35,
    "xarray": 0.44,
}
