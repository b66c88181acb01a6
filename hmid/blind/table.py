"""The blind suite's table (effect x strength) and its pass marks."""

from __future__ import annotations

import pandas as pd

from hmid.blind.cases import CLEAN
from hmid.blind.config import BlindSuite
from hmid.loop.result import Verdict

#: The outcomes' verdict column holds each verdict's value (its report wording).
REMAINS = Verdict.PATTERN_REMAINS.value


def suite_table(outcomes: pd.DataFrame) -> pd.DataFrame:
    """One row per effect and strength: how often the loop got it right, and the errors."""
    rows = []
    for (effect, strength), group in outcomes.groupby(["effect", "strength"], sort=False):
        expect = group["expect"].iloc[0]
        expect = None if pd.isna(expect) else expect
        added = group["added"].fillna("") != ""
        rows.append(
            {
                "effect": effect,
                "strength": strength,
                "expected": expect if expect is not None else ("none" if effect == CLEAN else "—"),
                "runs": len(group),
                "right first": group["correct"].mean() if expect else float("nan"),
                "of which indistinguishable": (
                    (group["correct"] & group["indistinguishable"]).mean()
                    if expect
                    else float("nan")
                ),
                "confidently wrong": group["confidently wrong"].mean(),
                "any effect added": added.mean(),
                "added, then held-out worse": _share(group, "added, then worse"),
                "spurious second effect": _share(group, "spurious second effect"),
                "declared falsely found": _share(group, "declared, falsely found"),
                f"'{REMAINS}'": (group["verdict"] == REMAINS).mean(),
                "correct": group["correct"].mean(),
                "RMSE before [N]": group["rmse before [N]"].median(),
                "RMSE after [N]": group["rmse after [N]"].median(),
                **_recovery(group),
                "first named (counts)": ", ".join(
                    f"{k or 'none'}: {v}"
                    for k, v in group["first named"].fillna("").value_counts().items()
                ),
            }
        )
    return pd.DataFrame(rows)


def _share(group: pd.DataFrame, column: str) -> float:
    """The share of runs where ``column`` holds (a failed case has no such column)."""
    if column not in group:
        return 0.0
    return float(group[column].astype("boolean").fillna(False).astype(bool).mean())


def _recovery(group: pd.DataFrame) -> dict:
    """Median estimate / truth of the compared parameter and its interval's coverage."""
    if "estimate" not in group or group["estimate"].isna().all():
        return {"parameter": "", "estimate / truth": float("nan"), "95 % CI covers truth": ""}
    known = group.dropna(subset=["estimate"])
    ratio = (known["estimate"] / known["truth"]).median()
    return {
        "parameter": known["parameter"].iloc[0],
        "estimate / truth": ratio,
        "95 % CI covers truth": f"{int(known['covered'].sum())}/{len(known)}",
    }


def suite_counts(outcomes: pd.DataFrame) -> pd.DataFrame:
    """Counts over every run of the suite: additions after which the held-out error rose,
    spurious second effects, declared terms found wrong where none was, runs with an interval
    that excludes its estimate (each of ``runs``: the runs it can happen in)."""
    added = outcomes.get("added", pd.Series("", outcomes.index)).fillna("") != ""
    judged = outcomes.get("declared, falsely found", pd.Series(None, outcomes.index)).notna()
    outside = outcomes.get("intervals without their estimate", pd.Series("", outcomes.index))
    rows = [
        ("added, then held-out worse", _count(outcomes, "added, then worse"), added.sum()),
        ("a spurious second effect added", _count(outcomes, "spurious second effect"),
         added.sum()),
        ("a declared term found wrong where none is (clean and declared cases)",
         _count(outcomes[judged], "declared, falsely found"), judged.sum()),
        ("an interval without its estimate", (outside.fillna("").astype(str) != "").sum(),
         len(outcomes)),
    ]  # fmt: skip
    return pd.DataFrame([(w, int(c), int(n)) for w, c, n in rows],
                        columns=["what", "runs", "of runs"])  # fmt: skip


def _count(group: pd.DataFrame, column: str) -> int:
    return round(_share(group, column) * len(group)) if len(group) else 0


def check_targets(outcomes: pd.DataFrame, suite: BlindSuite) -> pd.DataFrame:
    """Each pass mark with the measured rate; ``met`` says whether it holds."""
    t = suite.targets
    rows = []
    for effect in suite.effects:
        group = outcomes[(outcomes["effect"] == effect.kind) & (outcomes["strength"] == t.strength)]
        if group.empty:
            continue
        if effect.expect is None:
            rate = group["correct"].mean()
            label = f"{effect.kind} ({t.strength}): no effect claimed, 'unexplained structure'"
            rows.append((label, rate, ">=", t.unexplained))
        else:
            rate = group["correct"].mean()
            names = " or ".join(effect.expect)
            label = f"{effect.kind} ({t.strength}): {names} named first (alone or among rivals)"
            rows.append((label, rate, ">=", t.right_first))
    for declared in suite.declared:
        group = outcomes[(outcomes["effect"] == declared.name)
                         & (outcomes["strength"] == t.strength)]  # fmt: skip
        if not group.empty:
            label = f"{declared.name} ({t.strength}): the wrong declared term named, no effect"
            rows.append((label, group["correct"].mean(), ">=", t.right_first))
    clean = outcomes[outcomes["effect"] == CLEAN]
    if not clean.empty:
        rate = (clean["added"].fillna("") != "").mean()
        rows.append(("clean: an effect added", rate, "<=", t.false_additions))
        rate = _share(clean, "declared, falsely found")
        rows.append(("clean: a declared term found wrong", rate, "<=", t.false_additions))
    moderate = outcomes[(outcomes["effect"] != CLEAN) & (outcomes["strength"] == t.strength)]
    if not moderate.empty:
        rate = moderate["confidently wrong"].mean()
        label = f"every effect ({t.strength}): a confidently wrong single name"
        rows.append((label, rate, "<=", t.confidently_wrong))
        rate = _share(moderate, "spurious second effect")
        label = f"every effect ({t.strength}): a spurious second effect added"
        rows.append((label, rate, "<=", t.false_additions))
    if "intervals without their estimate" in outcomes:
        outside = outcomes["intervals without their estimate"].fillna("").astype(str) != ""
        rows.append(("every run: an interval without its estimate (runs)", int(outside.sum()),
                     "<=", 0))  # fmt: skip
    frame = pd.DataFrame(rows, columns=["target", "measured", "rule", "mark"])
    frame["met"] = [
        m >= k if r == ">=" else m <= k
        for m, r, k in zip(frame["measured"], frame["rule"], frame["mark"], strict=True)
    ]
    return frame
