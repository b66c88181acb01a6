"""Cost against work: full pipeline wall time and peak memory for longer and longer logs.

Run: ``.venv/bin/python benchmarks/bench_scaling.py [--repeats 3] [--durations 15 30 60 120 240]
[--long]`` (``--long`` adds 480 s and 960 s, where the marginal cost dominates; ~15 min).

For each duration D a data set is simulated (two dynamic logs of D/2 s at 1 kHz, sine and random
levels, plus two free falls) and ``hmid run --force`` is timed in a fresh process (median of
repeats; peak RSS of that process), per stage and per model family inside the fit stage.
Families: the four polynomials, SINDy, and SLS with a fixed step budget (so its work is
proportional to the data, not to a convergence test). Cost must grow linearly: the time ratio for
each doubling of D should lie in 1.7-2.3.

Fixed costs (start-up and JIT compilation, figure rendering, the MCMC's per-call overhead) hide
that ratio at short logs, so each part's medians are also fitted as T = a + b D (least squares
over the durations): ``a`` is its fixed part, and the *marginal ratio* (T(2D) - a) / (T(D) - a)
the doubling ratio of the rest, which must lie in 1.7-2.3 as well; ``k`` is the log-log slope of
T - a against D over the durations (1 = linear, 2 = quadratic). A ratio is left out ("~") where
the marginal part is under 10 % of the time (it is then noise).

Also, side by side in the same run: the pipeline's wall time against the sum of its stage times
(overhead of imports, config, cache), and the polynomial family against a plain statsmodels
formula fit of the same 16-term model.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from _rigs import DEMO_RIG
from _timing import median_time

ROOT = Path(__file__).resolve().parents[1]

RUNNER = """
import json, resource, sys, time
start = time.perf_counter()
from hmid.families import FAMILIES
from pipelines.identify import run
families = {}
def timed(name, fit):
    def wrapper(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return fit(self, *args, **kwargs)
        finally:
            families[name] = families.get(name, 0.0) + time.perf_counter() - t0
    return wrapper
for name, cls in FAMILIES.items():
    cls.fit = timed(name, cls.fit)
run_dir, _ = run(sys.argv[1], results=sys.argv[2], force=True)
wall = time.perf_counter() - start
stages = json.load(open(run_dir / "manifest.json"))["stage_wall_s"]
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"wall": wall, "stages": stages, "families": families, "rss_mb": rss}))
"""


def dataset(folder: Path, duration: float) -> Path:
    from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
    from hmid.simulate.write import write_dataset

    half = duration / 2
    config = HydroMuscleDataset.model_validate(
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
        "rig": DEMO_RIG,
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


def run_pipeline(config: Path, results: Path) -> dict:
    """One ``hmid run --force`` in a fresh process: wall, stage and family times, peak RSS."""
    out = subprocess.run(
        [sys.executable, "-c", RUNNER, str(config), str(results)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def medians(runs: list[dict]) -> dict:
    """Medians over repeated runs of one data set."""
    wall = statistics.median(r["wall"] for r in runs)
    stages = statistics.median(sum(r["stages"].values()) for r in runs)
    per_stage = {k: statistics.median(r["stages"][k] for r in runs) for k in runs[0]["stages"]}
    families = {k: statistics.median(r["families"][k] for r in runs) for k in runs[0]["families"]}
    overhead = statistics.median(r["wall"] - sum(r["stages"].values()) for r in runs)
    rss = statistics.median(r["rss_mb"] for r in runs)
    return {
        "wall": wall, "stages": stages, "per_stage": per_stage, "families": families,
        "overhead": overhead, "rss_mb": rss,
    }  # fmt: skip


def linear_fit(durations: list[float], values: list[float]) -> tuple[float, float]:
    """``(a, b)`` of the least-squares line ``value = a + b * duration``; ``a`` clipped at 0."""
    b, a = np.polyfit(np.asarray(durations, float), np.asarray(values, float), 1)
    a = max(float(a), 0.0)
    return a, float(b)


def marginal(durations: list[float], values: list[float]) -> dict:
    """Fixed part, marginal slope, marginal ratio per doubling and log-log slope ``k``."""
    a, b = linear_fit(durations, values)
    if len(values) < 3:  # a line through two points says nothing about curvature
        return {"a": a, "b": b, "ratios": [None] * (len(values) - 1), "k": None}
    ratios = []
    for i in range(1, len(values)):
        step = durations[i] / durations[i - 1]
        low, high = values[i - 1] - a, values[i] - a
        if low < 0.1 * values[i - 1] or high <= 0 or not math.isclose(step, 2.0, rel_tol=0.01):
            ratios.append(None)  # marginal part too small to measure, or not a doubling
        else:
            ratios.append(high / low)
    rest = [(d, v - a) for d, v in zip(durations, values, strict=True) if v - a > 0.1 * v]
    k = None
    if len(rest) >= 2:
        k = float(np.polyfit(np.log([d for d, _ in rest]), np.log([r for _, r in rest]), 1)[0])
    return {"a": a, "b": b, "ratios": ratios, "k": k}


def _ratio(value: float | None) -> str:
    if value is None:
        return "~"
    return f"{value:.2f}" + (" (!)" if value > 2.3 else "")  # (!): faster than linear


def components(rows: list[tuple[float, dict]]) -> dict[str, list[float]]:
    """Median time of every part at every duration: stages, families, overhead, wall, RSS."""
    first = rows[0][1]
    parts: dict[str, list[float]] = {"wall [s]": [r["wall"] for _, r in rows]}
    parts["start-up etc. [s]"] = [r["overhead"] for _, r in rows]
    for name in first["per_stage"]:
        parts[f"{name} [s]"] = [r["per_stage"][name] for _, r in rows]
        if name == "fit":
            for family in first["families"]:
                parts[f"  fit: {family} [s]"] = [r["families"][family] for _, r in rows]
    parts["peak RSS [MB]"] = [r["rss_mb"] for _, r in rows]
    return parts


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
    parser.add_argument(
        "--long", action="store_true", help="also 480 s and 960 s (the marginal cost dominates)"
    )
    args = parser.parse_args()
    durations = sorted(set(args.durations) | ({480.0, 960.0} if args.long else set()))
    load_before = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folders = {d: Path(tmp) / f"d{int(d)}" for d in durations}
        configs = {d: dataset(folders[d], d) for d in durations}
        runs: dict[float, list[dict]] = {d: [] for d in durations}
        # round-robin over the lengths: a burst of other work on the machine then spreads over
        # all of them instead of inflating one length's every repeat
        for _ in range(args.repeats):
            for duration in durations:
                runs[duration].append(run_pipeline(configs[duration], folders[duration] / "out"))
        for duration in durations:
            rows.append((duration, medians(runs[duration])))
            print(f"{duration:6.0f} s: {json.dumps(rows[-1][1])}", flush=True)
    load_after = os.getloadavg()[0]
    names = list(rows[0][1]["per_stage"])
    wall_fit = marginal(durations, [r["wall"] for _, r in rows])
    lines = [
        "| log length | wall [s] | start-up etc. [s] | peak RSS [MB] | "
        + " | ".join(f"{n} [s]" for n in names)
        + " | wall ratio | marginal wall ratio |",
        "|" + "---:|" * (len(names) + 6),
    ]
    for i, (duration, r) in enumerate(rows):
        if i:
            ratios = (
                f"{r['wall'] / rows[i - 1][1]['wall']:.2f} | {_ratio(wall_fit['ratios'][i - 1])}"
            )
        else:
            ratios = "— | —"
        cells = " | ".join(f"{r['per_stage'][n]:.2f}" for n in names)
        lines.append(
            f"| {duration:.0f} s | {r['wall']:.2f} | {r['overhead']:.2f} | "
            f"{r['rss_mb']:.0f} | {cells} | {ratios} |"
        )
    pairs = [f"{durations[i - 1]:.0f}→{durations[i]:.0f}" for i in range(1, len(durations))]
    lines += [
        "",
        "| part | fixed a | marginal b [per min of log] | "
        + " | ".join(f"marginal ratio {p}" for p in pairs)
        + " | k (T - a ∝ D^k) |",
        "|---|" + "---:|" * (len(pairs) + 3),
    ]
    for part, values in components(rows).items():
        fit = marginal(durations, values)
        k = "~" if fit["k"] is None else f"{fit['k']:.2f}"
        lines.append(
            f"| {part} | {fit['a']:.2f} | {60 * fit['b']:.3f} | "
            + " | ".join(_ratio(v) for v in fit["ratios"])
            + f" | {k} |"
        )
    lines += [
        "",
        "| machine | cores | 1-min load before | 1-min load after | repeats (medians) |",
        "|---|---:|---:|---:|---:|",
        f"| {os.uname().machine} | {os.cpu_count()} | {load_before:.2f} | {load_after:.2f} | "
        f"{args.repeats} |",
    ]
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
