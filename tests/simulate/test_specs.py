"""The muscle specifications' scaling law: the thesis muscle, the exponents, the scatter."""

import math

import pytest
from pydantic import ValidationError

from hmid.simulate.params import MuscleParams
from hmid.simulate.specs import MuscleSpec, Scatter


def test_the_default_build_is_the_simulators_default_muscle():
    law, default = MuscleSpec().params(), MuscleParams()
    for name in ("A_eff", "k1", "k3", "k2", "tau"):
        assert getattr(law, name) == pytest.approx(getattr(default, name), rel=0.02), name


def test_the_parameters_scale_with_the_physically_expected_exponents():
    base = MuscleSpec()
    longer = base.model_copy(update={"length": 2 * base.length}).params()
    p = base.params()
    assert longer.k1 == pytest.approx(p.k1 / 2)
    assert longer.k2 == pytest.approx(p.k2 / 2)
    assert longer.k3 == pytest.approx(p.k3 / 8)
    assert longer.A_eff == pytest.approx(p.A_eff) and longer.tau == p.tau
    wider = MuscleSpec(inner_diameter=0.02, outer_diameter=0.0226).params()
    assert wider.A_eff / p.A_eff == pytest.approx((0.02 / 0.016) ** 2)
    wall = math.pi * (0.0226**2 - 0.02**2) / 4
    assert wider.k1 == pytest.approx(1.5e6 * wall / 0.035)


def test_a_drawn_muscle_is_off_the_law_and_reproducible():
    spec = MuscleSpec()
    a, b = spec.draw(Scatter(), seed=3), spec.draw(Scatter(), seed=3)
    assert a == b
    assert a != spec.params()
    assert spec.draw(Scatter(A_eff=0, k1=0, k3=0, k2=0, tau=0), seed=3) == spec.params()


@pytest.mark.parametrize(
    "bad", [{"outer_diameter": 0.015}, {"sheath_diameter": 0.018}, {"length": -1.0}]
)
def test_an_impossible_build_is_refused(bad):
    with pytest.raises(ValidationError):
        MuscleSpec(**bad)
