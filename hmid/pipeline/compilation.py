"""JAX's persistent compilation cache, kept beside the stage cache.

The SLS and loop stages compile some sixty small XLA programs per run (~3 s on the demo). Kept
on disk, a second run loads them instead (measured: the demo's fit stage 6.6 s -> 3.8 s). A
loaded program is the one a fresh compile gives, so the numbers do not change. Set once per
process, by the command line (never at import): the first folder set stays.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

#: JAX's options, as it reads them from the environment when it is imported.
OPTIONS = {
    "jax_compilation_cache_dir": None,  # the folder
    # the programs are small and quick to compile one by one, but there are many of them
    "jax_persistent_cache_min_compile_time_secs": 0.0,
    "jax_persistent_cache_min_entry_size_bytes": 0,
}


def use_compilation_cache(folder: Path) -> None:
    """Keep compiled programs in ``folder`` (made if missing) from now on in this process.
    JAX is not imported for it: a run whose families never compile does not load JAX (~130 MB)."""
    folder = Path(folder)
    values = {name: str(folder) if value is None else value for name, value in OPTIONS.items()}
    if "jax" not in sys.modules:
        if os.environ.get("JAX_COMPILATION_CACHE_DIR"):
            return
        folder.mkdir(parents=True, exist_ok=True)
        for name, value in values.items():
            os.environ[name.upper()] = str(value)
        return
    import jax

    if jax.config.jax_compilation_cache_dir:  # type: ignore[attr-defined]  # set dynamically
        return
    folder.mkdir(parents=True, exist_ok=True)
    for name, value in values.items():
        jax.config.update(name, value)
