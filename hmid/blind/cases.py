"""The cases of a blind suite, their simulated data sets, and what each outcome means."""

from __future__ import annotations

import copy
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from hmid.blind.config import BlindSuite
from hmid.loop.result import Verdict

CLEAN = "clean"
#: how a declared case's outcome names a finding (of the tested parameter that follows)
FINDING = "finding: "


@dataclass(frozen=True)
class Case:
    case_id: str
    effect: str  # a simulator effect kind, or "clean"
    strength: str
    index: int
    seed: int
    params: dict[str, float]
    # the candidates that count as right when named first; None: none should be claimed
    expect: tuple[str, ...] | None
    compare: dict[str, str] = field(default_factory=dict)  # loop parameter -> simulator one
    # a known term declared wrong: {dotted key of the experiment: value}; the data are clean
    declare: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _seed(suite_seed: int, *parts: object) -> int:
    return zlib.crc32(":".join(map(str, (suite_seed, *parts))).encode())


def plan_cases(suite: BlindSuite) -> list[Case]:
    """Clean controls first, then every effect x strength x seed; seeds differ across cases."""
    cases = [
        Case(f"clean-{i}", CLEAN, "-", i, _seed(suite.seed, CLEAN, i), {}, None)
        for i in range(suite.clean_seeds)
    ]
    for effect in suite.effects:
        for strength, params in effect.strengths.items():
            for i in range(suite.seeds):
                cases.append(
                    Case(
                        f"{effect.kind}-{strength}-{i}",
                        effect.kind,
                        strength,
                        i,
                        _seed(suite.seed, effect.kind, strength, i),
                        dict(params),
                        tuple(effect.expect) if effect.expect is not None else None,
                        dict(effect.compare),
                    )
                )
    for declared in suite.declared:
        for strength, values in declared.strengths.items():
            for i in range(suite.seeds):
                cases.append(
                    Case(
                        f"{declared.name}-{strength}-{i}",
                        declared.name,
                        strength,
                        i,
                        _seed(suite.seed, declared.name, strength, i),
                        {},
                        (declared.finding,),
                        declare=dict(values),
                    )
                )
    return cases


def declare(template: dict[str, Any], case: Case) -> dict[str, Any]:
    """The experiment template with ``case``'s declared values (dotted keys) in place."""
    out = copy.deepcopy(template)
    for key, value in case.declare.items():
        *path, last = key.split(".")
        node = out
        for part in path:
            node = node[part]
        node[last] = value
    return out


def dataset_for(template: dict[str, Any], case: Case) -> dict[str, Any]:
    """The data-set config of ``case``: the template with the case's seed and the effect on
    every log (it is a property of the rig, free falls included)."""
    config = {**template, "seed": case.seed, "logs": []}
    for log in template["logs"]:
        effects = list(log.get("effects", ()))
        if case.effect != CLEAN and not case.declare:
            effects.append({"kind": case.effect, **case.params})
        config["logs"].append({**log, "effects": effects})
    return config


def experiment_for(template: dict[str, Any], folder: Path, index: list[dict]) -> dict[str, Any]:
    """The experiment config of a simulated folder: the template with its logs filled in."""
    roles = {"dynamic": "dynamic", "free_fall": "free_fall"}
    logs = [
        {
            "path": str(folder / entry["file"]),
            "columns": str(folder / entry["columns"]),
            "role": roles[entry["kind"]],
        }
        for entry in index
        if entry["kind"] in roles
    ]
    return {**template, "logs": logs}


def _default(kind: str, name: str) -> float:
    from hmid.simulate.effects import make_effect

    return make_effect({"kind": kind}).params()[name]


def outcome(case: Case, result) -> dict[str, Any]:
    """What the loop concluded on ``case`` (a :class:`hmid.loop.LoopResult`), and whether that
    was right: the first effect, or the "indistinguishable" set it heads, holds an expected
    name; "confidently wrong" is a single first name that is not expected (any name, on clean
    data or for an effect outside the library)."""
    added = [e.name for e in result.effects]
    named = result.first_named
    expect = set(case.expect or ())
    row = case.to_dict() | {
        "expect": " | ".join(case.expect) if case.expect else None,
        "first": added[0] if added else None,
        "first named": " | ".join(named),
        "indistinguishable": len(named) > 1,
        "confidently wrong": len(named) == 1 and named[0] not in expect,
        "added": " + ".join(added),
        "verdict": result.verdict.value,
        "rmse before [N]": result.before.rmse,
        "rmse after [N]": result.after.rmse,
        # an addition after which the held-out error rose (reported, never decided on)
        "added, then worse": any(n.startswith("added ") for n in result.notes),
        # every printed interval contains its estimate: those that do not, by table
        "intervals without their estimate": "; ".join(_outside(result)),
        # a second or later addition that is not expected: each case has one effect at most
        "spurious second effect": any(name not in expect for name in added[1:]),
        # the declared terms found wrong (hmid.loop.declared.decide), and the unexpected ones
        "declared found wrong": " + ".join(f.parameter for f in result.findings),
        # judged only where the truth of every declared term is known (None: an effect's data)
        "declared, falsely found": (
            any(f.parameter not in expect for f in result.findings)
            if case.effect == CLEAN or case.declare
            else None
        ),
    }
    if case.compare and added and added[0] in expect:
        table = result.effects[0].parameters.set_index("parameter")
        for loop_name, sim_name in case.compare.items():
            if loop_name not in table.index:
                continue  # a parameter of another expected candidate
            estimate = table.loc[loop_name]
            truth = case.params.get(sim_name, _default(case.effect, sim_name))
            row |= {
                "parameter": loop_name,
                "truth": truth,
                "estimate": float(estimate["value"]),
                "covered": bool(estimate["lower"] <= truth <= estimate["upper"]),
            }
    if case.declare:  # named as a finding, never credited to an effect
        found = [f.parameter for f in result.findings if f.parameter in expect]
        row["first named"] = FINDING + found[0] if found else row["first named"]
        row["correct"] = bool(found) and not added
    elif case.effect == CLEAN:
        row["correct"] = not added
    elif case.expect is None:
        row["correct"] = not added and result.verdict is Verdict.PATTERN_REMAINS
    else:
        row["correct"] = bool(expect & set(named))
    return row


def _outside(result) -> list[str]:
    """Every parameter of the loop's tables whose interval excludes its estimate."""
    from hmid.loop.result import outside

    tables = [(result.base_name, result.base_parameters)]
    for e in result.effects:
        tables += [(e.name, e.parameters), *((a.name, a.parameters) for a in e.alternatives)]
    return [f"{name}: {p}" for name, table in tables for p in outside(table)]
