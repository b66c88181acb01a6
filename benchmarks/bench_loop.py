"""The loop's cost per candidate effect: what each candidate adds to a round, beside the fixed part.

Run: ``.venv/bin/python benchmarks/bench_loop.py [--repeats 3]`` (about two minutes).

The demo experiment (``configs/demo.yaml``: 75 s of dynamic log at 1 kHz, the SLS base) is
analysed up to its fit stage once (the stage cache under a temporary folder), then the loop stage
(``pipeline.stages.loop``, one round: the demo's data add no effect) runs in this process with
``loop.candidates`` set to none (the fixed part: the base's profile, cross-validation folds,
diagnostics), to each candidate of the rig's library alone, and to the whole library; every
configuration ``--repeats`` times, interleaved, medians. A candidate's cost is its run less the
fixed part. Issue 14's target is ≤ 1 s per 40 s of log for 7 candidates and one round; the table
gives the fixed part and each candidate per 40 s of log, so any 7 can be added up, and the
whole library as measured. A second round screens the candidates left, so it costs about the sum
of their costs again.
"""

from __future__ import annotations

import argparse
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
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    from hmid.experiment import load_experiment
    from hmid.loop import Setting
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
    names = config.loop.candidate_names(Setting.of(config.rig))
    cases = {"(none: the fixed part)": (), **{n: (n,) for n in names}, "(all)": names}

    def run(candidates: tuple[str, ...]) -> None:
        spec = config.loop.model_copy(update={"candidates": candidates})
        stages.loop(config.model_copy(update={"loop": spec}), artifacts["split"], artifacts["fit"])

    run(())  # compiles the Maxwell-arm scan
    walls: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(args.repeats):
        for name, candidates in cases.items():
            start = time.perf_counter()
            run(candidates)
            walls[name].append(time.perf_counter() - start)
    median = {name: statistics.median(w) for name, w in walls.items()}
    fixed = median["(none: the fixed part)"]
    per_40 = 40.0 / seconds
    costs = {n: max(median[n] - fixed, 0.0) for n in names}
    cheapest, dearest = sorted(costs.values())[:7], sorted(costs.values())[-7:]
    print(
        f"_Demo, {seconds:.0f} s of dynamic log, one round; medians of {args.repeats} "
        "interleaved repeats; per 40 s = seconds x 40 / log seconds._\n"
    )
    print("| loop run | seconds | per 40 s of log | candidate's own cost per 40 s |")
    print("|---|---:|---:|---:|")
    for name in cases:
        own = f"{costs[name] * per_40:.3f}" if name in costs else ""
        print(f"| {name} | {median[name]:.2f} | {median[name] * per_40:.2f} | {own} |")
    print(
        f"| 7 candidates (fixed + the 7 cheapest / the 7 dearest / 7 x the mean) | | "
        f"{(fixed + sum(cheapest)) * per_40:.2f} / {(fixed + sum(dearest)) * per_40:.2f} / "
        f"{(fixed + 7 * statistics.mean(costs.values())) * per_40:.2f} | |"
    )
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
