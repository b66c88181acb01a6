"""The population posterior in a run folder, so that a later session predicts from it.

``population/fit.json`` holds the muscles, their builds and the law's centring and units;
``population/law.npz`` the law's draws (intercepts, exponents, scatter); ``population/
template.json`` the SLS model file that predicted models copy their rig, units and smoother from;
``population/posterior.nc`` the full ArviZ posterior (the muscles' own parameters included).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.errors import HmidError
from hmid.files import write_json
from hmid.population._model import PopulationFit
from hmid.simulate.specs import MuscleSpec


def save_fit(folder: Path, fit: PopulationFit, template: dict) -> Path:
    """Write ``fit`` (and the model-file template) under ``folder/population``."""
    out = Path(folder) / "population"
    out.mkdir(parents=True, exist_ok=True)
    write_json(
        out / "fit.json",
        {
            "muscles": list(fit.names),
            "specifications": [s.model_dump(mode="json") for s in fit.specs],
            "scale": fit.scale.tolist(),
            "center": fit.center.tolist(),
            "center_offsets": fit.center_offsets.tolist(),
            "wall_s": fit.wall_s,
            "cpu_s": fit.cpu_s,
        },
    )
    np.savez_compressed(
        out / "law.npz", intercept=fit.intercept, exponent=fit.exponent, scatter=fit.scatter
    )
    write_json(out / "template.json", template)
    if fit.idata is not None:
        fit.idata.to_netcdf(str(out / "posterior.nc"))
    return out


def load_fit(folder: Path) -> tuple[PopulationFit, dict]:
    """The population fit and the model-file template saved in the run folder ``folder``."""
    where = Path(folder) / "population"
    try:
        meta = json.loads((where / "fit.json").read_text(encoding="utf-8"))
        law = np.load(where / "law.npz")
        template = json.loads((where / "template.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise HmidError(f"{folder}: not a finished population run ({err})") from None
    fit = PopulationFit(
        names=tuple(meta["muscles"]),
        specs=tuple(MuscleSpec(**s) for s in meta["specifications"]),
        scale=np.array(meta["scale"]),
        center=np.array(meta["center"]),
        center_offsets=np.array(meta["center_offsets"]),
        intercept=law["intercept"],
        exponent=law["exponent"],
        scatter=law["scatter"],
        muscles=np.empty((0, 0, 0)),
        diagnostics=pd.DataFrame(),
        wall_s=float(meta["wall_s"]),
        cpu_s=float(meta.get("cpu_s", 0.0)),
    )
    return fit, template
