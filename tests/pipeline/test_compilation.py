"""The persistent compilation cache is set without importing JAX, and JAX honours it."""

import subprocess
import sys


def test_the_cache_folder_is_set_without_importing_jax_and_jax_reads_it(tmp_path):
    folder = tmp_path / "jax-cache"
    code = (
        "import sys, os\n"
        "from hmid.pipeline.compilation import use_compilation_cache\n"
        f"use_compilation_cache({str(folder)!r})\n"
        "assert 'jax' not in sys.modules\n"
        f"use_compilation_cache({str(tmp_path / 'other')!r})  # the first folder stays\n"
        "import jax\n"
        "print(jax.config.jax_compilation_cache_dir,"
        " jax.config.jax_persistent_cache_min_compile_time_secs)\n"
    )
    env = {k: v for k, v in __import__("os").environ.items() if not k.startswith("JAX_")}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    assert out.stdout.split() == [str(folder), "0.0"]
    assert folder.is_dir()
