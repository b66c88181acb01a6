"""CONTRIBUTING.md's worked example: a whole model family in under 80 lines, run through the same
contract as the shipped families (tests/families/test_contract.py).

The family fills the rig's model slot with a linear spring, F_m = A P + F0 - k x, fitted by least
squares on the balance's own terms (so the loop can refit it, and its intervals are the balance
family's). A real family lives in hmid/families/<name>.py and is imported by
hmid/families/__init__.py; defining the class registers it under its ``family`` name.
"""

from typing import Literal

import numpy as np
from test_contract import test_every_family_honours_the_fit_contract as honours_contract
from test_contract import test_every_family_states_terms_the_loop_can_refit as refittable

from hmid.balance import RigSection, Structure, fit_structure, make_term, parameters
from hmid.balance.inference import CALIBRATED_TAU
from hmid.families import (
    FAMILIES,
    FamilySpec,
    FitContext,
    FitData,
    FitSummary,
    Fitted,
    FittedTerms,
)
from hmid.intervals import IntervalNote
from hmid.stats import residual_tau_int


class LinearSpringSpec(FamilySpec):  # 1. a config section, named by its ``family`` literal
    """The actuator force as A P + F0 - k x (``models: [{family: linear_spring}]``)."""

    family: Literal["linear_spring"] = "linear_spring"
    confidence: float = 0.95

    def check(self, rig: RigSection) -> None:  # can it model this rig? (one-line errors)
        super().check(rig)  # a slot to fill, every other term known
        self.channels_needed(rig, ["P", rig.position])

    def fit(self, data: FitData, context: FitContext) -> list[Fitted]:  # 2. FitData: the rows
        s, x = data.slot_sign, data.rig.position  # 3. terms in the rig language
        terms = [make_term({"kind": "channel", "name": "A", "channel": "P", "sign": s}),
                 make_term({"kind": "constant", "name": "F0", "sign": s}),
                 make_term({"kind": "channel", "name": "k", "channel": x, "sign": -s,
                            "positive": True})]  # fmt: skip
        fitted = fit_structure(Structure.of(terms), data.signals)  # on the training rows
        tau = residual_tau_int(fitted.residual, data.signals)
        return [
            Fitted(  # 4. what the comparison, the report and the loop read
                name="linear_spring",
                family=self.family,
                # 5. a model that predicts any rows and states its terms
                model=FittedTerms(fitted.structure, fitted.columns.names, fitted.fit.coef.copy()),
                kind="one-step",
                fit_summary=FitSummary.of_fit(
                    self.family,
                    "linear_spring",
                    data.y,
                    fitted.prediction[data.rows],
                    3,
                    tau_int=tau,
                ),
                coefficients=parameters(fitted, data.signals, self.confidence),
                equation="F_m = A P + F0 - k x",
                interval=IntervalNote(  # 6. what its intervals are, who calibrated them
                    self.confidence,
                    "OLS + autocovariance sandwich",
                    tau,
                    CALIBRATED_TAU,
                    "benchmarks/bench_calibration_balance.py",
                ),
            )
        ]


# The shipped pipeline's registry stays as it was: the example is checked here, not offered.
FAMILIES.pop(LinearSpringSpec.model_fields["family"].default)


def test_the_example_family_honours_the_fit_contract(ch4_split, tmp_path):
    config, split, friction, root = ch4_split
    spec = LinearSpringSpec.example(config.rig)
    spec.check(config.rig)
    signals = split.signals
    hidden = signals.with_columns(target=np.where(signals.train, signals.target, np.nan))
    fitted = spec.fit(FitData(hidden, config.rig), FitContext(5, root / spec.family, friction))
    fits = {spec.family: (spec, fitted)}
    honours_contract(spec.family, fits, ch4_split, tmp_path)
    refittable(spec.family, fits, ch4_split)
    table = fitted[0].coefficients.set_index("parameter")
    assert table.loc["k", "value"] > 0 and table.loc["A", "value"] > 0  # a spring, a piston
