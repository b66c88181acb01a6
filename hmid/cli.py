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
  simulate    generate a simulated data set (rig logs + ground truth, or the thesis's Ch. 2
              relaxation curves and figure) from a config
  run         run an identification experiment: friction, model families, held-out
              comparison, report (HTML + Markdown + JSON + figures)
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
    print(f"wrote {len(paths)} simulated entries with their ground truth to {args.out}")
    return 0


def _run(args: argparse.Namespace) -> int:
    from pipelines.identify import run

    run_dir, metrics = run(Path(args.config), results=Path(args.results), force=args.force)
    best = metrics["held_out"][0]
    print(f"best model: {best['model']}, held-out RMSE {best['rmse (held-out)']:.4g} N (one-step)")
    print(f"report: {run_dir / 'report.html'}")
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
        description="Simulate every entry of a data-set config (see configs/simulate/): rig logs "
        "(data files, their column maps, a ground-truth JSON per log) and Ch. 2 relaxation runs "
        "(curves, figure, numbers; configs/simulate/ch2-relaxation.yaml). The output folder "
        "must be new or empty unless --replace is given.",
    )
    p.add_argument("config", type=Path, help="data-set config (YAML)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--replace", action="store_true", help="regenerate into a non-empty folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_simulate)

    p = sub.add_parser(
        "run",
        help="run an identification experiment and write its report",
        description="Run the identification study of an experiment config: load and validate "
        "the logs, denoise, identify friction from the free-fall logs, reconstruct the muscle "
        "force, fit every configured model family on the training rows, score all of them on "
        "the held-out rows, and write results/<experiment>/<run-id>/ (report.html, report.md, "
        "metrics.json, tables/, figures/, manifest.json, config.yaml). Stage results are cached "
        "by content hash; --force recomputes everything.",
    )
    p.add_argument("config", type=Path, help="experiment config (YAML), e.g. configs/demo.yaml")
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--force", action="store_true", help="recompute every stage, ignore the cache")
    p.set_defaults(func=_run)

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
