"""Bad inputs made from the shipped demo logs: each case a small experiment in a folder of its own,
its logs or config broken the way a new user's are (issue 31's audit)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "data" / "demo"
RIG = yaml.safe_load((ROOT / "configs" / "demo.yaml").read_text())["rig"]
ROWS = 6000  # 6 s of each dynamic log: enough for every stage, quick to fit

DYNAMIC = ("dyn-cycles", "dyn-steps")
FREE_FALL = ("free-fall-1", "free-fall-2")


def frames() -> dict[str, pd.DataFrame]:
    out = {name: pd.read_csv(DEMO / f"{name}.csv").iloc[:ROWS] for name in DYNAMIC}
    return out | {name: pd.read_csv(DEMO / f"{name}.csv") for name in FREE_FALL}


def column_maps() -> dict[str, dict]:
    return {
        role: yaml.safe_load((DEMO / f"columns-{role}.yaml").read_text())
        for role in ("dynamic", "free_fall")
    }


def experiment(**changes) -> dict:
    config = {
        "name": "bad",
        "seed": 1,
        "rig": json.loads(json.dumps(RIG)),
        "logs": [
            {"path": f"{name}.csv", "columns": f"columns-{role}.yaml", "role": role}
            for names, role in ((DYNAMIC, "dynamic"), (FREE_FALL, "free_fall"))
            for name in names
        ],
        "denoise": {"smoother": {"kind": "moving_average", "window_s": 0.011, "passes": 3}},
        "friction": {"model": "coulomb", "v_min": 0.05},
        "split": {"kind": "time_block", "validation_fraction": 0.3},
        "models": [{"family": "polynomial", "variants": ["quadratic_xv"]}],
    }
    return config | changes


def write(folder: Path, logs=None, maps=None, config=None) -> Path:
    """The case's folder: its logs, column maps and experiment config; returns the config."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, frame in (logs or frames()).items():
        frame.to_csv(folder / f"{name}.csv", index=False)
    for role, data in (maps or column_maps()).items():
        (folder / f"columns-{role}.yaml").write_text(yaml.safe_dump(data))
    path = folder / "experiment.yaml"
    path.write_text(yaml.safe_dump(config or experiment()))
    return path


def ten_hz_log(minutes: float = 30.0, seed: int = 0) -> pd.DataFrame:
    """A slow 10 Hz log whose time column is in seconds (the demo map reads it as ms)."""
    rng = np.random.default_rng(seed)
    t = np.arange(1, int(minutes * 600) + 1) / 10.0
    phase = 2 * np.pi * t / 40.0
    x = 7.0 + 5.0 * np.sin(phase) + rng.normal(0, 0.02, len(t))
    P = 140.0 + 80.0 * np.sin(phase + 0.3)
    accel = -((2 * np.pi / 40.0) ** 2) * 5e-3 * np.sin(phase)  # m/s²: F = 0.75 a + m1 g
    F = 4.903325 + 0.75 * accel + rng.normal(0, 0.01, len(t))
    return pd.DataFrame(
        {"t_ms": t, "P_kPa": np.round(P, 3), "x_mm": np.round(x, 2), "F_N": np.round(F, 2)}
    )


def case(name: str, folder: Path) -> Path:
    """The experiment of case ``name`` (see CASES), written in ``folder``."""
    logs, maps, config = frames(), column_maps(), experiment()
    dynamic = maps["dynamic"]["channels"]
    if name == "clean":
        pass
    elif name == "time_s_as_ms":  # a 10 Hz log, time in s, mapped as ms
        logs = {k: v for k, v in logs.items() if k not in DYNAMIC} | {"slow": ten_hz_log()}
        config["logs"] = [e for e in config["logs"] if e["role"] != "dynamic"] + [
            {"path": "slow.csv", "columns": "columns-dynamic.yaml", "role": "dynamic"}
        ]
        config["split"] = {"kind": "time_block", "validation_fraction": 0.3}
    elif name == "bar_as_kpa":  # pressure in bar, mapped as kPa
        for k in DYNAMIC:
            logs[k]["P_kPa"] = logs[k]["P_kPa"] / 100.0
    elif name == "mm_as_m":  # position in mm, mapped as m (every log)
        for role in maps:
            maps[role]["channels"]["x"]["unit"] = "m"
            maps[role]["channels"]["x"].pop("range", None)
    elif name == "position_too_small":  # one log's position 1000x too small
        logs["dyn-steps"]["x_mm"] = logs["dyn-steps"]["x_mm"] / 1000.0
    elif name == "position_stuck":
        logs["dyn-steps"]["x_mm"] = 5.0
    elif name == "pressure_constant":
        logs["dyn-steps"]["P_kPa"] = 150.0
    elif name == "force_clipped":  # clipped at 6 N, inside the declared 0 ... 10.23 N
        logs["dyn-steps"]["F_N"] = logs["dyn-steps"]["F_N"].clip(upper=6.0)
    elif name == "position_clipped":  # clipped at 8 mm, inside the declared 0 ... 20.46 mm
        logs["dyn-cycles"]["x_mm"] = logs["dyn-cycles"]["x_mm"].clip(upper=8.0)
    elif name == "x_F_swapped":
        dynamic["x"]["column"], dynamic["F"]["column"] = "F_N", "x_mm"
    elif name == "position_reversed":  # polynomial only: the sign must be caught all the same
        config["rig"]["channels"]["x"]["sign"] = -1
    elif name in ("pressure_declared_positive", "pressure_reversed"):  # positive: [P] declared
        linear = {"name": "linear", "variables": ["x", "v", "P"], "degree": 1}
        config["models"] = [
            {"family": "polynomial", "variants": [], "custom": [linear], "positive": ["P"]}
        ]
        if name == "pressure_reversed":
            config["rig"]["channels"]["P"]["sign"] = -1
    elif name == "free_fall_mass":  # 7.5 kg declared, 0.75 kg true
        config["rig"]["free_fall"]["mass"] = 7.5
    elif name == "max_effects_0":
        config["loop"] = {"base": "poly:quadratic_xv", "max_effects": 0}
    elif name == "force_1e300":
        logs["dyn-steps"].loc[2500, "F_N"] = 1e300
    elif name == "khz_as_hz":  # a 1 kHz log, time in ms, mapped as s
        for role in maps:
            maps[role]["channels"]["t"]["unit"] = "s"
    elif name == "three_rows":
        logs["dyn-steps"] = logs["dyn-steps"].iloc[:3]
    elif name == "dynamic_as_free_fall":
        config["logs"][1] = config["logs"][1] | {"columns": "columns-free_fall.yaml",
                                                 "role": "free_fall"}  # fmt: skip
    elif name == "v_deadband_10":
        config["fit"] = {"v_deadband": 10}
    else:
        raise KeyError(name)
    return write(folder, logs, maps, config)
