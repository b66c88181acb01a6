"""Cost against work: full pipeline wall time and peak memory for longer and longer logs.

Run: ``.venv/bin/python benchmarks/bench_scaling.py [--repeats 3] [--durations 15 30 60 120 240]``.

For each duration D a data set is simulated (two dynamic logs of D/2 s at 1 kHz, sine and random
levels, plus two free falls) and ``hmid run --force`` is timed in a fresh process (median of
repeats; peak RSS of that process). Families: the four polynomials, SINDy, and SLS with a fixed
step budget (so its work is proportional to the data, not to a convergence test). Cost must grow
linearly: the time ratio for each doubling of D should lie in 1.7-2.3.

Also, side by side in the same run: the pipeline's wall time against the sum of its stage times
(overhead of imports, config, cache), and the polynomial family against a plain statsmodels
formula fit of the same 16-term model.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from _timing import median_time

ROOT = Path(__file__).resolve().parents[1]

RUNNER = """
import json, resource, sys, time
start = time.perf_counter()
from pipelines.identify import run
run_dir, _ = run(sys.argv[1], results=sys.argv[2], force=True)
wall = time.perf_counter() - start
stages = json.load(open(run_dir / "manifest.json"))["stage_wall_s"]
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"wall": wall, "stages": stages, "rss_mb": rss}))
"""


def dataset(folder: Path, duration: float) -> Path:
    from hmid.simulate.dataset import DatasetConfig
    from hmid.simulate.write import write_dataset

    half = duration / 2
    config = DatasetConfig.model_validate(
        {
            "seed": 7,
            "logs": [
                {"name": "sine", "kind": "dynamic", "duration": half, "profile": {"kind": "sine"}},
                {
                    "name": "levels",
                    "kind": "dynamic",
                    "duration": half,
                    "profile": {
                        "kind": "random_levels",
                        "low": 8e4,
                        "high": 1.7e5,
                        "hold_min": 0.5,
                    },
                },
                {"name": "ff1", "kind": "free_fall", "duration": 0.3, "x0": 0.15},
                {"name": "ff2", "kind": "free_fall", "duration": 0.3, "x0": 0.17},
            ],
        }
    )
    write_dataset(config, folder / "data")
    logs = [
        {"path": f"data/{n}.csv", "columns": f"data/columns-{k}.yaml", "role": r}
        for n, k, r in (
            ("sine", "dynamic", "dynamic"),
            ("levels", "dynamic", "dynamic"),
            ("ff1", "free_fall", "free_fall"),
            ("ff2", "free_fall", "free_fall"),
        )
    ]
    experiment = {
        "name": f"scale{int(duration)}",
        "seed": 1,
        "rig": {"M": 0.25, "m1": 0.5},
        "logs": logs,
        "friction": {"v_min": 0.05},
        "models": [
            {"family": "polynomial"},
            {"family": "sindy"},
            {"family": "sls", "stride": 4, "max_steps": 400, "max_seconds": 1e6},
        ],
    }
    path = folder / "experiment.yaml"
    path.write_text(yaml.safe_dump(experiment))
    return path


def time_pipeline(config: Path, results: Path, repeats: int) -> dict:
    runs = []
    for _ in range(repeats):
        out = subprocess.run(
            [sys.executable, "-c", RUNNER, str(config), str(results)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        )
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    wall = statistics.median(r["wall"] for r in runs)
    stages = statistics.median(sum(r["stages"].values()) for r in runs)
    per_stage = {k: statistics.median(r["stages"][k] for r in runs) for k in runs[0]["stages"]}
    rss = max(r["rss_mb"] for r in runs)
    return {"wall": wall, "stages": stages, "per_stage": per_stage, "rss_mb": rss}


#: Stages whose work is proportional to the data; fit and report also carry fixed costs (JIT
#: compilation, a fixed MCMC step budget's per-call overhead, figure rendering).
DATA_STAGES = ("load", "denoise", "friction", "reconstruct", "split", "compare")


def _data_time(result: dict) -> float:
    return sum(result["per_stage"].get(k, 0.0) for k in DATA_STAGES)


def polynomial_vs_formula(repeats: int = 5) -> tuple[float, float]:
    import statsmodels.formula.api as smf

    from hmid.models.polynomial import PolynomialModel

    rng = np.random.default_rng(0)
    n = 30_000
    frame = pd.DataFrame(
        {
            "x": rng.uniform(0, 0.015, n),
            "v": rng.uniform(-0.1, 0.1, n),
            "P": rng.uniform(3e4, 2.5e5, n),
        }
    )
    frame["F"] = 1 + 2e-4 * frame.P - 3000 * frame.x + rng.normal(0, 0.01, n)
    formula = (
        "F ~ x + v + P + I(x**2) + I(x*v) + I(v**2) + I(x*P) + I(v*P) + I(x**3) + "
        "I(x**2*v) + I(x*v**2) + I(v**3) + I(x**2*P) + I(x*v*P) + I(v**2*P)"
    )

    def median(fn):
        return median_time(fn, repeats)

    ours = median(lambda: PolynomialModel("cubic_xvP").fit(frame[["x", "v", "P"]], frame.F))
    base = median(lambda: smf.ols(formula, frame).fit())
    return ours, base


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--durations", type=float, nargs="+", default=[15, 30, 60, 120, 240])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for duration in args.durations:
            folder = Path(tmp) / f"d{int(duration)}"
            config = dataset(folder, duration)
            result = time_pipeline(config, folder / "results", args.repeats)
            rows.append((duration, result))
            print(f"{duration:6.0f} s: {result}", flush=True)
    names = list(rows[0][1]["per_stage"])
    lines = [
        "| log length | wall [s] | overhead [s] | peak RSS [MB] | "
        + " | ".join(f"{n} [s]" for n in names)
        + " | wall ratio | data-stage ratio |",
        "|" + "---:|" * (len(names) + 6),
    ]
    for i, (duration, r) in enumerate(rows):
        if i:
            prev = rows[i - 1][1]
            ratios = f"{r['wall'] / prev['wall']:.2f} | {_data_time(r) / _data_time(prev):.2f}"
        else:
            ratios = "— | —"
        cells = " | ".join(f"{r['per_stage'][n]:.2f}" for n in names)
        lines.append(
            f"| {duration:.0f} s | {r['wall']:.2f} | {r['wall'] - r['stages']:.2f} | "
            f"{r['rss_mb']:.0f} | {cells} | {ratios} |"
        )
    ours, base = polynomial_vs_formula()
    lines += [
        "",
        "| fit of the 16-term cubic with P, 30k rows | hmid [s] | statsmodels formula [s] "
        "| ratio |",
        "|---|---:|---:|---:|",
        f"| PolynomialModel vs smf.ols(formula) | {ours:.4f} | {base:.4f} | {base / ours:.2f}x |",
    ]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
