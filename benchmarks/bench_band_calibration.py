"""The free run's band, calibrated? Its held-out coverage over simulated data sets.

A run reports one band per model and its coverage of the measured held-out position (nominal
90 %): one data set's, one seed's. Calibration is a property over replications, as the
coefficient intervals' is (``make calibration``). Here a shipped config's data set is simulated
again with other seeds (``configs/simulate/<name>.yaml``, its seed + 1 .. + R: the same rig,
references of the same kind, new noise and motion), each is run as the config runs it up to the
free runs (the stage cache under a temporary folder), and every exported model's held-out band
coverage is collected: its mean ± standard error over the data sets, its spread, and how many
fall within ± 5 points of the nominal; a band that no scale calibrates on the training blocks
is not drawn, and counted apart.

Run: ``.venv/bin/python benchmarks/bench_band_calibration.py [--replications 20]
[--config linear-motor --config demo] [--scale 1 --scale 3]``. Prints one Markdown row per
config and model. A linear-stage data set costs about 2 s, a demo one about 20 s, on one core.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import tempfile
from pathlib import Path
from unittest import mock

import yaml
from _band import band_coverage, exported

from hmid.portable.freerun import Calibration
from hmid.portable.freerun import run as freerun_run
from hmid.portable.freerun.band import FORCE

ROOT = Path(__file__).resolve().parents[1]
#: config -> its data set's simulation config (the shipped logs are that config's seed)
CONFIGS = {"linear-motor": "linear-motor", "demo": "demo"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replications", type=int, default=20)
    parser.add_argument("--config", action="append", choices=sorted(CONFIGS), default=None)
    parser.add_argument(
        "--scale",
        action="append",
        type=float,
        default=[],
        help="also the coverage with a disturbance force held at this scale",
    )
    args = parser.parse_args(argv)
    if args.replications < 2:
        parser.error("--replications must be at least 2")
    os.environ["HMID_WORKERS"] = "0"  # every free run in this process

    print("| config | model | data sets | mean ± s.e. | sd | min | max | within 85–95 % "
          "| no band (not calibrated) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.config or sorted(CONFIGS):
        found: dict[str, list[float]] = {}
        for r in range(1, args.replications + 1):
            for model, coverage in _replication(name, r, args.scale).items():
                found.setdefault(model, []).append(coverage)
        for model, every in found.items():
            values = [v for v in every if math.isfinite(v)]
            if len(values) < 2:
                print(f"| {name} | {model} | {len(values)} | | | | | | "
                      f"{len(every) - len(values)} of {len(every)} |")  # fmt: skip
                continue
            n, mean, sd = len(values), statistics.fmean(values), statistics.stdev(values)
            inside = sum(85.0 <= v <= 95.0 for v in values)
            print(
                f"| {name} | {model} | {n} | {mean:.1f} ± {sd / math.sqrt(n):.1f} | {sd:.1f} | "
                f"{min(values):.1f} | {max(values):.1f} | {inside} of {n} | "
                f"{len(every) - n} of {len(every)} |",
                flush=True,
            )
    return 0


def _replication(name: str, r: int, scales: list[float]) -> dict[str, float]:
    """Every exported model's held-out band coverage (%) on the data set of seed + ``r``, and
    with a disturbance force held at each of ``scales`` (its calibration replaced: what a
    scale known in advance gives, the spread that no calibration can remove)."""
    from hmid.experiment import load_experiment
    from hmid.simulate.datasets import load_dataset_config
    from hmid.simulate.write import write_dataset

    simulation = load_dataset_config(ROOT / "configs" / "simulate" / f"{CONFIGS[name]}.yaml")
    with tempfile.TemporaryDirectory(prefix="hmid-band-calibration-") as tmp:
        data = Path(tmp) / "data"
        write_dataset(simulation.model_copy(update={"seed": simulation.seed + r}), data)
        config_path = ROOT / "configs" / f"{name}.yaml"
        raw = yaml.safe_load(config_path.read_text())
        for entry in raw["logs"]:
            for key in ("path", "columns"):
                shipped = (config_path.parent / entry[key]).resolve()
                # the data set's logs and column maps are read from the new folder; a column map
                # of the config's own (the knee's) stays where it is
                moved = data / shipped.name
                entry[key] = str(moved if moved.exists() else shipped)
        path = Path(tmp) / f"{name}.yaml"
        path.write_text(yaml.safe_dump(raw))
        config = load_experiment(path)
        held, models = exported(config, Path(tmp) / "cache")
    out = {name: band_coverage(model, held, config.seed) for name, model in models}
    for scale in scales:
        fixed = Calibration(scale, float("nan"), 0, kind=FORCE)
        with mock.patch.object(freerun_run, "choose", lambda *_, fixed=fixed: fixed):
            out |= {f"{name} at force scale {scale:g}": band_coverage(model, held, config.seed)
                    for name, model in models}  # fmt: skip
    print(
        f"{name} data set {r}: " + ", ".join(f"{k} {v:.1f}" for k, v in out.items()),
        file=sys.stderr,
        flush=True,
    )
    return out


if __name__ == "__main__":
    sys.exit(main())
