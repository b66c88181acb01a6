"""The run's answer in a few lines: the winning model's equation and parameters, its margin over
the runner-up with an interval, its one-step and free-run scores, and which rows were left out
and why. One record (metrics.json's ``answer``), read by the report's summary and the console.

The margin's interval is a **block bootstrap** of the held-out RMSE difference: held-out rows are
cut into blocks of :data:`BLOCK_S` seconds of one log (the residuals are correlated over many
rows, so single rows are not independent draws), the blocks resampled with replacement and both
models' RMSE recomputed on each resample. Seeded from the experiment's seed.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

#: Length of a bootstrap block of held-out rows, seconds; resamples; interval level.
BLOCK_S, RESAMPLES, LEVEL = 1.0, 2000, 0.95


def coefficient_rows(table: pd.DataFrame) -> list[dict]:
    """A coefficient table (any family's columns) as ``name, value, lower, upper, unit``."""
    columns = list(table.columns)
    value = next((c for c in ("value", "median") if c in columns), None)
    lower = next((c for c in columns if c.startswith(("ci_low", "lower"))), None)
    upper = next((c for c in columns if c.startswith(("ci_high", "upper"))), None)
    if value is None or not len(columns):
        return []
    out = []
    for _, row in table.iterrows():
        out.append({
            "name": str(row[columns[0]]),
            "value": _number(row[value]),
            "lower": None if lower is None else _number(row[lower]),
            "upper": None if upper is None else _number(row[upper]),
            "unit": str(row["unit"]) if "unit" in columns and pd.notna(row["unit"]) else "",
        })  # fmt: skip
    return out


def _number(x) -> float | None:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _blocks(predictions: pd.DataFrame) -> np.ndarray:
    """Each held-out row's block: consecutive BLOCK_S-second stretches of one log."""
    codes = pd.factorize(predictions["log"].astype(str))[0]
    t = predictions["t"].to_numpy(float)
    start = pd.Series(t).groupby(codes).transform("min").to_numpy()
    within = np.floor((t - start) / BLOCK_S).astype(np.int64)
    return pd.factorize(pd.Series(codes).astype(str) + ":" + pd.Series(within).astype(str))[0]


def margin(predictions: pd.DataFrame, best: str, other: str, seed: int) -> dict | None:
    """``other``'s held-out RMSE less ``best``'s, with a block-bootstrap interval (None where the
    two share fewer than two blocks of finite predictions)."""
    y = predictions["target"].to_numpy(float)
    a, b = predictions[best].to_numpy(float), predictions[other].to_numpy(float)
    ok = np.isfinite(y) & np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 2:
        return None
    block = _blocks(predictions[ok])
    n_blocks = int(block.max()) + 1
    if n_blocks < 2:
        return None
    count = np.bincount(block, minlength=n_blocks).astype(float)
    sse_a = np.bincount(block, (y[ok] - a[ok]) ** 2, minlength=n_blocks)
    sse_b = np.bincount(block, (y[ok] - b[ok]) ** 2, minlength=n_blocks)
    rng = np.random.default_rng([seed, 32])  # the experiment's seed, this statistic's stream
    picks = rng.integers(0, n_blocks, size=(RESAMPLES, n_blocks))
    weights = np.stack([np.bincount(p, minlength=n_blocks) for p in picks])
    n = weights @ count
    diff = np.sqrt(weights @ sse_b / n) - np.sqrt(weights @ sse_a / n)
    tail = 100 * (1 - LEVEL) / 2
    low, high = np.percentile(diff, [tail, 100 - tail])
    rmse_a, rmse_b = math.sqrt(sse_a.sum() / count.sum()), math.sqrt(sse_b.sum() / count.sum())
    return {
        "runner_up": other,
        "rmse_best": rmse_a,
        "rmse_runner_up": rmse_b,
        "difference": rmse_b - rmse_a,
        "lower": float(low),
        "upper": float(high),
        "ratio": rmse_b / rmse_a if rmse_a > 0 else None,
        "level": LEVEL,
        "block_s": BLOCK_S,
        "blocks": n_blocks,
        "resamples": RESAMPLES,
        "rows": int(ok.sum()),
    }


def answer(config, artifacts: dict, free_run: pd.DataFrame | None) -> dict:
    """metrics.json's ``answer`` (see the module docstring)."""
    comparison = artifacts["compare"]
    scores = comparison.scores
    best = scores.iloc[0]
    name = str(best["model"])
    model = next(m for m in artifacts["fit"] if m.name == name)
    out = {
        "model": name,
        "family": model.family,
        "equation": model.equation,
        "interval": None if model.interval is None else model.interval.method,
        "level": None if model.interval is None else model.interval.level,
        "parameters": coefficient_rows(model.coefficient_table()),
        "one_step": {
            "rmse": _number(best["rmse (held-out)"]),
            "r2": _number(best["r2 (held-out)"]),
            "nrmse_fit_pct": _number(best["nrmse_fit_pct (held-out)"]),
        },
        "margin": None,
        "free_run": None,
        "rows": excluded_rows(config, artifacts["rows"]),
    }
    if len(scores) > 1:
        out["margin"] = margin(comparison.predictions, name, str(scores.iloc[1]["model"]),
                               config.seed)  # fmt: skip
    if free_run is not None and len(free_run) and name in set(free_run["model"]):
        row = free_run.set_index("model").loc[name]
        fit = next((c for c in row.index if c.startswith("fit %")), None)
        rmse = next((c for c in row.index if c.startswith("rmse") and "[mm]" in c), None)
        out["free_run"] = {
            "position": config.rig.position,
            "fit_pct": None if fit is None else _number(row[fit]),
            "rmse_mm": None if rmse is None else _number(row[rmse]),
            "blocks": int(row.get("free-run blocks", 0) or 0),
            "diverged": int(row.get("diverged", 0) or 0),
            "note": str(row.get("note") or "") if pd.notna(row.get("note")) else "",
        }
    return out


def excluded_rows(config, rows) -> dict:
    """How many rows neither fit nor score, and why."""
    edges = min(getattr(rows, "edges", 0), rows.excluded)
    return {
        "train": rows.train,
        "held_out": rows.validation,
        "excluded": rows.excluded,
        "filter_edges": edges,
        "stopped_or_slow": rows.excluded - edges,
        "exclude_stuck": bool(config.fit.exclude_stuck),
        "v_deadband": config.fit.v_deadband,
        "rig_declares_friction": config.rig.declares_friction,
    }


#: At most this many parameters are listed in the summary; the rest are in the model's table.
SHOWN_PARAMETERS = 8


def _g(x: float | None) -> str:
    from hmid.report._common import format_float

    return "n/a" if x is None else format_float(x)


def _decimals(low: float, high: float, value: float) -> int | None:
    """Decimals that show an interval's width with two significant digits (None: the width is
    zero or the numbers are too large or small for fixed notation)."""
    width = abs(high - low)
    scale = max(abs(value), abs(low), abs(high))
    if not (width > 0 and 1e-3 <= scale < 1e6):
        return None
    decimals = 1 - math.floor(math.log10(width))
    return min(max(decimals, 0), 12) if decimals - math.floor(math.log10(scale)) <= 10 else None


def _with(x: float | None, decimals: int | None) -> str:
    if x is None:
        return "n/a"
    return _g(x) if decimals is None else f"{x:.{decimals}f}"


def r2_text(r2: float | None) -> str:
    """R² with digits enough to tell it from 1 (0.99998, not 1.000)."""
    if r2 is None:
        return "n/a"
    gap = 1 - r2
    if 0 < gap < 1e-3:
        return f"{r2:.{min(1 - math.floor(math.log10(gap)), 12)}f}"
    return f"{r2:.3f}"


def parameter_lines(found: dict) -> list[str]:
    """``name = value unit (level interval low … high)``, one per parameter (the first few)."""
    level = found.get("level")
    what = f"{100 * level:g} % interval" if level else "interval"
    lines = []
    for p in found["parameters"][:SHOWN_PARAMETERS]:
        unit = f" {p['unit']}" if p["unit"] else ""
        low, high, value = p["lower"], p["upper"], p["value"]
        if low is None or high is None or value is None:
            lines.append(f"{p['name']} = {_g(value)}{unit}")
            continue
        d = _decimals(low, high, value)
        lines.append(f"{p['name']} = {_with(value, d)}{unit} ({what} {_with(low, d)} … "
                     f"{_with(high, d)})")  # fmt: skip
    extra = len(found["parameters"]) - SHOWN_PARAMETERS
    if extra > 0:
        lines.append(f"… and {extra} more (the model's coefficient table)")
    return lines


def margin_text(found: dict, unit: str) -> str | None:
    m = found["margin"]
    if m is None:
        return None
    ratio = f", {m['ratio']:.3g}× the best's" if m["ratio"] else ""
    return (
        f"runner-up {m['runner_up']}: held-out RMSE {_g(m['rmse_runner_up'])} {unit}{ratio}; "
        f"difference {_g(m['difference'])} {unit} ({100 * m['level']:g} % interval "
        f"{_g(m['lower'])} … {_g(m['upper'])} {unit}, block bootstrap over "
        f"{m['blocks']} blocks of {m['block_s']:g} s of held-out rows)"
    )


def free_run_text(found: dict) -> str | None:
    f = found["free_run"]
    if f is None:
        return None
    if f["fit_pct"] is None:
        if not f["diverged"]:
            return None
        why = f" ({f['note']})" if f.get("note") else ""
        return (f"free run of {f['position']}: diverged in {f['diverged']} of {f['blocks']} "
                f"held-out block{'s' if f['blocks'] != 1 else ''}{why}")  # fmt: skip
    diverged = f", diverged in {f['diverged']} of {f['blocks']} blocks" if f["diverged"] else ""
    return (
        f"free run of {f['position']}: fit {f['fit_pct']:.1f} %, RMSE {_g(f['rmse_mm'])} mm "
        f"over {f['blocks']} held-out block{'s' if f['blocks'] != 1 else ''}{diverged}"
    )


def rows_text(found: dict) -> str:
    r = found["rows"]
    text = f"{r['train']} training and {r['held_out']} held-out rows; {r['excluded']} left out"
    reasons = []
    if r["filter_edges"]:
        reasons.append(f"{r['filter_edges']} within the filters' reach of a piece's ends")
    deadband = f"{1e3 * r['v_deadband']:g} mm/s"
    if r["exclude_stuck"] and r["stopped_or_slow"]:
        reasons.append(
            f"{r['stopped_or_slow']} where the motion stops or is slower than {deadband} "
            "(static friction is indeterminate there)"
        )
    text += f" ({'; '.join(reasons)})" if reasons else ""
    if not r["exclude_stuck"] and not r["rig_declares_friction"]:
        text += (
            f". The low-speed rule (|v| < {deadband}), meant for friction, is not applied: the "
            "rig declares no friction term (fit.exclude_stuck: true applies it)"
        )
    elif r["exclude_stuck"] and not r["rig_declares_friction"]:
        text += (". The low-speed rule is applied as the config asks (fit.exclude_stuck), "
                 "though the rig declares no friction term")  # fmt: skip
    return text


def equation_text(found: dict) -> str:
    """The model's equation without the values it may append (``...; A = 1, B = 2``): the
    parameters are listed beside it, with their intervals."""
    equation = found["equation"]
    names = {p["name"] for p in found["parameters"]}
    head, _, tail = equation.partition("; ")
    while tail:
        rest, _, after = tail.partition("; ")
        if rest.split(" = ")[0] in names:
            return head
        head, tail = f"{head}; {rest}", after
    return equation


def console_lines(found: dict, unit: str, label: str, kind: str = "one-step") -> list[str]:
    """The answer on the console: the model, its equation and parameters, the margin, the
    scores and the rows."""
    one = found["one_step"]
    lines = [
        f"best model: {found['model']}, held-out RMSE {_g(one['rmse'])} {unit} of {label} "
        f"({kind}), R² {r2_text(one['r2'])}",
        f"  {equation_text(found)}",
        *(f"  {line}" for line in parameter_lines(found)),
    ]  # fmt: skip
    for text in (margin_text(found, unit), free_run_text(found), rows_text(found)):
        if text:
            lines.append(text)
    return lines
