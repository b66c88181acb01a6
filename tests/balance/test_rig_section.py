"""The rig section: what it declares, what it derives, and one-line errors for what it cannot be."""

import pytest
from pydantic import ValidationError

from hmid.balance import RigSection
from hmid.errors import ConfigError

STAGE = {
    "channels": {"x": {}},
    "position": "x",
    "explained": "u",
    "balance": [
        {"kind": "channel", "name": "M", "channel": "a", "positive": True, "unit": "kg"},
        {"kind": "channel", "name": "Fv", "channel": "v", "positive": True},
        {"kind": "coulomb", "name": "Fc"},
        {"kind": "constant", "name": "offset"},
    ],
}
LOGGED = {"x": "m", "u": "N"}


def rig(**changes) -> RigSection:
    return RigSection.model_validate(STAGE | changes)


def test_a_linear_motor_stage_is_one_config_section():
    stage = rig()
    assert stage.model_channels == ("x", "v", "a")
    assert stage.log_channels == ("x", "u")
    assert [t.name for t in stage.fitted] == ["M", "Fv", "Fc", "offset"]
    assert stage.slot is None and stage.known == () and stage.resolved_friction_sign == 1
    units = stage.units(LOGGED)
    assert units == {"x": "m", "u": "N", "v": "m/s", "a": "m/s^2", "target": "N"}
    stage.check_units(units, "stage.yaml")  # kg is the unit of M·a in N


def test_a_rig_without_a_force_sensor_explains_known_parts():
    knee = rig(
        explained={"name": "inertial force", "parts": [
            {"channel": "a", "value": 750, "unit": "g"}, {"value": 4.903325, "unit": "N"}]},
        balance=[{"kind": "model"}, {"kind": "coulomb", "name": "Fc", "sign": -1}],
        channels={"x": {}, "P": {}},
    )  # fmt: skip
    units = knee.units({"x": "m", "P": "Pa"})
    assert units["target"] == "N" and knee.log_channels == ("x", "P")
    assert knee.part_values(units) == pytest.approx([0.75, 4.903325])  # 750 g is 0.75 kg
    assert knee.resolved_friction_sign == -1 and knee.slot.name == "F_m"


def test_known_coefficients_convert_their_declared_unit():
    weighed = rig(balance=[{"kind": "channel", "name": "M", "channel": "a", "value": 95000,
                            "unit": "g"}, {"kind": "constant", "name": "offset"}])  # fmt: skip
    units = weighed.units(LOGGED)
    assert weighed.term_value(weighed.balance[0], units) == pytest.approx(95.0)
    assert [t.name for t in weighed.known] == ["M"]


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"position": "y"}, "position 'y' is not among channels"),
        ({"channels": {"x": {}, "v": {}}}, r"channel names \['v'\] are derived"),
        ({"balance": [{"kind": "channel", "name": "k", "channel": "z"}]}, r"reads \['z'\]"),
        (
            {
                "balance": [{"kind": "channel", "name": "k", "channel": "u"}],
                "channels": {"x": {}, "u": {}},
            },
            "reads the explained quantity's channel",
        ),
        ({"balance": [{"kind": "model"}, {"kind": "model", "name": "G"}]}, "at most one"),
        (
            {"balance": [{"kind": "constant", "name": "c"}, {"kind": "coulomb", "name": "c"}]},
            r"share names \['c'\]",
        ),
        (
            {"balance": [{"kind": "coulomb", "name": "Fc", "from": "free_fall"}]},
            "add a free_fall section",
        ),
        (
            {
                "balance": [
                    {"kind": "coulomb", "name": "a1"},
                    {"kind": "coulomb", "name": "a2", "sign": -1},
                ]
            },
            "different signs",
        ),
        ({"friction_sign": -1}, "contradicts the Coulomb terms' sign"),
        (
            {"balance": [{"kind": "memory", "name": "k2", "channel": "x", "value": 1.0}]},
            "fix its parameter too",
        ),
        ({"balance": [{"kind": "constant", "name": "c", "value": 1.0}]}, "nothing to identify"),
        ({"balance": [{"kind": "spring", "name": "k"}]}, "term kind 'spring' is unknown"),
        ({"balance": [{"kind": "constant", "name": "c", "sing": -1}]}, "'sing': unknown key"),
        ({"balance": [{"kind": "channel", "name": "c", "channel": "x^^2"}]}, "cannot read term"),
        (
            {"explained": {"name": "f", "parts": [{"channel": "a"}]}, "position": None},
            "declare the position",
        ),
    ],
)
def test_impossible_rigs_are_errors_that_say_why(changes, match):
    with pytest.raises((ValidationError, ConfigError), match=match):
        rig(**changes)


def test_a_declared_unit_must_be_the_unit_the_balance_implies():
    wrong = rig(balance=[{"kind": "channel", "name": "M", "channel": "a", "unit": "kg/s"}])
    with pytest.raises(ConfigError, match=r"^s\.yaml: key 'rig\.balance\.0\.unit': 'kg/s' is"):
        wrong.check_units(wrong.units(LOGGED), "s.yaml")
    mixed = rig(
        explained={"name": "f", "parts": [{"channel": "a", "value": 1, "unit": "kg"},
                                          {"channel": "x", "value": 1}]},
        balance=[{"kind": "constant", "name": "c"}],
    )  # fmt: skip
    with pytest.raises(ConfigError, match=r"rig\.explained\.parts\.1: its unit m is not that of"):
        mixed.units(LOGGED)
