"""The real pneumatic-cylinder friction logs load with the shipped column map, in SI units.

The files live outside the project (../shared/data/pneumatic-friction, or $HMID_SHARED_DATA/
pneumatic-friction); these tests skip when they are absent.
"""

import math
import os
import re
from pathlib import Path

import numpy as np
import pytest

from hmid.errors import HmidWarning, LogError
from hmid.io import Log, load_column_map, read_log

pytestmark = pytest.mark.shared_data

REPO = Path(__file__).resolve().parents[2]
COLUMN_MAP = REPO / "configs" / "logs" / "pneumatic-friction.yaml"
NAMES = [f"{seal}_{bar}bar.csv" for seal in ("NAPN", "O-ring", "PK") for bar in (1, 3, 5, 7)]
PISTON_AREA = math.pi * 0.0125**2  # m^2, 25 mm bore (PROVENANCE.md)


def data_dir() -> Path:
    shared = os.environ.get("HMID_SHARED_DATA")
    root = Path(shared) if shared else REPO.parent / "shared" / "data"
    folder = root / "pneumatic-friction"
    if not folder.is_dir():
        pytest.skip(f"real pneumatic logs not found at {folder} (set HMID_SHARED_DATA)")
    return folder


@pytest.fixture(scope="module")
def logs() -> dict[str, Log]:
    folder = data_dir()
    columns = load_column_map(COLUMN_MAP)
    with pytest.warns(HmidWarning, match="gap"):  # every file has logger gaps of ~0.27 s or more
        return {name: read_log(folder / name, columns) for name in NAMES}


def test_all_twelve_files_load(logs):
    assert sorted(p.name for p in data_dir().glob("*.csv")) == sorted(NAMES)
    for name, log in logs.items():
        assert log.channels == ("x_raw", "P_raw", "F_raw", "x", "P", "F"), name
        assert dict(log.units) == {
            "t": "s",
            "x_raw": "V",
            "P_raw": "V",
            "F_raw": "V",
            "x": "m",
            "P": "Pa",
            "F": "N",
        }
        assert 6_000 < len(log) < 11_000, name  # 6907 to 10321 rows
        # no saturation; the logger's gaps (27-266 x the 10 ms step) are reported, not hidden
        assert len(log.flags) == 1 and "gap(s) longer than 3 x" in log.flags[0], name
        assert re.fullmatch(r"[0-9a-f]{64}", str(log.meta["sha256"])), name
    assert len({log.meta["sha256"] for log in logs.values()}) == 12


@pytest.mark.parametrize("name", NAMES)
def test_physical_ranges(logs, name):
    log = logs[name]
    nominal_bar = int(re.search(r"_(\d)bar", name).group(1))
    # gauge pressure held near the nominal value
    assert np.median(log["P"]) == pytest.approx(nominal_bar * 1e5, rel=0.2)
    # about 10 strokes of roughly 40 mm, in metres
    x = log["x"]
    assert np.all(np.abs(x) < 0.1)
    assert 0.03 < x.max() - x.min() < 0.05
    # ~100 Hz: the median step is 10 ms in every file
    assert log.sample_rate == pytest.approx(100.0, rel=0.05)
    assert 60 < log.duration < 120
    # rod force = P * area - seal friction: N and Pa * m^2 must agree to within friction
    assert np.median(log["F"]) / (np.median(log["P"]) * PISTON_AREA) == pytest.approx(1.0, abs=0.15)
    # raw sensor voltages are kept as they are (0-10 V sensors)
    for raw in ("x_raw", "P_raw", "F_raw"):
        assert 0 < log[raw].min() and log[raw].max() < 10


@pytest.mark.filterwarnings("ignore::hmid.errors.HmidWarning")  # gaps are expected here
def test_dropout_in_o_ring_3bar_is_what_sets_the_gap_factor():
    # O-ring_3bar has a 2.66 s dropout (266 median steps); the other files stay below 30
    folder = data_dir()
    strict = load_column_map(COLUMN_MAP).model_copy(update={"max_gap_factor": 30})
    for name in NAMES:
        if name != "O-ring_3bar.csv":
            read_log(folder / name, strict)
    with pytest.raises(LogError) as info:
        read_log(folder / "O-ring_3bar.csv", strict)
    assert (
        "column 0 (channel t): row 13 (line 13): gap of 2.66 s before this row is 266.0 x"
        in str(info.value)
    )
