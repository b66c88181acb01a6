"""The comparison table of a sweep: one row per run, as CSV (full values) and Markdown (short).

Columns: ``#`` (position in the sweep), ``run id``, one column per override key, ``status``
(``ok``, ``failed: <reason>`` or ``pending``), the columns of each run's summary (chosen by the
work function), ``warnings`` (how many, when any run had some), ``wall [s]`` and ``folder`` (the
run's own results folder, relative to the sweep folder).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from hmid.files import atomic_path, write_text
from hmid.report import Report, Section, Table, render_markdown
from hmid.sweep._plan import PlannedRun, SweepPlan
from hmid.sweep._records import RunRecord


def _full(value: Any) -> Any:
    return value if isinstance(value, str | int | float | bool) or value is None else (
        json.dumps(value, separators=(",", ":"))
    )  # fmt: skip


def _short(value: Any) -> Any:
    """A log set as its file names; other structured values as compact JSON."""
    if isinstance(value, list) and value and all(
        isinstance(e, dict) and isinstance(e.get("path"), str) for e in value
    ):  # fmt: skip
        return " ".join(Path(e["path"]).name for e in value)
    if isinstance(value, dict) and isinstance(value.get("path"), str):
        return Path(value["path"]).name
    return _full(value)


def _status(run: PlannedRun, record: RunRecord | None) -> str:
    if run.error is not None:
        return f"failed: {run.error}"
    if record is None:
        return "pending"
    return "ok" if record.status == "ok" else f"failed: {record.error}"


def sweep_frame(
    plan: SweepPlan, records: Mapping[str, RunRecord], show: Callable[[Any], Any] = _full
) -> pd.DataFrame:
    """The table as a data frame; ``show`` turns override values into cells."""
    keys = list(dict.fromkeys(k for run in plan.runs for k in run.overrides))
    with_warnings = any(r.warnings for r in records.values())
    rows = []
    for run in plan.runs:
        record = records.get(run.run_id) if run.run_id is not None else None
        row: dict[str, Any] = {"#": run.number, "run id": run.run_id}
        row |= {k: show(run.overrides[k]) if k in run.overrides else None for k in keys}
        row["status"] = _status(run, record)
        row |= record.summary if record is not None else {}
        if with_warnings:
            row["warnings"] = len(record.warnings) if record is not None else None
        row["wall [s]"] = record.wall_s if record is not None else None
        row["folder"] = record.run_dir if record is not None else None
        rows.append(row)
    frame = pd.DataFrame(rows)
    tail = [c for c in ("warnings", "wall [s]", "folder") if c in frame]
    return frame[[c for c in frame if c not in tail] + tail]  # summary columns before the tail


def _shown(frame: pd.DataFrame) -> pd.DataFrame:
    """Cells without a value as missing ("—"), not as NaN."""
    out = frame.copy()
    for column in out:
        if pd.api.types.is_float_dtype(out[column]):
            out[column] = out[column].astype("Float64")
        elif not pd.api.types.is_numeric_dtype(out[column]):
            out[column] = out[column].astype(object).where(out[column].notna(), None)
    return out


def write_table(
    plan: SweepPlan, records: Mapping[str, RunRecord], executor: str = ""
) -> tuple[Path, Path]:
    """Write ``sweep.csv`` and ``sweep.md`` into the sweep folder; returns their paths."""
    frame = sweep_frame(plan, records)
    csv_path, md_path = plan.folder / "sweep.csv", plan.folder / "sweep.md"
    with atomic_path(csv_path) as tmp:
        frame.to_csv(tmp, index=False)
    status = frame["status"]
    counts = {
        "ok": int((status == "ok").sum()),
        "failed": int(status.str.startswith("failed").sum()),
        "pending": int((status == "pending").sum()),
    }
    shown = sweep_frame(plan, records, _short)
    keys = list(dict.fromkeys(k for run in plan.runs for k in run.overrides))
    same = [k for k in keys if all(k in r.overrides for r in plan.runs) and shown[k].nunique() == 1]
    sweep = plan.sweep
    report = Report(
        title=f"hmid sweep: {sweep.name}",
        summary=(
            ("base experiment", str(sweep.base_path.resolve())),
            ("runs", ", ".join(f"{n} {what}" for what, n in counts.items())),
            ("executor", executor or sweep.executor.kind),
            *((f"in every run: {k}", str(shown[k].iloc[0])) for k in same),
            ("table as CSV", csv_path.name),
        ),
        sections=(
            Section(
                "Runs",
                text="One row per run, in sweep order. Each run's own report is in its folder "
                "(relative to this file); `done/<run id>.json` holds its full record.",
                tables=(Table(_shown(shown.drop(columns=same)), "Runs of the sweep"),),
            ),
        ),
    )
    write_text(md_path, render_markdown(report, plan.folder))
    return csv_path, md_path
