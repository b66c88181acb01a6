"""The ``hmid`` command line: ``hmid <command> --help`` explains each command."""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from hmid.errors import HmidError

_DESCRIPTION = """\
hmid: system identification of soft fluidic actuators (the Hydro Muscle).

commands:
  simulate    generate a simulated data set (rig logs + ground truth) from a config
  relaxation  reproduce the thesis's Ch. 2 relaxation experiment (figure + numbers)
  summary     load, validate, denoise and summarise the logs named by an experiment config
"""


def _simulate(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from hmid.config import load_yaml_model
    from hmid.files import fresh_dir
    from hmid.simulate.dataset import DatasetConfig
    from hmid.simulate.write import write_dataset

    config = load_yaml_model(args.config, DatasetConfig)
    fresh_dir(args.out, replace=args.replace)  # fail before any work is done
    with tqdm(total=len(config.logs), desc="simulating", unit="log", disable=args.quiet) as bar:

        def step(name: str) -> None:
            bar.set_postfix_str(name)
            bar.update()

        paths = write_dataset(config, args.out, replace=args.replace, progress=step)
    print(f"wrote {len(paths)} logs with ground truth and column maps to {args.out}")
    return 0


def _relaxation(args: argparse.Namespace) -> int:
    from hmid.files import fresh_dir, write_json
    from hmid.simulate.relaxation import RelaxationParams, plot_relaxations, relax

    params = RelaxationParams(P0=args.p0)
    out = fresh_dir(args.out, replace=args.replace)
    results = [relax(params, valve) for valve in ("instant", "ramp")]
    plot_relaxations(results, out / "relaxation.png")
    summary = {
        "params": params.model_dump(),
        "cases": {
            r.valve: {
                "t_equilibrium_ms": r.t_eq * 1e3,
                "peak_speed_m_s": float(abs(r.v).max()),
                "peak_pressure_after_opening_kPa": float(r.P[1:].max() / 1e3),
            }
            for r in results
        },
    }
    write_json(out / "relaxation.json", summary)
    for r in results:
        print(f"{r.valve:>7} opening: equilibrium after {r.t_eq * 1e3:.1f} ms, "
              f"peak speed {abs(r.v).max():.3f} m/s")  # fmt: skip
    print(f"figure and numbers in {out}")
    return 0


def _summary(args: argparse.Namespace) -> int:
    from pipelines.summary import run

    run_dir = run(Path(args.config), results=Path(args.results), quiet=args.quiet)
    print(f"report: {run_dir / 'summary.md'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hmid", description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = parser.add_subparsers(dest="command", metavar="command", required=True)

    p = sub.add_parser(
        "simulate",
        help="generate a simulated data set from a config",
        description="Simulate every log named in a data-set config (see configs/simulate/) and "
        "write the data files, their column maps and a ground-truth JSON per log. The output "
        "folder must be new or empty unless --replace is given.",
    )
    p.add_argument("config", type=Path, help="data-set config (YAML)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--replace", action="store_true", help="regenerate into a non-empty folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_simulate)

    p = sub.add_parser(
        "relaxation",
        help="reproduce the thesis's Ch. 2 relaxation (10 kg, valve opened instantly or 1 %%/ms)",
        description="Simulate the Ch. 2 relaxation experiment for both valve cases and write "
        "relaxation.png (elongation, velocity, acceleration, pressure) and relaxation.json.",
    )
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--p0", type=float, default=5.0e4, help="pre-stretch gauge pressure, Pa")
    p.add_argument("--replace", action="store_true", help="write into a non-empty folder")
    p.set_defaults(func=_relaxation)

    p = sub.add_parser(
        "summary",
        help="load, validate, denoise and summarise an experiment's logs",
        description="Load every log of an experiment config, validate it, smooth it, estimate "
        "velocity and acceleration, and write a summary (Markdown, JSON, figure) to a new run "
        "folder results/<experiment>/<run-id>/.",
    )
    p.add_argument("config", type=Path, help="experiment config (YAML), e.g. configs/demo.yaml")
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_summary)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"hmid: warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    warnings.showwarning = _show_warning  # one line per finding, not a source excerpt
    try:
        return args.func(args)
    except HmidError as err:
        print(f"hmid {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
