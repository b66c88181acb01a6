"""Physical-sign findings: only a positive parameter whose whole interval is negative is flagged,
and the message names the channel behind it."""

import pandas as pd

from hmid.balance import sign_findings

TABLE = pd.DataFrame(
    {
        "parameter": ["M", "Fv", "offset", "k3"],
        "value": [-95.0, 2.0, -3.0, -1.0],
        "lower": [-96.0, -1.0, -3.1, -3.0],
        "upper": [-94.0, 5.0, -2.9, 1.0],
        "unit": ["kg", "N·s/m", "N", "N/m³"],
        "positive": [True, True, False, True],
    }
)


def test_only_a_positive_parameter_wholly_below_zero_is_flagged():
    reads = {"M": ("a",), "Fv": ("v",), "offset": (), "k3": ("x",)}
    (finding,) = sign_findings("balance", TABLE, reads, position="x")
    assert finding.parameter == "M" and finding.channels == ("x",)  # a comes from x
    text = finding.message()
    assert text.startswith("balance: M = -95 kg (interval -96 … -94) is negative")
    assert "rig.channels.x.sign: -1" in text and "\n" not in text
    assert finding.to_dict()["message"] == text


def test_a_familys_declared_positive_terms_are_checked():
    from hmid.balance.checks import declared_positive

    table = pd.DataFrame(
        {
            "term": ["1", "x", "P", "tanh(v/v0)", "v"],
            "value": [5.0, -400.0, -2e-5, -0.3, 0.0],
            "unit": ["N", "N/m", "N/Pa", "N", "N·s/m"],
            "ci_low (95%)": [4.9, -420.0, -3e-5, -0.4, float("nan")],
            "ci_high (95%)": [5.1, -380.0, -1e-5, -0.2, float("nan")],
        }
    )
    found = declared_positive("sindy:stlsq", table, ["P", "tanh(v/v0)", "v"], position="x")
    assert [f.parameter for f in found] == ["P", "tanh(v/v0)"]  # x is not declared; v left out
    assert found[0].channels == ("P",) and found[1].channels == ("x",)
    assert declared_positive("poly:x", table, (), position="x") == ()
