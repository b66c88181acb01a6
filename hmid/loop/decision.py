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
}


def decision_table(decisions: tuple[Decision, ...] | list[Decision]) -> pd.DataFrame:
    """Every candidate tested, per round: one row per decision, one labelled column per field."""
    return pd.DataFrame(
        [{label: getattr(d, name) for name, label in LABELS.items()} for d in decisions]
    )
