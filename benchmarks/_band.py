"""Shared by the band benchmarks: a config's exported models and one free run's band coverage.

The config is analysed up to its export (the stage cache in a folder of the caller's), each
exported model read back as the run's free-run stage reads it (its posterior draws where its
family has them), and run free as that stage runs it (``hmid.pipeline.stages.free_run_or_why``,
on the same rows).
"""

from __future__ import annotations

from pathlib import Path


def exported(config, cache: Path) -> tuple[object, list[tuple[str, object]]]:
    """The free runs' rows of ``config`` and its exported models, by name (those exported)."""
    from hmid.portable import Model
    from pipelines.identify import analyse

    found = analyse(config, ("freerun_blocks", "fit", "export"), cache)
    models = []
    for fitted in found["fit"]:
        document = found["export"].get(fitted.name)
        if document is None or isinstance(document, str):
            continue
        posterior = getattr(fitted.model, "posterior_draws", None)
        models.append((fitted.name, Model(document, draws=posterior() if posterior else None)))
    return found["freerun_blocks"].rows, models


def band_coverage(model, held, seed: int, draws: int | None = None) -> float:
    """The held-out coverage (%) of ``model``'s free-run band with ``seed`` (NaN: no band)."""
    from hmid.pipeline import stages

    run = stages.free_run_or_why(model, held.signals, held.spans,
                                 draws=draws or stages.FREE_RUN_DRAWS,
                                 level=stages.FREE_RUN_LEVEL, seed=seed, held=held)  # fmt: skip
    return 100 * run.scores().get("band coverage", float("nan"))
