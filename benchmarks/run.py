"""hmid benchmarks: each figure is a ratio against a baseline run side by side, medians of repeats.

Run: ``make bench`` (or ``.venv/bin/python benchmarks/run.py [--quick]``). Runs
``bench_targets.py`` first (issue 14's targets, one table: met or not), then the core table below,
then every other ``benchmarks/bench_*.py`` script one after another (never side by side: the
machine has two cores), and writes all their tables to stdout and to one file
``results/benchmarks/<UTC time>.md``, the targets at the top. ``--quick`` runs only the core table.
"""

from __future__ import annotations

import datetime as dt
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _baseline_rig import integrate_python
from _timing import median_time

from hmid.io import ChannelSpec, ColumnMap, read_log
from hmid.signal import moving_average
from hmid.simulate.params import RigParams
from hmid.simulate.profiles import Sine
from hmid.simulate.rig import integrate
from hmid.simulate.rigs.hydro_muscle import HydroMuscle, equilibrium


def bench_simulator(rows):
    rig, rate, substeps = RigParams(), 1000.0, 20
    for seconds, repeats, base_repeats in ((6.0, 5, 3), (60.0, 5, 0)):
        t = np.arange(1, int(seconds * rate) + 1) / rate
        P_cmd = Sine().command(t, None)
        hmid_t = median_time(
            lambda P=P_cmd: integrate(HydroMuscle(rig), {"P_cmd": P}, rate, substeps=substeps),
            repeats,
        )
        if base_repeats:
            x0 = equilibrium(rig, float(P_cmd[0]))
            x_ref = integrate_python(rig, P_cmd, rate, x0, substeps)
            x_hmid = integrate(HydroMuscle(rig), {"P_cmd": P_cmd}, rate, substeps=substeps).x
            agree = float(np.max(np.abs(x_ref - x_hmid)))
            base_t = median_time(
                lambda P=P_cmd, x0=x0: integrate_python(rig, P, rate, x0, substeps), base_repeats
            )
            rows.append(
                (
                    f"rig simulator, {seconds:g} s at 1 kHz, 20 substeps",
                    "pure-Python loop, same equations",
                    hmid_t,
                    base_t,
                    f"max |x diff| {agree:.1e} m",
                )
            )
        else:
            rows.append(
                (
                    f"rig simulator, {seconds:g} s at 1 kHz, 20 substeps",
                    "—",
                    hmid_t,
                    None,
                    "target: a few seconds",
                )
            )


def bench_moving_average(rows):
    y = np.random.default_rng(0).normal(size=1_000_000)
    for n in (11, 1001):
        ours = median_time(lambda n=n: moving_average(y, n), 7)
        series = pd.Series(y)
        base = median_time(lambda n=n, s=series: s.rolling(n, center=True, min_periods=1).mean(), 7)
        rows.append(
            (
                f"centred moving average, 1e6 samples, window {n}",
                "pandas rolling(center=True).mean()",
                ours,
                base,
                "",
            )
        )


def bench_read_log(rows):
    n = 60_000
    rng = np.random.default_rng(1)
    frame = pd.DataFrame(
        {
            "t_ms": np.arange(n, dtype=float),
            "P_kPa": rng.uniform(0, 300, n),
            "x_mm": rng.uniform(0, 20, n),
            "F_N": rng.uniform(0, 10, n),
        }
    )
    units = {"t": "ms", "P": "kPa", "x": "mm", "F": "N"}
    columns = ColumnMap(
        channels={c: ChannelSpec(column=f"{c}_{u}", unit=u) for c, u in units.items()}
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "log.csv"
        frame.to_csv(path, index=False)
        ours = median_time(lambda: read_log(path, columns), 7)
        base = median_time(lambda: pd.read_csv(path), 7)
    rows.append(
        (
            "read_log: 60 s, 1 kHz CSV, validated + SI",
            "pandas.read_csv alone",
            ours,
            base,
            "cost of validation and units",
        )
    )


SCRIPTS = (
    ("Targets (issue 14)", "bench_targets.py", []),  # first: its table heads the output
    ("Startup: import hmid and hmid --help", "bench_startup.py", []),
    ("SLS likelihood", "bench_sls_likelihood.py", []),
    ("SLS stage speed and calibration", "bench_sls_calibration.py", []),
    ("Polynomial interval calibration", "bench_calibration_polynomial.py", []),
    ("The loop's cost per candidate effect", "bench_loop.py", []),
    ("Balance (loop) interval calibration", "bench_calibration_balance.py", []),
    ("SINDy interval calibration", "bench_calibration_sindy.py", []),
    ("Friction interval calibration", "bench_calibration_friction.py", []),
    ("Memory and disk at 1 M and 10 M rows", "bench_memory.py", ["--rows", "1000000", "10000000"]),
    ("SINDy fit", "bench_sindy.py", []),
    ("Free run against solve_ivp (issue 29)", "bench_freerun.py", []),
    ("Cost against log length", "bench_scaling.py", []),
    ("Sweeps: 1 vs 2 workers", "bench_sweep.py", []),
)


def _tables(stdout: str) -> list[str]:
    """The Markdown tables (``|`` lines) and italic notes (``_`` lines) of a script's output,
    a blank line between a note and a table."""
    kept: list[str] = []
    for line in stdout.splitlines():
        if not line.startswith(("|", "_")):
            continue
        if kept and kept[-1][0] != line[0] and "|" in (kept[-1][0], line[0]):
            kept.append("")
        kept.append(line)
    return kept


def run_scripts(scripts) -> list[str]:
    """A section per script of ``scripts``: its title, its Markdown table and italic notes."""
    import subprocess

    sections = []
    here = Path(__file__).resolve().parent
    for title, script, args in scripts:
        if not (here / script).is_file():
            continue
        print(f"running {script} ...", flush=True)
        done = subprocess.run(
            [sys.executable, str(here / script), *args],
            capture_output=True,
            text=True,
            cwd=here.parent,
        )
        table = _tables(done.stdout)
        status = "" if done.returncode == 0 else f"\n(exit {done.returncode}: {done.stderr[-300:]})"
        sections.append(f"## {title} (`{script}`)\n\n" + "\n".join(table) + status + "\n")
    return sections


def main() -> int:
    quick = "--quick" in sys.argv[1:]
    targets = "" if quick else "\n".join(run_scripts(SCRIPTS[:1])) + "\n"
    if targets:
        print(targets, flush=True)
    rows: list[tuple] = []
    bench_simulator(rows)
    bench_moving_average(rows)
    bench_read_log(rows)
    lines = [
        f"# hmid benchmarks ({dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC, medians of repeats)",
        "",
        "| what | baseline | hmid [s] | baseline [s] | speed-up | note |",
        "|---|---|---:|---:|---:|---|",
    ]
    for what, baseline, ours, base, note in rows:
        ratio = f"{base / ours:.1f}x" if base else "—"
        base_s = f"{base:.4f}" if base else "—"
        lines.append(f"| {what} | {baseline} | {ours:.4f} | {base_s} | {ratio} | {note} |")
    text = "\n".join(lines) + "\n"
    print(text, flush=True)
    text = targets + text
    if not quick:
        text += "\n" + "\n".join(run_scripts(SCRIPTS[1:]))
        print(text)
    out = Path("results/benchmarks")
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{dt.datetime.now(dt.UTC):%Y%m%dT%H%M%SZ}.md").write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
