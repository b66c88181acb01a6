"""Memory and disk at scale: `hmid run` (polynomial family) on a long log: peak RSS, cache size.

A dynamic log of N rows is made by repeating the demo's dynamic logs end to end (time running on),
written as CSV with the demo's column map; the demo's free falls give the friction. The run is a
separate process; its peak resident memory comes from ``os.wait4`` and is set against the log's
float64 size (rows x 4 channels x 8 bytes), the stage cache against the CSV's size.

Targets (issue "Trust", item 10): peak RSS <= 4x the log's float64 size, cache <= the input size.
The peak is judged twice: whole, and above the same run's peak on a 20,000-row log (the
interpreter and its libraries, about 0.2 GB: by itself 6x a 1 M-row log's float64 size, so at
1 M rows only the part the log adds can meet the target).

    python benchmarks/bench_memory.py --rows 1000000 10000000
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.report.markdown import markdown_table

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "data" / "demo"
CHANNELS = 4  # t, P, x, F
BASE_ROWS = 20_000  # the run's peak without a long log: interpreter, libraries, figures

CONFIG = """\
name: memory
seed: 1
rig:
{rig}
logs:
  - {{path: {log}, columns: {demo}/columns-dynamic.yaml, role: dynamic}}
  - {{path: {demo}/free-fall-1.csv, columns: {demo}/columns-free_fall.yaml, role: free_fall}}
  - {{path: {demo}/free-fall-2.csv, columns: {demo}/columns-free_fall.yaml, role: free_fall}}
models:
  - {{family: polynomial, variants: [quadratic_xv, cubic_xvP]}}
"""


def long_log(rows: int, path: Path) -> Path:
    """The demo's dynamic logs repeated to ``rows`` rows, time continuing at 1 kHz."""
    parts = [pd.read_csv(p) for p in sorted(DEMO.glob("dyn-*.csv"))]
    one = pd.concat(parts, ignore_index=True)
    reps = -(-rows // len(one))
    table = pd.concat([one] * reps, ignore_index=True).iloc[:rows].copy()
    table["t_ms"] = np.arange(1, rows + 1)
    table.to_csv(path, index=False)
    return path


def rig_section() -> str:
    lines = (ROOT / "configs" / "demo.yaml").read_text().splitlines()
    start = lines.index("rig:")
    body = []
    for line in lines[start + 1 :]:
        if line and not line.startswith((" ", "#")):
            break
        body.append(line)
    return "\n".join(body)


def measure(rows: int, work: Path) -> dict[str, float]:
    log = long_log(rows, work / f"long-{rows}.csv")
    config = work / f"memory-{rows}.yaml"
    config.write_text(CONFIG.format(rig=rig_section(), log=log, demo=DEMO))
    results = work / f"results-{rows}"
    start = time.perf_counter()
    child = subprocess.Popen(
        [sys.executable, "-m", "hmid.cli", "run", str(config), "--results", str(results)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    if status != 0:
        raise SystemExit(f"hmid run failed for {rows} rows: {child.stderr.read().decode()}")
    cache = sum(p.stat().st_size for p in (results / "memory" / ".cache").rglob("*") if p.is_file())
    data = rows * CHANNELS * 8
    return {
        "rows": rows,
        "csv MB": log.stat().st_size / 1e6,
        "log float64 MB": data / 1e6,
        "peak RSS MB": usage.ru_maxrss / 1e3,  # kB on Linux
        "peak / float64": usage.ru_maxrss * 1e3 / data,
        "cache MB": cache / 1e6,
        "cache / csv": cache / log.stat().st_size,
        "wall s": wall,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, nargs="+", default=[1_000_000])
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="hmid-memory-") as tmp:
        base = measure(BASE_ROWS, Path(tmp))["peak RSS MB"]
        for n in args.rows:
            rows.append(measure(n, Path(tmp)))
            rows[-1]["above base / float64"] = (rows[-1]["peak RSS MB"] - base) / (
                n * CHANNELS * 8e-6
            )
            print(pd.DataFrame(rows).to_string(index=False, float_format="%.3g"), flush=True)
    table = pd.DataFrame(rows)
    table["peak <= 4x"] = table["peak / float64"] <= 4.0
    table["above base <= 4x"] = table["above base / float64"] <= 4.0
    table["cache <= csv"] = table["cache / csv"] <= 1.0
    print()
    print(markdown_table(table, ".3g"))


if __name__ == "__main__":
    main()
