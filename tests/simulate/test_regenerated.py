"""The shipped-data comparison forgives last-digit rounding and nothing else."""

import json

import pytest
from _regenerated import differences


def _write(folder, truth, rows):
    folder.mkdir()
    (folder / "a.truth.json").write_text(json.dumps(truth))
    (folder / "a.csv").write_text("t_ms,x_mm\n" + "".join(f"{t},{x}\n" for t, x in rows))
    (folder / "index.yaml").write_text("logs: [{name: a, kind: dynamic}]\n")


TRUTH = {"seed": 3, "checks": {"min_string_tension_N": 4.212948152261052, "stops": 2}}
ROWS = [(1, 0.0123456789), (2, 4.212948152)]


def test_last_digit_rounding_is_no_difference(tmp_path):
    _write(tmp_path / "a", TRUTH, ROWS)
    moved = {**TRUTH, "checks": {**TRUTH["checks"], "min_string_tension_N": 4.212948152261043}}
    _write(tmp_path / "b", moved, [(1, 0.0123456789), (2, 4.212948153)])  # 10th digit
    assert differences(tmp_path / "a", tmp_path / "b") == []


@pytest.mark.parametrize(
    ("truth", "rows", "where"),
    [
        ({**TRUTH, "seed": 4}, ROWS, "a.truth.json.seed"),
        ({**TRUTH, "checks": {"min_string_tension_N": 4.2129482, "stops": 2}}, ROWS, "tension"),
        ({**TRUTH, "checks": {"stops": 2}}, ROWS, "keys"),
        (TRUTH, [(1, 0.0123456789), (2, 4.21294816)], "a.csv[2]"),  # one ADC count of 1e-8
        (TRUTH, [(1, 0.0123456789)], "a.csv: 3 items != 2"),
    ],
)
def test_a_real_change_is_a_difference(tmp_path, truth, rows, where):
    _write(tmp_path / "a", TRUTH, ROWS)
    _write(tmp_path / "b", truth, rows)
    found = differences(tmp_path / "a", tmp_path / "b")
    assert found and where in " ".join(found)
