"""The loop's cost per candidate effect: each candidate's screen, beside the fixed part.

Run: ``.venv/bin/python benchmarks/bench_loop.py [--repeats 3]`` (about a minute).

The demo experiment (``configs/demo.yaml``: 75 s of dynamic log at 1 kHz, the SLS base) is
analysed up to its fit stage once (the stage cache under a temporary folder), then the loop stage
(``pipeline.stages.loop`` with the rig's whole candidate library, one round: the demo's data add
no effect) runs ``--repeats`` times in this process, after a warm-up run, with no worker (each
screen's own cost; ``hmid run`` shares the screens with one, see ``hmid.loop.parallel``). Each
candidate's cost is the wall time of its screen (``hmid.loop.screen.screen``, timed by wrapping
the loop's reference to it: the candidate fitted and tested with the model, its parameter
profiled); the
fixed part is the rest of the stage (the base's profile, cross-validation folds, diagnostics).
Medians over the repeats. Issue 14's target is ≤ 1 s per 40 s of log for 7 candidates and one
round: the table gives every candidate's cost per 40 s, so any 7 can be added up, and the
cheapest, dearest and mean seven. A second round screens the candidates left again, so it costs
about the sum of theirs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "configs" / "demo.yaml"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    os.environ["HMID_WORKERS"] = "0"  # every screen in this process, timed
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    from hmid.experiment import load_experiment
    from hmid.loop import parallel
    from hmid.pipeline import stages
    from pipelines.identify import analyse

    config = load_experiment(DEMO)
    with tempfile.TemporaryDirectory(prefix="hmid-loop-") as tmp:
        artifacts = analyse(config, ("load", "split", "fit"), Path(tmp))
    seconds = sum(
        float(entry.log["t"][-1] - entry.log["t"][0])
        for entry in artifacts["load"].values()
        if entry.role == "dynamic"
    )
    screens: dict[str, list[float]] = {}
    screen = parallel.screen

    def timed(current, candidate, signals, confidence):
        start = time.perf_counter()
        found = screen(current, candidate, signals, confidence)
        screens.setdefault(candidate.name, []).append(time.perf_counter() - start)
        return found

    def run() -> float:
        start = time.perf_counter()
        stages.loop(config, artifacts["split"], artifacts["fit"])
        return time.perf_counter() - start

    run()  # compiles the Maxwell-arm scan
    parallel.screen = timed
    try:
        walls = [run() for _ in range(args.repeats)]
    finally:
        parallel.screen = screen
    costs = {name: statistics.median(times) for name, times in screens.items()}
    total = statistics.median(walls)
    fixed = statistics.median(
        wall - sum(times[i] for times in screens.values()) for i, wall in enumerate(walls)
    )
    per_40 = 40.0 / seconds
    ordered = sorted(costs.values())
    print(
        f"_Demo, {seconds:.0f} s of dynamic log, {len(costs)} candidates, one round; medians of "
        f"{args.repeats} runs; per 40 s = seconds x 40 / log seconds._\n"
    )
    print("| part of the loop stage | seconds | per 40 s of log |")
    print("|---|---:|---:|")
    print(f"| fixed part (base profile, folds, diagnostics) | {fixed:.2f} | {fixed * per_40:.2f} |")
    for name, cost in costs.items():
        print(f"| screen of {name} | {cost:.3f} | {cost * per_40:.3f} |")
    print(f"| whole stage, {len(costs)} candidates | {total:.2f} | {total * per_40:.2f} |")
    seven = {
        "the 7 cheapest": sum(ordered[:7]),
        "the 7 dearest": sum(ordered[-7:]),
        "7 at the mean cost": 7 * statistics.mean(ordered),
    }
    for label, cost in seven.items():
        print(f"| fixed part + {label} | {fixed + cost:.2f} | {(fixed + cost) * per_40:.2f} |")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
