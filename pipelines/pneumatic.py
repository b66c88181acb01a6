"""Measured-data study: the loop on a pneumatic cylinder's friction logs, one seal at a time.

Wires hmid.studies.pneumatic (data preparation) and hmid.loop (analysis, report section) into a
run folder: report.html/.md, metrics.json, tables/, figures/, manifest.json, study.yaml.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from hmid.errors import HmidError
from hmid.files import atomic_path, write_json, write_text
from hmid.loop import run_loop
from hmid.loop.report import loop_section
from hmid.report import Report, Section, Table, write_report
from hmid.runs import Manifest, git_state, new_run_dir, versions
from hmid.studies.pneumatic import load_study, prepare


class DataAbsent(HmidError, FileNotFoundError):
    """The shared measured data are not on this machine: the study is skipped."""


def _csv(frame: pd.DataFrame, path: Path) -> None:
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)


def run(study_path: Path, *, results: Path = Path("results")) -> tuple[Path, dict]:
    study = load_study(study_path)
    folder = study.data_dir()
    if not folder.is_dir():
        raise DataAbsent(
            f"{folder} does not exist: the pneumatic logs are not on this machine (see "
            "PROVENANCE.md in ../shared/data/pneumatic-friction, or set HMID_SHARED_DATA)"
        )
    files = study.files()
    resolved = json.dumps(study.model_dump(mode="json", exclude={"base_dir"}), sort_keys=True)
    run_dir = new_run_dir(Path(results), study.name, resolved).resolve()
    manifest = Manifest(run_dir, json.loads(resolved), 0)
    for path in [Path(study_path), study.resolve(study.columns)]:
        manifest.add_input(path)
    write_text(run_dir / "study.yaml", Path(study_path).read_text(encoding="utf-8"))
    tables, figures = run_dir / "tables", run_dir / "figures"
    tables.mkdir()
    figures.mkdir()
    sections, summary, metrics = [], [], {"study": study.name, "seals": {}}
    for seal, seal_files in files.items():
        for _, path in seal_files:
            manifest.add_input(path)
        with manifest.stage(f"loop {seal}"):
            data, pieces = prepare(study, seal_files)
            result = run_loop(data, study.loop)
        prefix = f"{seal}_loop".replace(" ", "_")
        section, seal_metrics = loop_section(
            result,
            figures,
            lambda frame, name: _csv(frame, tables / name),
            prefix=prefix,
            title=f"Seal {seal}",
        )
        _csv(pieces, tables / f"{prefix}_pieces.csv")
        sections.append(
            Section(
                section.title,
                text=section.text,
                tables=(
                    *section.tables,
                    Table(pieces, "Log pieces between logger gaps (all used unless marked)"),
                ),
                figures=section.figures,
                subsections=section.subsections,
            )
        )
        metrics["seals"][seal] = seal_metrics
        added = ", ".join(e.title for e in result.effects) or "none"
        summary.append(
            (
                f"seal {seal}",
                f"{result.verdict}; added: {added}; held-out RMSE (one-step) "
                f"{result.before.rmse:.4g} → {result.after.rmse:.4g} N",
            )
        )
    write_json(run_dir / "metrics.json", metrics)
    git = git_state()
    provenance = {
        "study": str(study_path),
        "data": str(folder),
        "git commit": f"{git['commit']}{' (dirty)' if git['dirty'] else ''}",
        **{f"version {k}": str(v) for k, v in versions().items()},
    }
    report = Report(
        title=f"hmid measured-data study: {study.name}",
        summary=(
            ("base model", f"{study.loop.base.title}: `{study.loop.base.equation()}`"),
            (
                "fitted / held-out pressures [bar]",
                f"{list(study.train_pressures)} / {list(study.validation_pressures)}",
            ),
            *summary,
        ),
        sections=tuple(sections),
        provenance=provenance,
    )
    with manifest.stage("report"):
        write_report(report, run_dir)
    manifest.write()
    return run_dir, metrics
