"""What the loop decided about each candidate of each round, as typed fields.

The engine decides on these fields alone; the report renders them as the table of every
candidate tested (:func:`decision_table`, the one place a field gets its column label), so that
renaming a column can change no selection.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd


@dataclass(frozen=True)
class Decision:
    """One candidate in one round: its nested test on the training rows, its blocked
    cross-validation (where it passed the test) and the verdict on it.

    A candidate is *added* when it passes training (Holm-adjusted p below alpha, ΔBIC below 0,
    identified), is *selected* (cross-validation confidently better) and ranks first on ΔBIC at
    the common n_eff; a selected rival of the added one that cross-validates not clearly worse
    is *indistinguishable* from it."""

    round: int
    candidate: str
    profiled: str  # its profiled parameter with interval ("" if it has none)
    partial_r: float  # the residual's correlation with its (nonlinear) features, jointly
    f: float
    n_eff: float  # of its own residual: what decides significance
    p: float
    p_holm: float  # Holm-adjusted over the round's candidates
    delta_bic: float  # on its own n_eff
    delta_bic_common: float  # on the round's common n_eff: what ranks the selected
    identified: bool
    passes_training: bool
    cv_change: float = float("nan")  # relative change of the out-of-fold RMSE
    cv_upper: float = float("nan")  # its bootstrap upper bound
    selected: bool = False
    added: bool = False
    vs_added: float = float("nan")  # its out-of-fold RMSE relative to the added one's, less 1
    indistinguishable: bool = False
    # where the split holds out whole logs: the change with every training log left out whole
    # (selection needs both this and cv_change confidently better)
    cv_across: float = float("nan")
    cv_across_upper: float = float("nan")


#: The report's column label of each field, in the table's order.
LABELS: dict[str, str] = {
    "round": "round",
    "candidate": "candidate",
    "profiled": "profiled",
    "partial_r": "partial R",
    "f": "F",
    "n_eff": "n_eff",
    "p": "p",
    "p_holm": "p (Holm)",
    "delta_bic": "ΔBIC",
    "delta_bic_common": "ΔBIC (common n_eff)",
    "identified": "identified",
    "passes_training": "passes training",
    "cv_change": "CV change",
    "cv_upper": "CV upper bound",
    "selected": "selected",
    "added": "added",
    "vs_added": "vs added (CV)",
    "indistinguishable": "indistinguishable",
    "cv_across": "CV change, logs left out",
    "cv_across_upper": "its upper bound",
}
#: columns only a loop that cross-validated across logs has
ACROSS = ("cv_across", "cv_across_upper")


def decision_table(decisions: tuple[Decision, ...] | list[Decision]) -> pd.DataFrame:
    """Every candidate tested, per round: one row per decision, one labelled column per field
    (those of the cross-validation across logs only where it was done)."""
    across = any(d.cv_across == d.cv_across for d in decisions)  # any not NaN
    labels = {k: v for k, v in LABELS.items() if across or k not in ACROSS}
    return pd.DataFrame(
        [{label: getattr(d, name) for name, label in labels.items()} for d in decisions]
    )
