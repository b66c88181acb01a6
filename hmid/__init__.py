"""hmid: system identification of soft fluidic actuators, first of all the Hydro Muscle.

The public surface is re-exported here; submodules hold one concept each. Importing hmid does no
work: heavy dependencies (JAX, matplotlib) are imported by the functions that use them.
"""

from hmid.errors import ConfigError, HmidError, HmidWarning, LogError, SignalError, UnitError
from hmid.io.log import CANONICAL_UNITS, Log

__version__ = "0.1.0"

__all__ = [
    "CANONICAL_UNITS",
    "ConfigError",
    "HmidError",
    "HmidWarning",
    "Log",
    "LogError",
    "SignalError",
    "UnitError",
    "__version__",
]
