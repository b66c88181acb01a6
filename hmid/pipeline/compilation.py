"""JAX's persistent compilation cache, kept beside the stage cache.

The SLS and loop stages compile some sixty small XLA programs per run (~3 s on the demo). Kept
on disk, a second run loads them instead (measured: the demo's fit stage 6.6 s -> 3.8 s). A
loaded program is the one a fresh compile gives, so the numbers do not change. Set once per
process, by the command line (never at import): the first folder set stays.
"""

from __future__ import annotations

from pathlib import Path


def use_compilation_cache(folder: Path) -> None:
    """Keep compiled programs in ``folder`` (made if missing) from now on in this process."""
    import jax

    if jax.config.jax_compilation_cache_dir:
        return
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(folder))
    # the programs are small and quick to compile one by one, but there are many of them
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
