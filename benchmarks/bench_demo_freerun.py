"""The free run's cost to the demo (issue 29's target: at most 10 % of the demo's time).

Measured as a user pays it: ``hmid run configs/demo.yaml --force`` in fresh processes, with the
free run and without it (the same command with the ``freerun_blocks`` and ``freerun`` stages
left out: the report then has no free-run section), interleaved. Reported per variant (medians):

* the whole process's wall time; the free run's **cost** is the difference, as a share of the
  run with it (what the free run adds to the demo, overlap with the other stages included);
* the CPU time of the process and its workers (``RUSAGE_CHILDREN``): the same difference in
  CPU seconds, steadier than wall time on a loaded machine; and split, the main process's
  (which a quiet machine's wall time follows: the worker's work beside it is hidden as long as
  it ends first) and the worker's;
* the ``freerun`` stage's share of the stages' summed wall time (``timings.json``): the time
  the run's main process spends in the stage, which overlap with other stages hides, so it is
  given beside the cost, never alone.

``--cold``: every run in a fresh results folder (programs traced and compiled, nothing stored:
a clone's first run); otherwise one untimed warm-up run per variant first fills JAX's caches
and the stored programs. ``--root`` (repeatable) runs another checkout's code on the same
config, interleaved with this one's (e.g. ``main`` against a branch).

Run: ``.venv/bin/python benchmarks/bench_demo_freerun.py [--repeats 3] [--cold]
[--root PATH ...]``. Prints one Markdown row per root and variant, and the load.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
#: what each run says as it ends: its main process's CPU time and its workers' (reaped by then:
#: the pool's exit hook, registered later, runs first)
SAY_CPU = (
    "import atexit, resource, sys; "
    "u = lambda w: (lambda r: r.ru_utime + r.ru_stime)(resource.getrusage(w)); "
    "atexit.register(lambda: print(f'CPU {u(resource.RUSAGE_SELF):.3f} "
    "{u(resource.RUSAGE_CHILDREN):.3f}', file=sys.stderr)); "
)
#: the demo with its free-run stages left out (the report skips a missing free run)
WITHOUT = SAY_CPU + (
    "import pipelines.identify as i; "
    "i.STAGES = tuple(s for s in i.STAGES if not s.name.startswith('freerun')); "
    "from hmid.cli import entry; entry()"
)
WITH = SAY_CPU + "from hmid.cli import entry; entry()"


def run_once(root: Path, code: str, results: Path) -> dict:
    """One demo run of ``root``'s code: wall, CPU (with its workers) and stage times."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    command = [PY, "-c", code, "run", str(root / "configs" / "demo.yaml"), "--force",
               "--results", str(results)]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, check=True, capture_output=True, text=True, cwd=root, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    folder = Path(re.search(r"report: (.+)report\.html", done.stdout)[1])
    stages = json.loads((folder / "timings.json").read_text())["stages_s"]
    main, workers = (float(x) for x in re.search(r"CPU (\S+) (\S+)", done.stderr).groups())
    return {"wall": wall, "cpu": cpu, "main": main, "workers": workers,
            "stages": sum(stages.values()), "freerun": stages.get("freerun", 0.0)}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cold", action="store_true")
    parser.add_argument("--root", type=Path, action="append", default=[])
    args = parser.parse_args()
    roots = [ROOT, *args.root]
    variants = {"with": WITH, "without": WITHOUT}
    keep = Path(tempfile.mkdtemp(prefix="hmid-freerun-cost-"))
    found: dict[tuple, list[dict]] = {(r, v): [] for r in roots for v in variants}

    def results(root: Path, variant: str) -> Path:
        fresh = tempfile.mkdtemp(dir=keep) if args.cold else None
        return Path(fresh) if fresh else keep / f"{roots.index(root)}-{variant}"

    loads = [os.getloadavg()[0]]
    if not args.cold:
        for root in roots:
            for variant, code in variants.items():
                run_once(root, code, results(root, variant))
    for _ in range(args.repeats):
        for root in roots:
            for variant, code in variants.items():
                found[root, variant].append(run_once(root, code, results(root, variant)))
        loads.append(os.getloadavg()[0])
    table(found, roots, variants)
    print(
        f"\nload (1 min) {' -> '.join(f'{x:.1f}' for x in loads)}; "
        f"{'cold' if args.cold else 'warm'}, {args.repeats} repeats; runs in {keep}"
    )


def table(found: dict, roots: list[Path], variants: dict) -> None:
    """One Markdown row per root and variant (medians), and the cost's row per root."""
    print("| code | free run | wall (s) | CPU (s) | main's CPU (s) | worker's CPU (s) | stages (s) "
          "| freerun stage (s, share) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for root in roots:
        runs = {v: found[root, v] for v in variants}
        med = {v: {k: statistics.median(r[k] for r in runs[v]) for k in runs[v][0]}
               for v in variants}  # fmt: skip
        for variant in variants:
            m = med[variant]
            share = f"{m['freerun']:.2f}, {100 * m['freerun'] / m['stages']:.0f} %"
            print(f"| {root} | {variant} | {m['wall']:.2f} | {m['cpu']:.2f} | {m['main']:.2f} | "
                  f"{m['workers']:.2f} | {m['stages']:.2f} | "
                  f"{share if variant == 'with' else ''} |")  # fmt: skip
        pairs = [w["wall"] - o["wall"] for w, o in zip(runs["with"], runs["without"], strict=True)]
        cost = med["with"]["wall"] - med["without"]["wall"]
        cpu, main = (med["with"][k] - med["without"][k] for k in ("cpu", "main"))
        workers = med["with"]["workers"] - med["without"]["workers"]
        print(f"| {root} | cost | {cost:.2f} ({100 * cost / med['with']['wall']:.0f} %; pairs "
              f"{', '.join(f'{w:.2f}' for w in pairs)}) | {cpu:.2f} "
              f"({100 * cpu / med['with']['cpu']:.0f} %) | {main:.2f} "
              f"({100 * main / med['with']['main']:.0f} %) | {workers:.2f} | | |")  # fmt: skip


if __name__ == "__main__":
    main()
