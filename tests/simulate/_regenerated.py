"""Compare a regenerated data set with the shipped one, number by number.

The shipped sets (data/demo, data/linear-motor) were written on one machine; another CPU (another
vendor's libm, other vector widths) may round a float differently in its last bits, so a truth
JSON can differ in its 16th digit. Byte equality would fail there for no real change. Here every
number, in a CSV cell, a JSON value or a YAML value, must agree within RTOL relative (ATOL
absolute, for values near zero); everything else (file names, headers, keys, strings, integers,
booleans, list lengths) must be identical. A data file written with 10 significant digits can
move by one unit in its last digit, at most 1e-9 relative: RTOL allows that and nothing more.

Byte identity on the machine that wrote the data stays a manual check: ``make demo-data`` and
``make linear-motor-data`` leave ``git status`` clean.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import yaml

RTOL = 1e-9
ATOL = 1e-12


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=RTOL, abs_tol=ATOL) or (math.isnan(a) and math.isnan(b))


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _same(a: Any, b: Any, where: str) -> list[str]:
    """The places where ``a`` and ``b`` differ beyond the tolerance."""
    if isinstance(a, float) or isinstance(b, float):
        numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (a, b))
        return [] if numbers and _close(float(a), float(b)) else [f"{where}: {a!r} != {b!r}"]
    if isinstance(a, dict) and isinstance(b, dict):
        if list(a) != list(b):
            return [f"{where}: keys {list(a)} != {list(b)}"]
        return [d for k in a for d in _same(a[k], b[k], f"{where}.{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items != {len(b)}"]
        return [
            d
            for i, (x, y) in enumerate(zip(a, b, strict=True))
            for d in _same(x, y, f"{where}[{i}]")
        ]
    return [] if type(a) is type(b) and a == b else [f"{where}: {a!r} != {b!r}"]


def _csv_rows(path: Path) -> list[list[Any]]:
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    # the header stays text; a cell that reads as a number is compared as one
    return rows[:1] + [[_number(c) if _number(c) is not None else c for c in r] for r in rows[1:]]


def _read(path: Path) -> Any:
    if path.suffix == ".csv":
        return _csv_rows(path)
    if path.suffix == ".json":
        return json.loads(path.read_text(encoding="utf-8"))
    if path.suffix in (".yaml", ".yml"):
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    return path.read_bytes()


def differences(shipped: Path, regenerated: Path) -> list[str]:
    """Every difference beyond the tolerance between two folders of a written data set."""
    names = sorted(p.name for p in shipped.iterdir())
    others = sorted(p.name for p in regenerated.iterdir())
    if names != others:
        return [f"files {names} != {others}"]
    return [d for n in names for d in _same(_read(shipped / n), _read(regenerated / n), n)]
