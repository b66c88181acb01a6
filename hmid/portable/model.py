"""A model loaded from its model file: it predicts the explained quantity one step ahead on any
log, and runs free where the rig declares its motion (:mod:`hmid.portable.freerun`).

Evaluation goes through the same code as the run that fitted the model (the denoise step, the
balance's signals, the terms' columns), so a loaded model predicts what the run's model
predicted, to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from hmid.balance import RigSection, Structure
from hmid.balance.kinds import make_term
from hmid.errors import LogError
from hmid.io.log import Log
from hmid.portable.file import read_model_file


@dataclass(frozen=True)
class Model:
    """A fitted model as its file states it; see :func:`load_model`."""

    document: dict = field(repr=False)
    path: Path | None = None
    #: posterior draws held in memory (name -> (chains, draws)), before a file has them
    draws: dict | None = field(default=None, repr=False)

    @property
    def name(self) -> str:
        return self.document["name"]

    @property
    def family(self) -> str:
        return self.document["family"]

    @property
    def equation(self) -> str:
        return self.document.get("equation", "")

    @cached_property
    def rig(self) -> RigSection:
        return RigSection.model_validate(self.document["rig"])

    @cached_property
    def terms(self) -> tuple:
        terms = self.document["terms"]
        return tuple(make_term(t, f"{self.name}: terms.{i}") for i, t in enumerate(terms))

    @property
    def coef(self) -> np.ndarray:
        return np.asarray(self.document["coefficients"]["values"], dtype=float)

    @property
    def covariance(self) -> np.ndarray | None:
        cov = self.document["coefficients"].get("covariance")
        return None if cov is None else np.asarray(cov, dtype=float)

    @property
    def parameters(self) -> pd.DataFrame:
        """The family's parameters: value, unit, interval (level and method), calibration."""
        return pd.DataFrame(self.document.get("parameters", []))

    @cached_property
    def posterior(self):
        """The posterior draws as ArviZ ``InferenceData`` (None where the family has none)."""
        if self.draws is not None:
            from hmid.portable.posterior import inference_data

            return inference_data(self.draws)
        name = self.document.get("posterior")
        if not name or self.path is None:
            return None
        import arviz as az

        return az.from_netcdf(self.path.parent / name)

    def signals(self, log: Log, name: str = "log"):
        """``log`` (as logged: the rig's channel signs are applied here) as the model reads it:
        the balance's :class:`~hmid.balance.Signals` under the model's smoother."""
        from hmid.balance.prepare import prepare
        from hmid.denoise import denoise_log
        from hmid.experiment import DenoiseSection

        rig = self.rig
        needed = [c for c in rig.log_channels if c not in log]
        if needed:
            raise LogError(f"{log.source}: the model {self.name!r} reads {needed}, absent here")
        flips = {c: -log[c] for c, s in rig.channels.items() if s.sign < 0 and c in log}
        if flips:
            log = log.with_channels(None, **flips)
        smoother, differentiator = DenoiseSection.model_validate(self.document["denoise"]).build()
        piece = denoise_log(log, smoother, differentiator, channels=rig.log_channels,
                            position=rig.position)  # fmt: skip
        fit = self.document.get("fit") or {}
        return prepare(
            rig, {name: [piece]}, self.document["units"], smoother=smoother,
            differentiator=differentiator, free_fall_law=self.friction_law(),
            v_deadband=fit.get("v_deadband", 0.002), exclude_stuck=fit.get("exclude_stuck", True),
        )  # fmt: skip

    def friction_law(self):
        """The free-fall friction as a function of v (N, signed with v), or None."""
        law = (self.document.get("known") or {}).get("free_fall_friction")
        if law is None:
            return None
        Fc, b = float(law["Fc"]), float(law["b"])
        return lambda v: (Fc + b * np.abs(v)) * np.sign(v)

    def predict_signals(self, signals) -> np.ndarray:
        """The target (the explained quantity less its known terms) on every row of
        ``signals``."""
        columns = Structure.of(self.terms).columns(signals)
        names = tuple(self.document["coefficients"]["names"])
        if tuple(columns.names) != names:
            raise ValueError(f"{self.name}: columns {columns.names} differ from the file's {names}")
        return columns.values @ self.coef

    def predict(self, log: Log) -> pd.DataFrame:
        """One-step prediction on ``log``: per sample t, the measured explained quantity, the
        predicted one, and ``usable`` (rows the fit would have used: moving, away from the
        filters' edges)."""
        signals = self.signals(log)
        target = self.predict_signals(signals)
        known = signals["explained"] - signals["target"]
        return pd.DataFrame(
            {
                "t": signals["t"],
                "measured": signals["explained"],
                "predicted": target + known,
                "usable": signals["usable"],
            }
        )

    @cached_property
    def simulator(self):
        """The compiled equation of motion (:class:`~hmid.portable.freerun.Simulator`);
        :class:`~hmid.portable.freerun.NotSimulable` says why a rig has none."""
        from hmid.portable.freerun import simulator

        return simulator(self)

    def simulate(self, t, inputs, x0: float, v0: float = 0.0, memory0=None):
        """Free run from the state (``x0``, ``v0``; memory arms ``memory0``, default at rest)
        over the times ``t``, driven by ``inputs`` (channel -> values at ``t``, SI units, the
        rig's sign convention): a :class:`~hmid.portable.freerun.FreeTrajectory`."""
        return self.simulator.integrate(t, inputs, x0, v0, memory0)

    def free_run(self, log: Log):
        """Free run over ``log`` from its measured first state, scored against its measured
        position (:class:`~hmid.portable.freerun.FreeRun`)."""
        from hmid.portable.freerun import free_run

        return free_run(self, log)


def load_model(path: str | Path) -> Model:
    """A model from its model file (``<run>/models/<name>.json``)."""
    path = Path(path)
    return Model(read_model_file(path), path.resolve())
