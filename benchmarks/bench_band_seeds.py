"""How much of a band's held-out coverage is its seed's: the free run's band over many seeds.

A run reports one band per model, from one seed (the config's): 14 draws of the coefficients
and of the disturbance, calibrated on the training blocks, its coverage of the measured
held-out position checked against the nominal 90 %. That coverage is one realisation of a
Monte Carlo estimate. Here each shipped config is analysed up to its export once (the stage
cache under a temporary folder), then every exported model's free run (the run's own
``hmid.pipeline.stages.free_run_or_why``, on the same rows) is repeated with seeds 0..K-1, and
the held-out coverage's mean and standard deviation over the seeds are printed beside the
config seed's: the mean says whether the band is calibrated, the spread how far one seed's
number may fall from it.

Run: ``.venv/bin/python benchmarks/bench_band_seeds.py [--seeds 40] [--draws 14]
[--config linear-motor ...]``. Prints one Markdown row per model. On one core it costs about
0.4 s per model and seed at 14 draws (the demo's models, their bands calibrated).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import tempfile
from pathlib import Path

from _band import band_coverage, exported

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ("demo", "knee", "linear-motor")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--draws", type=int, default=None, help="default: the run's")
    parser.add_argument("--config", action="append", choices=CONFIGS, default=None)
    args = parser.parse_args(argv)
    if args.seeds < 2:
        parser.error("--seeds must be at least 2")
    os.environ["HMID_WORKERS"] = "0"  # every free run in this process

    from hmid.experiment import load_experiment
    from hmid.pipeline import stages

    draws = args.draws or stages.FREE_RUN_DRAWS
    print(f"| config | model | seed {{config}} | mean over {args.seeds} seeds | sd | min | max |")
    print("|---|---|---|---|---|---|---|")
    for name in args.config or CONFIGS:
        config = load_experiment(ROOT / "configs" / f"{name}.yaml")
        with tempfile.TemporaryDirectory(prefix="hmid-band-seeds-") as tmp:
            held, models = exported(config, Path(tmp))
        for model_name, model in models:
            own = band_coverage(model, held, config.seed, draws)
            found_by_seed = [band_coverage(model, held, seed, draws) for seed in range(args.seeds)]
            found_by_seed = [v for v in found_by_seed if math.isfinite(v)]
            if len(found_by_seed) < 2:  # a band no scale calibrates is not drawn
                print(f"| {name} | {model_name} | no band (not calibrated) | | | | |")
                continue
            print(
                f"| {name} | {model_name} | {own:.1f} | "
                f"{statistics.fmean(found_by_seed):.1f} | {statistics.stdev(found_by_seed):.1f}"
                f" | {min(found_by_seed):.1f} | {max(found_by_seed):.1f} |",
                flush=True,
            )
    print(f"\n{draws} draws, level {100 * stages.FREE_RUN_LEVEL:.0f} %", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
