"""The identification stages: pure functions of the experiment config and upstream artifacts.

load -> denoise -> friction -> signals -> split -> fit -> compare -> loop. Each returns plain data
(logs, estimates, signals, fitted models, score tables); files are written elsewhere.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hmid.balance import RigSection, Signals
from hmid.denoise import Piece, check_time_base, denoise_log, pieces
from hmid.errors import ConfigError, FitError, HmidWarning, LogError
from hmid.experiment import ExperimentConfig, log_units
from hmid.families import FitContext, FitData, Fitted
from hmid.files import sha256
from hmid.io import Log, load_column_map, read_log
from hmid.io import plausibility as p
from hmid.io.plausibility import no_rows, outliers
from hmid.metrics import score
from hmid.pipeline.fits import FIT_ERRORS, Fits, fit_or_fail
from hmid.pipeline.runner import Pending
from hmid.split import validation_masks
from hmid.summary import LogSummary, summarize
from hmid.workers import Tasks, beside

if TYPE_CHECKING:
    from hmid.portable import Model
    from hmid.portable.freerun import FreeRun, FreeRunRows


@dataclass(frozen=True)
class LoadedLog:
    name: str
    role: str
    log: Log


def log_name(path) -> str:
    return path.stem


def load(config: ExperimentConfig) -> dict[str, LoadedLog]:
    """Read and validate every log (SI units, flags kept); channels the rig declares with
    ``sign: -1`` are negated, so that every later stage sees the rig's convention."""
    out: dict[str, LoadedLog] = {}
    flips = {c: s.sign for c, s in config.rig.channels.items() if s.sign < 0}
    for entry in config.logs:
        path = config.resolve(entry.path)
        name = log_name(path)
        if name in out:
            raise ConfigError(f"two logs are named {name!r}; log file names must be unique")
        with warnings.catch_warnings():
            if config.denoise.split_gaps_s is not None:  # split there, not bridged: said in
                warnings.filterwarnings("ignore", ".*gap", HmidWarning)  # the pieces table
            log = read_log(path, load_column_map(config.resolve(entry.columns)))
        flipped = {c: -log[c] for c in flips if c in log}
        if flipped:
            log = log.with_channels(None, **flipped)
        _no_absurd_sample(log, path, _read_channels(config, entry.role))
        out[name] = LoadedLog(name, entry.role, log)
    return out


def _read_channels(config: ExperimentConfig, role: str) -> tuple[str, ...]:
    if role == "dynamic" or config.rig.position is None:
        return config.rig.log_channels
    return (config.rig.position,)


def _no_absurd_sample(log: Log, path, channels) -> None:
    """A sample no result survives (1e300 N: squares overflow, every fit breaks) stops the run
    here, naming it; a milder outlier is a finding of the inventory."""
    for channel in channels:
        found = outliers(path.name, channel, log[channel], log.units[channel])
        if found is not None and found.fatal:
            raise LogError(f"{path}: channel {channel}: {found.text}")


def load_depends(config: ExperimentConfig):
    files = [(config.resolve(e.path), config.resolve(e.columns)) for e in config.logs]
    return {
        "logs": [e.model_dump(mode="json") for e in config.logs],
        "sha256": [[sha256(p), sha256(c)] for p, c in files],
        "signs": {c: s.sign for c, s in config.rig.channels.items()},
    }


@dataclass(frozen=True)
class Denoised:
    """A log's pieces (split at logger pauses, if asked), each with smoothed and derived
    channels, and a record of every piece (those too short for the filters marked unused)."""

    name: str
    role: str
    pieces: tuple[Log, ...]
    records: tuple[Piece, ...]


def denoise(config: ExperimentConfig, load: dict[str, LoadedLog]) -> dict[str, Denoised]:
    """Smoothed channels plus velocity and acceleration for every piece of every log."""
    smoother, differentiator = config.denoise.build()
    rig = config.rig
    out = {}
    units = {log_name(config.resolve(e.path)): config.resolve(e.columns) for e in config.logs}
    for name, item in load.items():
        # before any filter: a time unit off by 1000 would surface as a window misfit
        time_unit = load_column_map(units[name]).channels["t"].unit
        check_time_base(item.log, config.denoise.smoother.window_s, time_unit)
        kept, records = pieces(
            item.log, name, config.denoise.split_gaps_s, 3 * config.denoise.longest_window_s
        )
        channels = rig.log_channels if item.role == "dynamic" else (_position(rig),)
        denoised = tuple(
            denoise_log(part, smoother, differentiator, channels=channels, position=rig.position)
            for part in kept
        )
        out[name] = Denoised(name, item.role, denoised, tuple(records))
    return out


@dataclass(frozen=True)
class Inventory:
    """What the report says of the data, kept once the logs themselves are let go: a summary of
    each log, its pieces, the loader's findings, and the free-fall pieces (short) that the
    friction figure draws."""

    summaries: tuple[LogSummary, ...]
    pieces: tuple[Piece, ...]
    flags: tuple[str, ...]
    free_falls: tuple[Log, ...]
    findings: tuple = ()  # hmid.io.plausibility.DataFinding: what the physics makes implausible


def inventory(
    config: ExperimentConfig, load: dict[str, LoadedLog], denoise: dict[str, Denoised]
) -> Inventory:
    channels = list(config.rig.log_channels)
    summaries = tuple(summarize(n, i.role, i.pieces, channels) for n, i in denoise.items())
    return Inventory(
        summaries=summaries,
        pieces=tuple(r for item in denoise.values() for r in item.records),
        flags=tuple(f for item in load.values() for f in item.log.flags),
        free_falls=tuple(p for i in denoise.values() if i.role == "free_fall" for p in i.pieces),
        findings=plausibility(config, load, summaries),
    )


def plausibility(config: ExperimentConfig, load: dict[str, LoadedLog], summaries) -> tuple:
    """Every log judged against the physics (:mod:`hmid.io.plausibility`): its channels as
    loaded, and the motion its smoothed position implies."""
    rig, limits = config.rig, config.rig.limits()
    found: list = []
    maps = {log_name(config.resolve(e.path)): config.resolve(e.columns) for e in config.logs}
    for summary in summaries:
        item, columns = load[summary.name], load_column_map(maps[summary.name])
        read = _read_channels(config, item.role)
        specs = {c: columns.channels[c] for c in read}
        own = {c: spec.unit for c, spec in specs.items()}
        sensor = {
            c: (float(spec.range[0]) * p.unit_factor(spec.unit),
                float(spec.range[1]) * p.unit_factor(spec.unit))
            for c, spec in specs.items()
            if spec.range is not None
        }  # fmt: skip
        channels = {c: item.log[c] for c in read}
        found += p.check_channels(summary.name, channels, item.log.units, own, sensor, limits)
        if rig.position is not None and summary.peak_speed is not None:
            found.append(
                p.motion(
                    summary.name, rig.position, summary.peak_speed, summary.peak_accel or 0.0,
                    summary.rate_hz, limits, columns.channels["t"].unit, own[rig.position],
                    columns.sample_rate_hz,
                )
            )  # fmt: skip
    return p.ordered([f for f in found if f is not None])


def friction(config: ExperimentConfig, denoise: dict[str, Denoised]):
    """Rig friction identified from the free-fall logs (None if no term takes it from them)."""
    if not config.rig.from_free_fall:
        return None
    from hmid.friction import Coulomb, CoulombViscous, FallRig, identify_friction

    free_fall = [p for item in denoise.values() if item.role == "free_fall" for p in item.pieces]
    model = {"coulomb": Coulomb, "coulomb_viscous": CoulombViscous}[config.friction.model]()
    rig = config.rig
    assert rig.free_fall is not None  # the rig requires it for a term from: free_fall
    return identify_friction(
        free_fall,
        FallRig(rig.free_fall.mass, rig.free_fall.drive),
        model,
        differentiator=config.denoise.build()[1],
        v_min=config.friction.v_min,
        confidence=config.friction.confidence,
        position=_position(rig),
        friction_sign=rig.from_free_fall[0].sign,
        explained=rig.explained.channels[0] if len(rig.explained.parts) == 1 else None,
    )


def signals(config: ExperimentConfig, denoise: dict[str, Denoised], friction) -> Signals:
    """The dynamic logs as the balance reads them: smoothed channels, the explained quantity
    less its known terms, and the usable rows."""
    from hmid.balance.prepare import prepare

    dynamic = {n: list(item.pieces) for n, item in denoise.items() if item.role == "dynamic"}
    smoother, differentiator = config.denoise.build()
    try:
        return prepare(
            config.rig,
            dynamic,
            log_units(config),
            smoother=smoother,
            differentiator=differentiator,
            free_fall_law=None if friction is None else friction.friction,
            v_deadband=config.fit.v_deadband,
            exclude_stuck=bool(config.fit.exclude_stuck),  # resolved at load
        )
    except KeyError as err:
        raise LogError(f"signals: a dynamic log lacks channel {err}") from None


@dataclass(frozen=True)
class Split:
    signals: Signals  # with the train and validation rows marked
    excluded: int  # samples left out of both: motion stopped, or within a filter's reach

    @property
    def n_train(self) -> int:
        return int(self.signals.train.sum())

    @property
    def n_validation(self) -> int:
        return int(self.signals.validation.sum())


def split(config: ExperimentConfig, signals: Signals) -> Split:
    """Training and held-out rows, the same for every family."""
    log = signals.frame["log"]
    lengths: dict[str, int] = {}
    for start, stop in signals.bounds():  # a segment is a piece of one log; logs in order
        lengths[log.iat[start]] = lengths.get(log.iat[start], 0) + stop - start
    masks = validation_masks(lengths, config.split)
    # a log's pieces are consecutive rows, logs in order of first appearance
    validation = np.concatenate([masks[name] for name in lengths])
    out = signals.with_roles(~validation, validation)
    for role, n in (("training", int(out.train.sum())), ("held-out", int(out.validation.sum()))):
        if n < 10 and int(out.usable.sum()) < 10:  # the motion, not the split: say which key
            raise ConfigError(_too_few_rows(config, signals, role, n))
        if n < 10:
            raise ConfigError(
                f"split: only {n} {role} rows remain after excluding stopped motion; change "
                "split.validation_fraction or split.validation_logs"
            )
    return Split(out, int((~out.usable).sum()))


def checks(config: ExperimentConfig, split: Split, friction) -> tuple:
    """Signs the rig's physics fixes whatever family is fitted (:mod:`hmid.balance.checks`):
    the free falls' friction, and the force that the declared motion makes grow with the
    acceleration."""
    from hmid.balance.checks import friction_findings, motion_findings

    rig = config.rig
    return (*friction_findings(friction, rig), *motion_findings(rig, split.signals))


def _too_few_rows(config: ExperimentConfig, signals: Signals, role: str, n: int) -> str:
    """Why (almost) no row is usable: the deadband above every speed, or the filters' reach."""
    from hmid.balance.signals import raw

    found = f"split: only {n} {role} rows remain after excluding stopped motion"
    if config.rig.position is None or not config.fit.exclude_stuck:
        return f"{found}: the logs are too short for the filters' reach; record longer logs"
    peak = float(np.max(np.abs(signals[raw("v")]))) if len(signals) else 0.0
    deadband = config.fit.v_deadband
    if peak < deadband:
        return (
            f"{found}: fit.v_deadband {deadband:g} m/s is above every speed in the logs (peak "
            f"{peak:.3g} m/s), so every row counts as stopped; lower fit.v_deadband (e.g. "
            f"0.002 m/s) or check the position's unit"
        )
    return (
        f"{found}: the motion stops too often for fit.v_deadband {deadband:g} m/s (peak speed "
        f"{peak:.3g} m/s); lower fit.v_deadband or set fit.exclude_stuck: false"
    )


@dataclass(frozen=True)
class Rows:
    """The split's row counts: what the report says of it, once the rows are let go."""

    train: int
    validation: int
    excluded: int
    findings: tuple = ()  # hmid.io.plausibility.DataFinding: dynamic logs that give no rows
    edges: int = 0  # of the excluded: within a filter's reach of a piece's ends


def rows(config: ExperimentConfig, split: Split) -> Rows:
    from hmid.balance.signals import raw

    signals = split.signals
    found: list = []
    seen: dict = {}
    v = signals[raw("v")] if config.rig.position is not None else None
    for start, stop in signals.bounds():  # segment by segment: no copy of a long log's rows
        n, usable, peak = seen.get(signals.frame["log"].iat[start], (0, 0, 0.0))
        if v is not None:
            peak = max(peak, float(np.max(v[start:stop])), -float(np.min(v[start:stop])))
        usable += int(np.count_nonzero(signals.usable[start:stop]))
        seen[signals.frame["log"].iat[start]] = (n + stop - start, usable, peak)
    for entry in config.logs_with_role("dynamic"):
        name = log_name(config.resolve(entry.path))
        n, usable, peak = seen.get(name, (0, 0, None))
        found.append(
            no_rows(name, n, usable, peak if v is not None else None, config.fit.v_deadband,
                    config.rig.position)
        )  # fmt: skip
    return Rows(split.n_train, split.n_validation, split.excluded,
                tuple(f for f in found if f is not None), _edges(config, split))  # fmt: skip


def _edges(config: ExperimentConfig, split: Split) -> int:
    """How many rows the filters' edges take (the rest of the excluded rows are stopped or slow
    motion): both ends of every piece, as :func:`signals` cuts them."""
    from hmid.signal.reach import impulse_reach

    smoother, differentiator = config.denoise.build()
    t, edges = split.signals.frame["t"].to_numpy(), 0
    for start, stop in split.signals.bounds():
        piece = t[start:stop]
        reach = impulse_reach(piece, smoother)
        if config.rig.position is not None:
            derivative = impulse_reach(piece, lambda t, y: differentiator.derivative(t, y, 1))
            reach = max(reach, derivative)
        edges += min(2 * reach, stop - start)
    return edges


def fit(
    config: ExperimentConfig, split: Split, friction, *, workdir: Path, force: bool = False
) -> Fits:
    """Every configured family fitted on the same training rows; a fit that fails or diverges
    is left out with its reason (:mod:`hmid.pipeline.fits`), and the run goes on with the
    others. Raises :class:`~hmid.errors.FitError` if none is left."""
    context = FitContext(config.seed, workdir, friction, force, beside)
    signals = split.signals
    # families see the explained quantity only where they may fit: NaN elsewhere, so no
    # held-out force can leak into a fit; one that reads it only through the training rows
    # (FitData.y) is handed the signals as they are (a long log's column is not copied)
    if not all(spec.reads_training_target_only for spec in config.models):
        signals = signals.with_columns(target=np.where(signals.train, signals.target, np.nan))
    data = FitData(signals, config.rig, "train")
    # families are independent: shared with a worker (hmid.workers), each process taking the
    # next when it is free; a family fits the same wherever it runs
    tasks = Tasks(ahead=1) if len(config.models) > 1 else Tasks(workers=0)
    for spec in config.models:
        tasks.submit(fit_or_fail, spec, data, context)
    results = tasks.results()
    fits = Fits(tuple(m for good, _ in results for m in good),
                tuple(f for _, bad in results for f in bad))  # fmt: skip
    if not fits.fitted:
        raise FitError("fit: every model failed: " + "; ".join(f.message() for f in fits.failed))
    return fits


@dataclass(frozen=True)
class Comparison:
    scores: pd.DataFrame  # one row per model: held-out (and training) errors
    predictions: pd.DataFrame  # held-out rows with each model's prediction


def compare(config: ExperimentConfig, split: Split, fit: list[Fitted]) -> Comparison:
    """Every model scored on the held-out rows (and, for reference, on the training rows)."""
    train = FitData(split.signals, config.rig, "train")
    held = train.as_role("validation")
    predictions = held.frame(("explained", "target"))
    rows = []
    for model in fit:
        y_held = model.predict(held)
        s_val = score(held.y, y_held, model.kind)
        s_train = score(train.y, model.predict(train), model.kind)
        rows.append(
            {"model": model.name, "family": model.family, "error kind": model.kind}
            | {f"{k} (held-out)": v for k, v in s_val.to_dict().items() if k != "kind"}
            | {"r2 (train)": s_train.r2, "rmse (train)": s_train.rmse}
        )
        predictions[model.name] = y_held
        band = model.predict_interval(held)
        if band is not None:
            predictions[f"{model.name} lower"], predictions[f"{model.name} upper"] = band
    table = pd.DataFrame(rows).sort_values("rmse (held-out)", kind="stable")
    return Comparison(table.reset_index(drop=True), predictions)


def export(config: ExperimentConfig, split: Split, fit: list[Fitted], friction) -> dict:
    """Every fitted model as a model file's content (:mod:`hmid.portable`), by name; a model
    that cannot be exported gets its one-line reason instead (the run goes on)."""
    from hmid.portable.export import model_document

    data = FitData(_export_rows(split.signals), config.rig, "train")
    settings = {
        "units": log_units(config),
        "denoise": config.denoise.model_dump(mode="json"),
        "fit": config.fit.model_dump(mode="json"),
        "friction": friction,
    }
    out: dict[str, dict | str] = {}
    for model in fit:
        posterior = f"{file_stem(model.name)}.posterior.nc" if _draws(model) else None
        try:
            out[model.name] = model_document(model, data, posterior=posterior, **settings)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as err:
            out[model.name] = f"not exported: {err}"
    return out


#: A model file's coefficients are found (and checked against the model) on the first rows of
#: the signals that hold this many training rows: exact where the model lies in its terms' span
#: (every shipped family), and a long log's design is never held whole for it
EXPORT_ROWS = 50_000


def _export_rows(signals: Signals) -> Signals:
    """The first rows of ``signals`` that hold :data:`EXPORT_ROWS` training rows (all of them
    where there are fewer): a set of their own, so the terms' columns are computed there only."""
    rows = np.flatnonzero(signals.train)
    if len(rows) <= EXPORT_ROWS:
        return signals
    head = signals.frame.iloc[: rows[EXPORT_ROWS - 1] + 1].reset_index(drop=True)
    return Signals(head, signals.units, signals.channels, signals.position, signals.smoother)


@dataclass(frozen=True)
class FreeRunBlocks:
    """What the free runs read (:func:`freerun_blocks`): the rows of their blocks alone, and
    what the time budget left out, in words."""

    rows: FreeRunRows
    note: str


def freerun_blocks(config: ExperimentConfig, split: Split, export: dict) -> FreeRunBlocks:
    """The held-out blocks the exported models run free over (within the time budget) and the
    training blocks their bands are calibrated on, as rows of their own with every model's
    memory states there: a long log's signals are let go before the free runs import JAX."""
    from hmid.portable import Model
    from hmid.portable.freerun import block_spans, held_rows, within_budget

    signals = split.signals
    # as ranges: of the blocks, held_rows takes the rows of those it keeps alone
    kept, note = within_budget(block_spans(signals), signals.dt)
    training = block_spans(signals, "train")  # the band's disturbance is calibrated there
    models = [Model(document) for document in export.values() if not isinstance(document, str)]
    return FreeRunBlocks(held_rows(signals, kept, training, models), note)


def freerun(
    config: ExperimentConfig, freerun_blocks: FreeRunBlocks, fit: list[Fitted], export: dict
) -> Pending:
    """Every exported model run free over the held-out blocks (:mod:`hmid.portable.freerun`),
    by name; a model that cannot run free says why in one line. A stage begun
    (:attr:`Stage.started <hmid.pipeline.runner.Stage.started>`): the models are handed to the
    run's worker now and run there while the run compares the models and runs the loop; the
    :class:`~hmid.pipeline.runner.Pending` returned gives every model's run, those no worker has
    begun run here, or cancels them where a later stage fails. With no worker, every model runs
    when its result is asked for (after the stages that hold the signals: a long log's are let
    go before the free runs import JAX)."""
    tasks = Tasks(ahead=None)  # every model at once: the worker goes on while the run does
    if not tasks.workers:
        return Pending(lambda: _free_runs(config, freerun_blocks, fit, export, tasks)(),
                       work_s=lambda: tasks.seconds)  # fmt: skip
    return Pending(_free_runs(config, freerun_blocks, fit, export, tasks), tasks.cancel,
                   lambda: tasks.seconds)  # fmt: skip


def _free_runs(config: ExperimentConfig, freerun_blocks: FreeRunBlocks, fit: list[Fitted],
               export: dict, tasks: Tasks) -> Callable[[], dict]:  # fmt: skip
    """:func:`freerun`'s models submitted to ``tasks``; the callable gives their runs."""
    from hmid.portable import Model
    from hmid.portable.freerun import FreeRun

    held = freerun_blocks.rows
    out: dict = {}
    # the programs are read back from disk (:mod:`.freerun.stored`, JAX's compilation cache),
    # so a process pays a few tenths of a second to load a shape's, less than a model's runs;
    # a model runs the same program, to the same numbers, wherever
    for name, document in export.items():
        if isinstance(document, str):
            out[name] = FreeRun(name, (), document)
            continue
        fitted = next(m for m in fit if m.name == name)
        posterior_draws = _draws(fitted)
        draws = posterior_draws() if posterior_draws else None
        out[name] = None  # keeps the models' order
        run = partial(free_run_or_why, draws=FREE_RUN_DRAWS, level=FREE_RUN_LEVEL,
                      seed=config.seed, held=held)  # fmt: skip
        tasks.submit(run, Model(document, draws=draws), held.signals, held.spans)

    def finish() -> dict:
        for run in tasks.results():
            out[run.model] = replace(run.thinned(), note=freerun_blocks.note)  # whole runs'
        return out

    return finish


#: Draws of a model's coefficients (each with its own disturbance) behind its free run's band,
#: and the band's level. 14, not 20: the band's scale is calibrated for the draws it has, and
#: over simulated data sets 14 cover as 20 do (the demo's SLS 91.7 against 91.3 %, the linear
#: stage 88.1 ± 1.8 against 89.6 ± 1.6, paired, before its file carried the coefficients'
#: covariance: 89.1 ± 1.4 since), at two thirds of the runs: the free run then costs
#: the demo 9 % of its time, not 15 % (benchmarks/README.md, 2026-11-28 02:20)
FREE_RUN_DRAWS, FREE_RUN_LEVEL = 14, 0.9


def free_run_or_why(model: Model, signals: Signals, spans: list, **options) -> FreeRun:
    """:func:`hmid.portable.freerun.simulate_signals`, or, where it raises one of the fit's
    :data:`~hmid.pipeline.fits.FIT_ERRORS` (hmid's own, an overflow, a singular matrix: the
    model's numbers, the same on every run of the same data, so the line is cached as the run
    would be), a free run without blocks that says why in one line: one model's failing free
    run never takes the other models' or the run down with it. Anything else (a programming
    error, XLA out of memory) still raises."""
    from hmid.portable import freerun

    try:
        return freerun.simulate_signals(model, signals, spans, **options)
    except FIT_ERRORS as err:
        why = " ".join(str(err).split()) or "no message"
        return freerun.FreeRun(model.name, (), f"free run failed ({type(err).__name__}: {why})")


def file_stem(model_name: str) -> str:
    """A model's name as a file name (``poly:cubic_xv`` -> ``poly_cubic_xv``)."""
    return model_name.replace(":", "_")


def _position(rig: RigSection) -> str:
    """The rig's position channel, which free-fall logs and friction need."""
    if rig.position is None:
        raise ConfigError("rig: free-fall logs need the rig's position channel")
    return rig.position


def _draws(model: Fitted):
    return getattr(model.model, "posterior_draws", None)


def loop(config: ExperimentConfig, split: Split, fit: Fits, friction=None):
    """The loop on the model ``loop.base`` names (None if the experiment has no loop). If that
    model failed, the loop starts from the converged model with the lowest training RMSE, and
    says so; a loop that fails on its data is reported (a warning, no loop section), never a
    traceback. ``friction``: the free falls' estimate, whose uncertainty a refit of its level
    is compared with."""
    if config.loop is None:
        return None
    from hmid.loop import LoopBase, Setting, run_loop

    model, note = loop_base(config.loop.base, fit)
    base = LoopBase.of(model, FitData(split.signals, config.rig))
    setting = Setting.of(config.rig)
    if friction is not None and setting.known_level is not None:
        setting = replace(setting, known_se=float(friction.se.get("Fc", 0.0)))
    low_speed = None if config.fit.exclude_stuck else config.fit.v_deadband  # the loop's to apply
    try:
        result = run_loop(split.signals, base, config.loop, setting, config.seed,
                          across_logs=config.split.kind == "logs", rig=config.rig,
                          low_speed=low_speed)  # fmt: skip
    except (*FIT_ERRORS, ValueError, IndexError) as err:
        warnings.warn(f"loop: it failed on the base {model.name}: {' '.join(str(err).split())}; "
                      "the report has no loop section", HmidWarning, stacklevel=2)  # fmt: skip
        return None
    return replace(result, notes=(note, *result.notes)) if note else result


def loop_base(name: str, fit: Fits) -> tuple[Fitted, str]:
    """The model named ``name``, or, if it failed, the converged model with the lowest
    training RMSE and the one line that says so."""
    model = next((m for m in fit if m.name == name), None)
    if model is not None:
        return model, ""
    model = min(fit, key=lambda m: np.nan_to_num(m.fit_summary.rmse, nan=np.inf))
    why = next((f.reason for f in getattr(fit, "failed", ()) if f.name == name), "it failed")
    return model, (
        f"loop.base {name} failed ({why}); the loop starts from {model.name} instead, the "
        "converged model with the lowest training RMSE"
    )
