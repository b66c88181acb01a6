"""The ``hmid`` command line: ``hmid <command> --help`` explains each command."""

from __future__ import annotations

import argparse
import errno
import gc
import os
import signal
import sys
import threading
import warnings
from pathlib import Path

from tqdm import tqdm

from hmid.errors import ConfigError, HmidError, HmidWarning
from hmid.files import fresh_dir
from hmid.pipeline.compilation import use_compilation_cache
from hmid.progress import VARIABLE, Progress
from hmid.runs import list_runs, remove_runs
from hmid.workers import Tasks, allow_workers

_DESCRIPTION = """\
hmid: system identification of soft fluidic actuators (the Hydro Muscle).

commands:
  simulate    generate a simulated data set (rig logs + ground truth, or the thesis's Ch. 2
              relaxation curves and figure) from a config
  run         run an identification experiment on any declared rig: friction, model
              families, held-out comparison, the loop, report (HTML + Markdown + JSON + figures)
  summary     load, validate, denoise and summarise the logs named by an experiment config
  sweep       run one experiment over many logs or settings (process pool or Dask cluster)
              and compare the runs in one table
  blind       test the loop blind on simulated logs with undeclared effects
  control     model-based control in simulation: PD alone vs the identified model's
              feed-forward + PD, on proportional and on/off valves, and its robustness
  runs        list run folders with their status (complete, failed, running, stale); remove
              the failed ones on request
"""


def _simulate(args: argparse.Namespace) -> int:

    from hmid.simulate.datasets import load_dataset_config
    from hmid.simulate.write import write_dataset

    config = load_dataset_config(args.config)
    fresh_dir(args.out, replace=args.replace)  # fail before any work is done
    with tqdm(total=len(config.logs), desc="simulating", unit="log", disable=args.quiet) as bar:

        def step(name: str) -> None:
            bar.set_postfix_str(name)
            bar.update()

        paths = write_dataset(config, args.out, replace=args.replace, progress=step)
    print(f"wrote {len(paths)} simulated entries with their ground truth to {args.out}")
    return 0


def _run(args: argparse.Namespace) -> int:
    from hmid.io.units import UNIT_CACHE_VARIABLE

    if Path(args.results).is_file():  # said before anything is made beside it
        raise NotADirectoryError(20, "Not a directory", str(args.results))
    for what, path in (("--results", args.results), ("config", args.config)):
        _utf8(what, Path(path).resolve())  # refused now, not after the work
    use_compilation_cache(Path(args.results) / ".jax-cache")  # before a worker starts
    os.environ.setdefault(UNIT_CACHE_VARIABLE, str(Path(args.results) / ".unit-cache"))
    allow_workers()  # this program's main module is guarded: a spawned worker may import it
    progress = Progress(quiet=args.quiet)
    if progress.bars:  # before a worker starts: its bars (the SLS posterior's) read it
        os.environ[VARIABLE] = "1"
    # the worker starts on what every run's families need while this process imports the same
    tasks = Tasks().start(("hmid.families",))
    from pipelines.identify import run, worker_imports

    tasks.start(worker_imports(Path(args.config)))

    run_dir, metrics = run(
        Path(args.config),
        results=Path(args.results),
        force=args.force,
        strict=args.strict,
        progress=progress,
    )
    print(console_summary(metrics))
    print(f"report: {run_dir / 'report.html'}")
    return 0


def _utf8(what: str, path: Path) -> None:
    """A ConfigError if ``path`` cannot be written as UTF-8 (a name in another encoding): the
    run folder's manifest, report and links are UTF-8 text."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        shown = os.fsencode(path).decode("utf-8", "backslashreplace")
        raise ConfigError(
            f"{what} {shown}: the path is not valid UTF-8; rename it or choose another folder"
        ) from None


def console_summary(metrics: dict) -> str:
    """What a run found, in a few lines: the best model with its equation, parameters and
    intervals, its margin over the runner-up, its free run and the rows it saw; the loop's
    verdict with what it added and its before and after (one-step held-out RMSE); the sign
    check."""
    from hmid.pipeline.answer import console_lines

    unit = metrics["explained"]["unit"]
    best = metrics["held_out"][0]
    if metrics.get("answer"):
        lines = console_lines(metrics["answer"], unit, metrics["explained"]["name"],
                              best["error kind"])  # fmt: skip
    else:
        rmse = best["rmse (held-out)"]
        rmse_text = "n/a" if rmse is None else f"{rmse:.4g} {unit}"
        lines = [
            f"best model: {best['model']}, held-out RMSE {rmse_text} of "
            f"{metrics['explained']['name']} ({best['error kind']})"
        ]
    loop = metrics.get("loop")
    if loop is not None:
        added = ", ".join(e["name"] for e in loop["effects"])
        added = f"added {added}" if added else "nothing added"
        before, after = loop["held_out_before"]["rmse"], loop["held_out_after"]["rmse"]
        lines.append(
            f"loop on {loop['base']}: {loop['verdict']} ({added}); held-out RMSE "
            f"{loop['base']} {before:.4g} -> {loop['after']} {after:.4g} {unit} (one-step)"
        )
        lines += [f"  {line}" for line in loop.get("final_model", ())]
    findings = metrics.get("sign_findings") or []
    if findings:
        names = ", ".join(f"{f['model']}: {f['parameter']}" for f in findings)
        lines.append(f"sign check: {len(findings)} parameter(s) with an impossible sign ({names})")
    return "\n".join(lines)


def _summary(args: argparse.Namespace) -> int:
    from pipelines.summary import run

    run_dir = run(Path(args.config), results=Path(args.results))
    print(f"report: {run_dir / 'summary.md'}")
    return 0


def _sweep(args: argparse.Namespace) -> int:

    from hmid.sweep import execute
    from pipelines.sweep import identify, plan

    sweep = plan(
        Path(args.config),
        results=Path(args.results),
        force=args.force,
        retry_failed=args.retry_failed,
    )
    total = len(sweep.pending) if args.limit is None else min(args.limit, len(sweep.pending))
    with tqdm(total=total, desc=f"sweep {sweep.sweep.name}", unit="run", disable=args.quiet) as bar:

        def step(record) -> None:
            bar.set_postfix_str(f"{record.run_id} {record.status}")
            bar.update()

        try:
            outcome = execute(
                sweep,
                identify,
                workers=args.workers,
                scheduler=args.scheduler,
                limit=args.limit,
                progress=step,
            )
        except KeyboardInterrupt as err:
            kept, said = sweep.folder / "done", str(err) or "interrupted"
            print(f"\nhmid sweep: {said}; finished runs are kept ({kept}): run the same "
                  "command again to resume", file=sys.stderr)  # fmt: skip
            return 128 + getattr(err, "signum", signal.SIGINT)
    print(outcome.describe())
    print(f"table: {outcome.markdown} (CSV: {outcome.table})")
    return 1 if outcome.count("failed") else 0


def _blind(args: argparse.Namespace) -> int:

    from hmid.blind import load_suite, plan_cases
    from hmid.report.markdown import markdown_table
    from pipelines.blind import run

    total = len(plan_cases(load_suite(args.config)))
    with tqdm(total=total, desc="blind suite", unit="case", disable=args.quiet) as bar:

        def step(row) -> None:
            bar.set_postfix_str(f"{row['case_id']}: {row.get('added') or 'none'}")
            bar.update()

        run_dir, _, targets = run(
            Path(args.config), results=Path(args.results), workers=args.workers, progress=step
        )
    print(markdown_table(targets))
    print(f"table: {run_dir / 'blind.md'}")
    return 0 if targets["met"].all() else 1


def _control(args: argparse.Namespace) -> int:
    from pipelines.control import run

    say = None if args.quiet else (lambda what: print(f"hmid control: {what}", file=sys.stderr))
    run_dir, metrics = run(Path(args.config), results=Path(args.results), progress=say)
    said = {True: "met", False: "not met", None: "n/a"}
    for name, met in metrics["targets"].items():
        if isinstance(met, dict):  # robustness by controller and valves
            print(f"{name}: " + "; ".join(f"{k} {said[v]}" for k, v in met.items()))
        else:
            print(f"{name}: {said[met]}")
    print(f"report: {run_dir / 'report.html'}")
    return 0


def _population(args: argparse.Namespace) -> int:
    from pipelines.population import run

    say = (lambda _m: None) if args.quiet else (lambda m: print(f"hmid population: {m}"))
    run_dir, metrics = run(
        Path(args.config),
        results=Path(args.results),
        force=args.force,
        workers=args.workers,
        scheduler=args.scheduler,
        progress=say,
    )
    met = metrics["exponents_within_interval"]
    print(f"exponents within their intervals: {met} of {metrics['exponents']}")
    for key in (
        "loo_median_specs_over_own",
        "loo_median_specs_over_exact_law",
        "loo_median_specs_over_one_other",
        "loo_coverage",
    ):
        if key in metrics:
            print(f"{key}: {metrics[key]:.3g}")
    print(f"report: {run_dir / 'report.html'}")
    return 0


def _runs(args: argparse.Namespace) -> int:
    entries = list_runs(Path(args.root))
    if args.failed or args.remove_failed:
        entries = [e for e in entries if e.status in ("failed", "stale", "no manifest")]
    for entry in entries:
        error = f"  {entry.error}" if entry.error else ""
        print(f"{entry.status:<12} {entry.started or '-':<25} {entry.path}{error}")
    if args.remove_failed:
        removed = remove_runs(entries)
        print(f"removed {len(removed)} failed or stale run folder(s) under {args.root}")
    elif not entries:
        print(f"no {'failed ' if args.failed else ''}run folders under {args.root}")
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
        description="Run the identification study of an experiment config on the rig its "
        "rig section declares: load and validate the logs, denoise both sides of the balance "
        "alike, identify friction from free-fall logs where the rig takes it from them, fit "
        "every configured model family on the training rows, score all of them on the held-out "
        "rows, close the loop on the model loop.base names, check every physically positive "
        "parameter's sign, and write results/<experiment>/<run-id>/ (report.html, report.md, "
        "metrics.json, tables/, figures/, manifest.json, config.yaml). Stage results are cached "
        "by content hash; --force recomputes everything.",
    )
    p.add_argument("config", type=Path, help="experiment config (YAML), e.g. configs/demo.yaml")
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--force", action="store_true", help="recompute every stage, ignore the cache")
    p.add_argument(
        "--strict",
        action="store_true",
        help="a finding about the data (implausible units, stuck or clipped sensors, logs that "
        "give no rows) or a parameter's sign is an error (exit 2), not a warning",
    )
    p.add_argument(
        "--quiet", action="store_true", help="no progress (in a log: no line per stage either)"
    )
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
    p.set_defaults(func=_summary)

    p = sub.add_parser(
        "sweep",
        help="run one experiment over many logs or settings and compare the runs",
        description="Run the identification study once per run of a sweep config (see "
        "configs/sweeps/): a base experiment config and, per run, overrides at dotted keys, "
        "listed under runs: or as a grid:. Runs execute in a local process pool, or on a Dask "
        "cluster when the config's executor or --scheduler names one. Writes "
        "results/<sweep>/: runs/<run id>/ (each run's config and report), done/<run id>.json "
        "(each finished run's record) and sweep.csv + sweep.md (one row per run: overrides, "
        "status, best model, held-out RMSE per model, friction). A failed run is reported in "
        "the table and does not stop the others; runs finished before are skipped (an "
        "interrupted sweep resumes). Exit status 1 when a run failed.",
    )
    p.add_argument("config", type=Path, help="sweep config (YAML), see configs/sweeps/")
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--workers", type=int, help="local worker processes (default: the config's)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--limit", type=int, help="run at most this many of the pending runs")
    p.add_argument("--retry-failed", action="store_true", help="run failed runs again")
    p.add_argument("--force", action="store_true", help="run every run again, ignore the cache")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_sweep)

    p = sub.add_parser(
        "blind",
        help="test the loop blind: simulated logs with undeclared effects",
        description="Run a blind suite (see configs/blind/): for every simulator effect, "
        "strength and seed, simulate logs with the effect switched on but not declared, run the "
        "standard stages through the loop, and record which effect the loop names first. Clean "
        "logs are the negative controls. Writes results/<suite>/<run-id>/: blind.md and "
        "blind.csv (effect x strength: right first, alone or among indistinguishable rivals, "
        "confidently wrong, effects added, 'unexplained structure', held-out RMSE before/after "
        "on rows no decision saw), targets.csv (the pass marks), outcomes.csv and "
        "cases/<case>.json. Exit status 1 when a pass mark is missed.",
    )
    p.add_argument("config", type=Path, help="suite config (YAML), e.g. configs/blind/ci.yaml")
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--workers", type=int, help="local worker processes (default: the config's)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_blind)

    p = sub.add_parser(
        "control",
        help="model-based control of the simulated rig with an identified model",
        description="Load the model a run of hmid run identified (the config's model.run: a "
        "run folder or an experiment's folder, its newest complete run; run `make demo` "
        "first for configs/control/muscle.yaml), tune the PD set-point tracker on the model's "
        "linearisation (python-control), track steps both ways, a sine and a gait-like cycle "
        "with PD alone and with the model's inverse dynamics as feed-forward + the same PD, on "
        "proportional and on/off valves, then on plants drawn from the model's posterior and "
        "with undeclared effects; write results/<name>/<run-id>/ (report.html, report.md, "
        "metrics.json, tables/, figures/, manifest.json, config.yaml).",
    )
    p.add_argument("config", type=Path, help="control config (YAML), configs/control/*.yaml")
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_control)

    p = sub.add_parser(
        "population",
        help="fit a generic muscle model over muscles of different builds",
        description="Identify every muscle of a population config (configs/population/) with "
        "the standard pipeline (a sweep: the muscles in parallel, runs finished before reused), "
        "fit the hierarchical scaling law from the muscles' specifications to their SLS "
        "parameters (NumPyro NUTS), predict each build's model (models/<muscle>.predicted.json) "
        "and leave each muscle out to check the prediction. Writes results/<name>/<run-id>/.",
    )
    p.add_argument(
        "config", type=Path, help="population config, e.g. configs/population/muscles.yaml"
    )
    p.add_argument("--results", default="results", help="results root folder (default: results)")
    p.add_argument("--force", action="store_true", help="identify every muscle again")
    p.add_argument("--workers", type=int, help="local worker processes (default: the config's)")
    p.add_argument("--scheduler", help="a Dask scheduler's address for the muscles' runs")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=_population)

    p = sub.add_parser(
        "runs",
        help="list run folders and their status; remove failed ones",
        description="List every run folder under a results root (or one experiment's or "
        "sweep's folder) with its manifest's status: complete, failed (with its one-line "
        "error), running, stale (still 'running' but its process is gone: killed) or no "
        "manifest. --remove-failed deletes the failed, stale and manifest-less folders; "
        "complete runs are never touched.",
    )
    p.add_argument("root", nargs="?", default="results", help="results folder (default: results)")
    p.add_argument("--failed", action="store_true", help="list only failed or stale runs")
    p.add_argument(
        "--remove-failed", action="store_true", help="delete failed and stale run folders"
    )
    p.set_defaults(func=_runs)

    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """hmid's findings as ``hmid: warning:``; a library's own warning in one line that says
    whose it is, so it is never read as one of hmid's findings."""
    text = " ".join(str(message).split())
    if issubclass(category, HmidWarning):
        print(f"hmid: warning: {text}", file=sys.stderr)
        return
    parts = Path(filename).parts
    package = parts[parts.index("site-packages") + 1] if "site-packages" in parts else None
    origin = package or ("hmid" if "hmid" in parts else Path(filename).name)
    print(f"hmid: note from {origin} ({category.__name__}): {text}", file=sys.stderr)


class _Stopped(KeyboardInterrupt):
    """The command was asked to stop by a signal: unwound as Ctrl-C is (a run folder is marked
    failed), said in one line, and the exit status is 128 + the signal's number."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        how = "interrupted (Ctrl-C)" if signum == signal.SIGINT else "terminated (SIGTERM)"
        super().__init__(how)


def _stop(signum: int, frame) -> None:
    signal.signal(signum, signal.SIG_DFL)  # a second one ends the program at once
    raise _Stopped(signum)


def _stopped_by(err: BaseException | None) -> _Stopped | None:
    """The signal behind ``err``: itself, or one that a library turned into another error on
    its way out (e.g. an interrupted write said as an OSError)."""
    while err is not None:
        if isinstance(err, _Stopped):
            return err
        if isinstance(err, KeyboardInterrupt):
            return _Stopped(signal.SIGINT)
        err = err.__context__
    return None


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    warnings.showwarning = _show_warning  # one line per finding, not a source excerpt
    handlers = {}
    if threading.current_thread() is threading.main_thread():  # where Python runs handlers
        handlers = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
        for signum in handlers:
            signal.signal(signum, _stop)
    try:
        return args.func(args)
    except (HmidError, OSError, KeyboardInterrupt) as err:
        stopped = _stopped_by(err)
        if stopped is not None:
            print(
                f"hmid {args.command}: {stopped}; a run folder it made is marked failed "
                "(hmid runs --failed lists them), cached stages are kept",
                file=sys.stderr,
            )
            return 128 + stopped.signum
        if isinstance(err, KeyboardInterrupt):
            raise
        what = err if isinstance(err, HmidError) else environment_message(err, args)
        print(f"hmid {args.command}: error: {what}", file=sys.stderr)
        return 2
    finally:
        if "hmid.workers" in sys.modules:  # before the interpreter's exit, which would join them
            sys.modules["hmid.workers"].shutdown()
        for signum, handler in handlers.items():
            signal.signal(signum, handler)


def environment_message(err: OSError, args: argparse.Namespace) -> str:
    """One line for an OS failure: the path, what happened, and the fix."""
    path = err.filename or getattr(args, "results", None) or "?"
    what = err.strerror or type(err).__name__
    results = getattr(args, "results", "results")
    fixes: dict[int | None, str] = {
        errno.EACCES: f"make it writable or choose another folder with --results (now {results})",
        errno.EPERM: f"make it writable or choose another folder with --results (now {results})",
        errno.EROFS: "the file system is read-only: choose another folder with --results",
        errno.ENOSPC: f"free disk space (stage caches live in {results}/<experiment>/.cache and "
        "may be deleted) and run the same command again",
        errno.EDQUOT: "free disk space or raise the quota, then run the same command again",
        errno.ENOTDIR: "a part of this path is a file: --results must name a folder",
        errno.EEXIST: "a file is in the way: --results must name a folder",
        errno.EISDIR: "this is a folder where a file is expected: give the file's path",
        errno.ENOENT: "the path does not exist: check it",
    }
    fix = fixes.get(err.errno, "check the path and the machine's state, then run again")
    return f"{path}: {what.lower()}; {fix}"


def entry() -> None:
    """The ``hmid`` program: :func:`main`, its status the program's. What a command made is
    then frozen out of the garbage collector (:func:`gc.freeze`): the interpreter's last
    collections would walk every object a run loaded (1.2-3.5 s after the demo, by the
    machine's load; 0.3 s frozen) only to find what the process's end frees anyway. Exit
    handlers run and modules are torn down as usual."""
    code = main()

    gc.freeze()
    raise SystemExit(code)


if __name__ == "__main__":
    entry()
