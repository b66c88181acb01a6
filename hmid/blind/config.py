"""A blind suite: simulated logs with an undeclared effect, run through the standard pipeline.

The suite names a data-set template (``hmid simulate`` format, no extra effects), an experiment
template (its ``logs`` are filled in per case) and the simulator effects to switch on, each at
named strengths and with the candidate effect that should explain it (a name, or the names that
each count as right, such as a delay or a lag of the same sensor; ``expect: null`` for an effect
the library deliberately lacks). Clean cases (no effect) are the negative controls. Declared
cases simulate clean data and declare a known term wrong (a free-fall mass): the loop must name
the inconsistency as a finding, not credit it to an effect.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from hmid.config import load_yaml_model
from hmid.errors import ConfigError
from hmid.sweep._config import ExecutorSection


class _Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class EffectCases(_Frozen):
    kind: str  # a simulator effect (hmid.simulate.effects)
    # the loop candidate(s) that explain it; None: outside the library
    expect: tuple[str, ...] | None
    strengths: Annotated[dict[str, dict[str, float]], Field(min_length=1)]
    # {loop parameter: simulator parameter} whose estimate is compared with the truth
    compare: dict[str, str] = {}

    @field_validator("expect", mode="before")
    @classmethod
    def _names(cls, expect):
        return (expect,) if isinstance(expect, str) else expect

    @model_validator(mode="after")
    def _known(self) -> EffectCases:
        from hmid.simulate.effects import make_effect

        for params in self.strengths.values():
            try:
                effect = make_effect({"kind": self.kind, **params})
            except ConfigError as err:
                raise ValueError(str(err)) from None
            unknown = set(self.compare.values()) - set(effect.params())
            if unknown:
                raise ValueError(f"compare: {sorted(unknown)} are no parameters of {self.kind!r}")
        return self


class DeclaredCases(_Frozen):
    """A declared term taken as known, declared wrong: the data are clean (simulated with the
    template's rig), the experiment ``declare``s other values (dotted keys into the experiment
    template: ``rig.free_fall.mass``), at named strengths. The loop must name the inconsistency
    (a finding, never an effect): ``finding`` is the tested parameter whose finding names it or
    an honest set containing it (dFc, the friction level, for a wrong free-fall mass;
    ``motion.mass``; a correction ``d<name>`` of a known value)."""

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_]+$")]
    strengths: Annotated[dict[str, dict[str, float]], Field(min_length=1)]
    finding: str = "dFc"


class Targets(_Frozen):
    """Pass marks at ``strength``: the right effect first (alone, or in an "indistinguishable"
    set); an effect added on clean data; a confidently wrong single name (over all cases with an
    effect); no claim and "unexplained structure" for effects outside the library."""

    strength: str = "moderate"
    right_first: Annotated[float, Field(ge=0, le=1)] = 0.9
    false_additions: Annotated[float, Field(ge=0, le=1)] = 0.05
    confidently_wrong: Annotated[float, Field(ge=0, le=1)] = 0.05
    unexplained: Annotated[float, Field(ge=0, le=1)] = 0.9


class BlindSuite(_Frozen):
    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")]
    seed: Annotated[int, Field(ge=0)]
    dataset: Path  # simulate config template, relative to the suite file
    experiment: Path  # experiment template (logs are filled in), relative to the suite file
    seeds: Annotated[int, Field(ge=1)]  # per effect and strength
    clean_seeds: Annotated[int, Field(ge=0)]
    effects: Annotated[tuple[EffectCases, ...], Field(min_length=1)]
    declared: tuple[DeclaredCases, ...] = ()  # a known term declared wrong
    targets: Targets = Targets()
    executor: ExecutorSection = ExecutorSection(workers=1)
    base_dir: Path = Path(".")

    @field_validator("effects")
    @classmethod
    def _unique(cls, effects):
        kinds = [e.kind for e in effects]
        if len(set(kinds)) != len(kinds):
            raise ValueError("an effect kind is listed twice")
        return effects

    def check_expectations(self, offered: set[str], source: str) -> None:
        """ConfigError (one line) if an expected name is no candidate the rig is offered."""
        for i, effect in enumerate(self.effects):
            unknown = sorted(set(effect.expect or ()) - offered)
            if unknown:
                raise ConfigError(
                    f"{source}: effects.{i}.expect: {unknown} are no candidates of this rig; it "
                    f"offers {sorted(offered)}"
                )

    def resolve(self, path: Path) -> Path:
        return path if path.is_absolute() else self.base_dir / path


def load_suite(path: str | Path) -> BlindSuite:
    path = Path(path)
    suite = load_yaml_model(path, BlindSuite).model_copy(update={"base_dir": path.parent})
    for key in ("dataset", "experiment"):
        target = suite.resolve(getattr(suite, key))
        if not target.is_file():
            raise ConfigError(f"{path}: key {key!r}: file {target} does not exist")
    return suite
