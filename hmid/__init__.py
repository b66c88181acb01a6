"""hmid: system identification of soft fluidic actuators, first of all the Hydro Muscle.

The public surface is re-exported here; submodules hold one concept each. Importing hmid does no
work: heavy dependencies (pandas, pint, JAX, matplotlib) are imported by the functions that use
them, and names whose modules import them load on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from hmid._lazy import lazy_exports
from hmid.errors import ConfigError, HmidError, HmidWarning, LogError, SignalError, UnitError

if TYPE_CHECKING:
    from hmid.api import Run, load_run, run
    from hmid.io.log import CANONICAL_UNITS, Log
    from hmid.population import predict_muscle
    from hmid.portable import Model, load_model

__version__ = "0.1.0"

__all__ = [
    "CANONICAL_UNITS",
    "ConfigError",
    "HmidError",
    "HmidWarning",
    "Log",
    "LogError",
    "Model",
    "Run",
    "SignalError",
    "UnitError",
    "__version__",
    "load_model",
    "load_run",
    "predict_muscle",
    "run",
]

# Re-exports whose modules import pandas, resolved on first access (PEP 562) so that `import hmid`
# and `hmid --help` stay fast.
_LAZY = {
    "CANONICAL_UNITS": "hmid.io.log",
    "Log": "hmid.io.log",
    "Model": "hmid.portable",
    "Run": "hmid.api",
    "load_model": "hmid.portable",
    "load_run": "hmid.api",
    "predict_muscle": "hmid.population",
    "run": "hmid.api",
}


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
