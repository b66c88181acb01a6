"""Startup: ``import hmid`` and ``hmid --help`` in fresh interpreters (target: 0.3 s each).

Run: ``.venv/bin/python benchmarks/bench_startup.py [--repeats N]``. Prints a Markdown table. Each
timing is the wall time of a whole fresh process, as a user waits for it; medians of ``--repeats``
repeats, all commands interleaved so that load from other work on the machine hits them alike,
after one warm-up round (bytecode caches, the file cache). The baselines run side by side: the
bare interpreter (``python -c "pass"``) and ``python -c "import numpy"``, the floor of any
scientific Python command. A note says which heavy dependencies each command loaded.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 0.3
HEAVY = ("pandas", "pint", "jax", "scipy", "matplotlib", "pydantic", "numpy")
PY = sys.executable
# The help that ``hmid --help`` prints, in-process so the probe can read sys.modules afterwards.
HELP_CODE = (
    "import contextlib, io\nfrom hmid.cli import main\n"
    "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
    "    main(['--help'])"
)


def commands() -> dict[str, tuple[list[str], str | None]]:
    """name -> (argv, Python code whose loaded modules the note reports, or None)."""
    out = {
        '`python -c "pass"`': ([PY, "-c", "pass"], None),
        '`python -c "import numpy"`': ([PY, "-c", "import numpy"], None),
        '`python -c "import hmid"`': ([PY, "-c", "import hmid"], "import hmid"),
        "`python -m hmid.cli --help`": ([PY, "-m", "hmid.cli", "--help"], HELP_CODE),
    }
    script = Path(PY).parent / "hmid"  # the console script, where the package is installed
    if script.is_file():
        out["`hmid --help` (console script)"] = ([str(script), "--help"], HELP_CODE)
    return out


def median_walls(argvs: dict[str, list[str]], repeats: int) -> dict[str, float]:
    """Median wall time of each command run as a fresh process; repeats interleaved."""
    for argv in argvs.values():
        subprocess.run(argv, check=True, capture_output=True, cwd=ROOT)  # warm-up
    walls = {name: [] for name in argvs}
    for _ in range(repeats):
        for name, argv in argvs.items():
            start = time.perf_counter()
            subprocess.run(argv, check=True, capture_output=True, cwd=ROOT)
            walls[name].append(time.perf_counter() - start)
    return {name: statistics.median(values) for name, values in walls.items()}


def heavy_loaded(code: str) -> list[str]:
    """The heavy dependencies in ``sys.modules`` after ``code`` runs in a fresh interpreter."""
    probe = f"{code}\nimport sys\nprint(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    done = subprocess.run([PY, "-c", probe], check=True, capture_output=True, text=True, cwd=ROOT)
    return done.stdout.split()


def table(repeats: int) -> list[str]:
    cmds = commands()
    load_before = os.getloadavg()[0]
    walls = median_walls({name: argv for name, (argv, _) in cmds.items()}, repeats)
    bare, numpy_name = '`python -c "pass"`', '`python -c "import numpy"`'
    lines = [
        f"Startup, fresh processes, medians of {repeats} interleaved repeats; cores: "
        f"{os.cpu_count()}; 1-minute load average {load_before:.1f} before, "
        f"{os.getloadavg()[0]:.1f} after (other work on the machine slows every row alike); "
        f"heavy imports: which of {', '.join(HEAVY)} the command loaded\n",
        "| what | time [s] | baseline | baseline [s] | ratio | target | met | note |",
        "|---|---:|---|---:|---:|---|---|---|",
        f"| {bare} | {walls[bare]:.3f} | — | — | — | — | — | the bare interpreter |",
    ]
    for name, (_, code) in cmds.items():
        if name == bare:
            continue
        wall, base = walls[name], walls[bare if name == numpy_name else numpy_name]
        baseline = bare if name == numpy_name else numpy_name
        target, met = ("—", "—") if code is None else (f"≤ {TARGET_S} s", "met")
        if code is not None and wall > TARGET_S:
            met = "not met"
        note = f"+{wall - walls[bare]:.3f} s over the bare interpreter"
        if code is not None:
            note += f"; heavy imports: {', '.join(heavy_loaded(code)) or 'none'}"
        lines.append(
            f"| {name} | {wall:.3f} | {baseline} | {base:.3f} | {wall / base:.2f}x | {target} "
            f"| {met} | {note} |"
        )
    return lines


def _at_least_one(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1 (got {text!r})")
    return value


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=_at_least_one, default=11, help="default: 11")
    args = parser.parse_args()
    print("\n".join(table(args.repeats)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
