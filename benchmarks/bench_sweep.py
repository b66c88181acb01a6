"""Sweep benchmark: a 16-run sweep with 2 local workers against 1 (target: at least 1.6x faster).

Run: ``.venv/bin/python benchmarks/bench_sweep.py [--repeats N] [--dask]``. Prints a Markdown
table. The runs are small on purpose: the identification study with only the polynomial family
(``quadratic_xv``) on two simulated 3 s dynamic logs and two free falls, a 4 x 4 grid over the
smoothing window and the held-out fraction. Each timing is the whole sweep as a user sees it
(planning, worker start-up, the runs, the table) into a fresh results folder; medians of
``--repeats`` repeats, the 1- and 2-worker sweeps alternating. ``--dask`` also times a local Dask
cluster (started before the clock, as an existing cluster would be) with 1 and 2 worker processes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import yaml
from _rigs import DEMO_RIG

# hmid is imported inside the functions: the pool's worker processes import this (main) module
# again, and must not pay for the simulator (JAX) that only the parent needs.

DATASET = {
    "seed": 7,
    "logs": [
        {"name": "sine", "kind": "dynamic", "duration": 3, "profile": {"kind": "sine"}},
        {"name": "chirp", "kind": "dynamic", "duration": 3,
         "profile": {"kind": "chirp", "f0": 0.2, "f1": 1.5}},
        {"name": "ff1", "kind": "free_fall", "duration": 0.3, "x0": 0.15},
        {"name": "ff2", "kind": "free_fall", "duration": 0.3, "x0": 0.17},
    ],
}  # fmt: skip

GRID = {
    "denoise.smoother.window_s": [0.005, 0.011, 0.021, 0.031],
    "split.validation_fraction": [0.2, 0.25, 0.3, 0.35],
}


VARIANTS = ("quadratic_xv", "cubic_xvP", "cubic_xv", "quadratic_xvP")  # thesis Table 4.1


def workspace(root: Path, variants: int) -> Path:
    """Simulated logs, a polynomial-only experiment with ``variants`` model variants and the
    16-run sweep config on it; returns the sweep config's path."""
    from hmid.simulate.rigs.hydro_muscle_dataset import HydroMuscleDataset
    from hmid.simulate.write import write_dataset

    if not (root / "data").is_dir():
        write_dataset(HydroMuscleDataset.model_validate(DATASET), root / "data")
    logs = [
        {"path": f"data/{name}.csv", "columns": f"data/columns-{role}.yaml", "role": role}
        for name, role in (("sine", "dynamic"), ("chirp", "dynamic"),
                           ("ff1", "free_fall"), ("ff2", "free_fall"))
    ]  # fmt: skip
    experiment = {
        "name": f"bench-{variants}", "seed": 1, "rig": DEMO_RIG, "logs": logs,
        "friction": {"v_min": 0.05},
        "models": [{"family": "polynomial", "variants": list(VARIANTS[:variants])}],
    }  # fmt: skip
    (root / f"experiment-{variants}.yaml").write_text(yaml.safe_dump(experiment))
    sweep = root / f"sweep-{variants}.yaml"
    config = {"name": f"sweep-{variants}", "base": f"experiment-{variants}.yaml", "grid": GRID}
    sweep.write_text(yaml.safe_dump(config, sort_keys=False))
    return sweep


def timed_sweep(sweep: Path, results: Path, **options) -> tuple[float, float]:
    """(wall time of the whole sweep, summed wall time of its runs inside the workers)."""
    from pipelines.sweep import run

    start = time.perf_counter()
    outcome = run(sweep, results=results, **options)
    wall = time.perf_counter() - start
    if outcome.count("ok") != 16:
        raise RuntimeError(f"expected 16 ok runs: {outcome.describe()}")
    return wall, float(outcome.frame["wall [s]"].sum())


def compare(sweep: Path, root: Path, repeats: int, label: str) -> tuple:
    """Process pools of 1 and 2 workers, started with each sweep (as the command line does)."""
    times: dict[int, list[float]] = {1: [], 2: []}
    inside: dict[int, list[float]] = {1: [], 2: []}
    for k in range(repeats):
        for workers in (1, 2) if k % 2 == 0 else (2, 1):
            wall, busy = timed_sweep(sweep, root / f"{sweep.stem}-{workers}-{k}", workers=workers)
            times[workers].append(wall)
            inside[workers].append(busy)
    one, two = statistics.median(times[1]), statistics.median(times[2])
    note = (
        f"1 worker {min(times[1]):.1f}-{max(times[1]):.1f} s, "
        f"2 workers {min(times[2]):.1f}-{max(times[2]):.1f} s; summed time inside the runs "
        f"{statistics.median(inside[1]):.1f} s / {statistics.median(inside[2]):.1f} s"
    )
    return (f"16-run sweep, local process pool, {label}", one, two, one / two, note)


def compare_dask(sweep: Path, root: Path, repeats: int, label: str) -> tuple:
    """Local Dask clusters of 1 and 2 worker processes, started and warmed before the clock."""
    from distributed import LocalCluster

    medians = []
    for workers in (1, 2):
        with LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            address = cluster.scheduler_address
            timed_sweep(sweep, root / f"dask-warm-{workers}", scheduler=address)  # imports
            walls = [
                timed_sweep(sweep, root / f"dask-{workers}-{k}", scheduler=address)[0]
                for k in range(repeats)
            ]
        medians.append(statistics.median(walls))
    one, two = medians
    return (f"16-run sweep, local Dask cluster (warm workers), {label}", one, two, one / two,
            "after one warm-up sweep per cluster")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--variants", type=int, nargs="+", default=[1, 2], choices=range(1, 5),
        help="polynomial variants per run (the run's size), one table row each (default: 1 2)",
    )  # fmt: skip
    parser.add_argument("--dask", action="store_true", help="also time a local Dask cluster")
    args = parser.parse_args()
    from pipelines.sweep import plan

    rows = []
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for variants in args.variants:
            sweep = workspace(root, variants)
            plan(sweep, results=root / "warm-up")  # the parent's imports, outside the clock
            label = f"{variants} model{'s' if variants > 1 else ''} per run"
            rows.append(compare(sweep, root, args.repeats, label))
            if args.dask:
                rows.append(compare_dask(sweep, root, args.repeats, label))
    print(
        f"cores: {os.cpu_count()}; medians of {args.repeats} repeats; 1-minute load average "
        f"{load_before:.1f} before, {os.getloadavg()[0]:.1f} after (other work on the machine "
        "distorts the timings)\n"
    )
    print("| benchmark | 1 worker [s] | 2 workers [s] | speed-up | note |")
    print("| :--- | ---: | ---: | ---: | :--- |")
    for name, one, two, speedup, note in rows:
        print(f"| {name} | {one:.2f} | {two:.2f} | {speedup:.2f}x | {note} |")


if __name__ == "__main__":  # worker processes import this module: no work at import
    main()
