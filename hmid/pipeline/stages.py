"""The identification stages: pure functions of the experiment config and upstream artifacts.

load -> denoise -> friction -> reconstruct -> split -> fit -> compare. Each returns plain data
(logs, estimates, fitted models, score tables); the run folder and report are written elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.denoise import denoise_log
from hmid.errors import ConfigError
from hmid.experiment import ExperimentConfig
from hmid.families import FitContext, FitData, Fitted
from hmid.files import sha256
from hmid.io import Log, load_column_map, read_log
from hmid.metrics import score
from hmid.split import validation_masks


@dataclass(frozen=True)
class LoadedLog:
    name: str
    role: str
    log: Log


def log_name(path) -> str:
    return path.stem


def load(config: ExperimentConfig) -> dict[str, LoadedLog]:
    """Read and validate every log of the experiment (SI units, flags kept)."""
    out: dict[str, LoadedLog] = {}
    rig = config.rig.constants()
    for entry in config.logs:
        path = config.resolve(entry.path)
        name = log_name(path)
        if name in out:
            raise ConfigError(f"two logs are named {name!r}; log file names must be unique")
        log = read_log(path, load_column_map(config.resolve(entry.columns)), rig=rig)
        out[name] = LoadedLog(name, entry.role, log)
    return out


def load_depends(config: ExperimentConfig):
    files = [(config.resolve(e.path), config.resolve(e.columns)) for e in config.logs]
    return {
        "logs": [e.model_dump(mode="json") for e in config.logs],
        "sha256": [[sha256(p), sha256(c)] for p, c in files],
        "rig": config.rig.model_dump(mode="json"),
    }


def denoise(config: ExperimentConfig, load: dict[str, LoadedLog]) -> dict[str, LoadedLog]:
    """Smoothed channels plus velocity and acceleration for every log."""
    smoother = config.denoise.smoother.build()
    differentiator = config.denoise.derivative.build()
    return {
        name: LoadedLog(name, item.role, denoise_log(item.log, smoother, differentiator))
        for name, item in load.items()
    }


def friction(config: ExperimentConfig, denoise: dict[str, LoadedLog]):
    """Rig friction identified from the free-fall logs (thesis eq. 4.1 without the muscle)."""
    from hmid.friction import Coulomb, CoulombViscous, identify_friction

    free_fall = [item.log for item in denoise.values() if item.role == "free_fall"]
    if not free_fall:
        raise ConfigError("logs: no log has role 'free_fall'; friction needs free-fall tests")
    model = {"coulomb": Coulomb, "coulomb_viscous": CoulombViscous}[config.friction.model]()
    return identify_friction(
        free_fall,
        config.rig.constants(),
        model,
        differentiator=config.denoise.derivative.build(),
        v_min=config.friction.v_min,
        confidence=config.friction.confidence,
    )


def reconstruct(config: ExperimentConfig, denoise: dict[str, LoadedLog], friction):
    """Muscle force of every dynamic log from the load cell (or acceleration) and the friction."""
    from hmid.friction import reconstruct_muscle_force

    out = {}
    for name, item in denoise.items():
        if item.role != "dynamic":
            continue
        log = reconstruct_muscle_force(
            item.log,
            config.rig.constants(),
            friction,
            source=config.rig.force_source,
            v_deadband=config.friction.v_deadband,
        )
        out[name] = LoadedLog(name, item.role, log)
    if not out:
        raise ConfigError("logs: no log has role 'dynamic'; there is nothing to identify")
    return out


@dataclass(frozen=True)
class Split:
    train: FitData
    validation: FitData
    excluded_stuck: int  # samples left out: block stuck, or within a derivative reach of an end


def split(config: ExperimentConfig, reconstruct: dict[str, LoadedLog]) -> Split:
    """Training and held-out rows, the same for every family."""
    from hmid.friction import derivative_reach

    masks = validation_masks({n: len(item.log) for n, item in reconstruct.items()}, config.split)
    differentiator = config.denoise.derivative.build()
    frames = []
    for name, item in reconstruct.items():
        log = item.log
        # within one derivative reach of a log's ends v is less accurate and its sign unreliable
        reach = derivative_reach(log.t, differentiator)
        inner = np.zeros(len(log), dtype=bool)
        inner[reach : len(log) - reach] = True
        frames.append(
            pd.DataFrame(
                {
                    "log": name,
                    "t": log.t,
                    "x": log["x_s"],
                    "v": log["v"],
                    "P": log["P_s"],
                    "F_m": log["F_m"],
                    "sliding": (log["sliding"] > 0.5) & inner,
                    "validation": masks[name],
                }
            )
        )
    rows = pd.concat(frames, ignore_index=True)
    keep = rows["sliding"] if config.fit.exclude_stuck else np.ones(len(rows), dtype=bool)
    rows["train"] = keep & ~rows["validation"]
    rows["validation"] = keep & rows["validation"]
    columns = ["t", "x", "v", "P", "F_m", "train", "validation"]
    sequences = {
        name: group[columns].reset_index(drop=True)
        for name, group in rows.groupby("log", sort=False)
    }
    # families see forces only where they may fit: NaN elsewhere, so nothing can leak
    train_sequences = {
        name: seq.assign(F_m=seq["F_m"].where(seq["train"])) for name, seq in sequences.items()
    }
    columns = ["log", "t", "x", "v", "P", "F_m"]
    train = rows.loc[rows["train"], columns].reset_index(drop=True)
    held = rows.loc[rows["validation"], columns].reset_index(drop=True)
    for role, frame in (("training", train), ("held-out", held)):
        if len(frame) < 10:
            raise ConfigError(
                f"split: only {len(frame)} {role} rows remain after excluding stuck samples; "
                "change split.validation_fraction or split.validation_logs"
            )
    return Split(
        FitData(train, "train", train_sequences),
        FitData(held, "validation", sequences),
        int((~keep).sum()),
    )


def fit(
    config: ExperimentConfig, split: Split, friction, *, workdir: Path, force: bool = False
) -> list[Fitted]:
    """Every configured family fitted on the same training rows."""
    if not config.models:
        raise ConfigError("models: no model family configured; add e.g. {family: polynomial}")
    context = FitContext(config.seed, workdir, config.rig.constants(), friction, force)
    fitted: list[Fitted] = []
    for spec in config.models:
        fitted.extend(spec.fit(split.train, context))
    names = [model.name for model in fitted]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ConfigError(
            f"models: several fitted models are named {repeated}; give each entry its own name "
            "(e.g. name: cubic for a second sls entry, or distinct custom term-set names)"
        )
    return fitted


@dataclass(frozen=True)
class Comparison:
    scores: pd.DataFrame  # one row per model: held-out (and training) errors
    predictions: pd.DataFrame  # held-out rows with each model's prediction


def compare(config: ExperimentConfig, split: Split, fit: list[Fitted]) -> Comparison:
    """Every model scored on the held-out rows (and, for reference, on the training rows)."""
    rows, predictions = [], split.validation.frame.copy()
    for model in fit:
        held = model.predict(split.validation)
        train = model.predict(split.train)
        s_val = score(split.validation.y, held, model.kind)
        s_train = score(split.train.y, train, model.kind)
        rows.append(
            {"model": model.name, "family": model.family, "error kind": model.kind}
            | {f"{k} (held-out)": v for k, v in s_val.to_dict().items() if k not in ("kind",)}
            | {"r2 (train)": s_train.r2, "rmse (train)": s_train.rmse}
        )
        predictions[model.name] = held
        band = model.predict_interval(split.validation)
        if band is not None:
            predictions[f"{model.name} lower"], predictions[f"{model.name} upper"] = band
    table = pd.DataFrame(rows).sort_values("rmse (held-out)", kind="stable")
    return Comparison(table.reset_index(drop=True), predictions)


def loop(config: ExperimentConfig, split: Split):
    """Residual diagnostics, candidate effects and held-out confirmation (``None`` if the
    experiment has no ``loop`` section)."""
    if config.loop is None:
        return None
    from hmid.loop import from_sequences, run_loop

    return run_loop(from_sequences(split.validation.sequences), config.loop)
