"""The loop on measured data: a pneumatic cylinder's friction logs (public domain, see
``../shared/data/pneumatic-friction/PROVENANCE.md``).

Base model: rod force = pressure x area - Coulomb friction opposing the motion (area, offset and
friction level fitted). Per seal type, some pressure levels are fitted and the others held out;
the loop then looks for the physics the base lacks.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hmid.config import load_yaml_model
from hmid.errors import ConfigError, HmidWarning
from hmid.experiment import DenoiseSection
from hmid.loop.bases import PistonBase
from hmid.loop.config import LoopSpec

_FILE = re.compile(r"^(?P<seal>.+)_(?P<bar>\d+(\.\d+)?)bar\.csv$")


class PneumaticStudy(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")]
    # relative to this file; $HMID_SHARED_DATA/<folder name> wins when set
    data: Path
    columns: Path
    seals: Annotated[tuple[str, ...], Field(min_length=1)]
    train_pressures: Annotated[tuple[float, ...], Field(min_length=1)]  # bar
    validation_pressures: Annotated[tuple[float, ...], Field(min_length=1)]  # bar
    max_gap_s: Annotated[float, Field(gt=0)] = 0.1
    v_deadband: Annotated[float, Field(ge=0)] = 0.001  # m/s
    denoise: DenoiseSection = DenoiseSection()
    loop: LoopSpec = LoopSpec(base=PistonBase())
    base_dir: Path = Path(".")

    @model_validator(mode="after")
    def _disjoint(self) -> PneumaticStudy:
        both = set(self.train_pressures) & set(self.validation_pressures)
        if both:
            raise ValueError(f"pressures {sorted(both)} are both fitted and held out")
        if self.loop.base.kind != "piston":
            raise ValueError("loop.base must be {kind: piston} for a pneumatic cylinder")
        return self

    def resolve(self, path: Path) -> Path:
        return path if path.is_absolute() else self.base_dir / path

    def data_dir(self) -> Path:
        shared = os.environ.get("HMID_SHARED_DATA")
        return Path(shared) / self.data.name if shared else self.resolve(self.data)

    def files(self) -> dict[str, list[tuple[float, Path]]]:
        """Per seal, (pressure [bar], file) of every log used; missing ones are ConfigErrors."""
        folder = self.data_dir()
        found: dict[str, dict[float, Path]] = {}
        for path in sorted(folder.glob("*.csv")):
            match = _FILE.match(path.name)
            if match:
                found.setdefault(match["seal"], {})[float(match["bar"])] = path
        out = {}
        for seal in self.seals:
            wanted = self.train_pressures + self.validation_pressures
            missing = [p for p in wanted if p not in found.get(seal, {})]
            if missing:
                raise ConfigError(
                    f"{folder}: seal {seal!r} has no log at {missing} bar "
                    f"(files are named <seal>_<pressure>bar.csv)"
                )
            out[seal] = [(p, found[seal][p]) for p in wanted]
        return out


def load_study(path: str | Path) -> PneumaticStudy:
    path = Path(path)
    study = load_yaml_model(path, PneumaticStudy).model_copy(update={"base_dir": path.parent})
    if not study.resolve(study.columns).is_file():
        raise ConfigError(f"{path}: key 'columns': file {study.resolve(study.columns)} is missing")
    return study


def prepare(study: PneumaticStudy, files: list[tuple[float, Path]]):
    """LoopData of one seal: logs split at gaps, denoised per piece, held-out pressures marked;
    also a table of the pieces (so nothing is left out silently)."""
    import pandas as pd

    from hmid.denoise import denoise_log
    from hmid.friction import derivative_reach
    from hmid.io import load_column_map, read_log
    from hmid.io.segments import split_at_gaps
    from hmid.loop.data import from_segments

    column_map = load_column_map(study.resolve(study.columns))
    smoother, differentiator = study.denoise.smoother.build(), study.denoise.derivative.build()
    segments, pieces_table, validation = {}, [], set()
    for pressure, path in files:
        name = path.stem
        if pressure in study.validation_pressures:
            validation.add(name)
        pieces = []
        with warnings.catch_warnings():  # gaps are split at, not bridged (see the pieces table)
            warnings.filterwarnings("ignore", ".*gap", HmidWarning)
            log = read_log(path, column_map)
        for piece in split_at_gaps(log, study.max_gap_s):
            usable = _long_enough(piece, study)
            pieces_table.append(
                {
                    "log": name,
                    "start [s]": piece.t[0],
                    "duration [s]": piece.duration,
                    "samples": len(piece),
                    "used": usable,
                }
            )
            if usable:
                pieces.append(denoise_log(piece, smoother, differentiator))
        if not pieces:
            raise ConfigError(f"{path}: no piece between gaps is long enough for the filters")
        segments[name] = pieces
    reach = derivative_reach(segments[next(iter(segments))][0].t, differentiator)
    data = from_segments(
        segments, target="F", validation=validation, v_deadband=study.v_deadband, reach=reach
    )
    return data, pd.DataFrame(pieces_table)


def _long_enough(piece, study: PneumaticStudy) -> bool:
    """A piece shorter than three derivative windows cannot be differentiated and trimmed."""
    return piece.duration >= 3 * max(
        study.denoise.derivative.window_s, study.denoise.smoother.window_s
    )
