"""Base models of the loop: physics of the actuator, linear in its parameters given one
profiled hyperparameter, so that augmentations can be tested as nested linear models.

* :class:`SLSBase` — the Hydro Muscle as a standard linear solid (thesis eq. of the SLS family):
  F = A_eff P + F0 - k1 x - k3 x³ - k2 g_tau(x), tau profiled on a log grid.
* :class:`PistonBase` — a pneumatic cylinder: F = A P + F0 - Fc sign(v) (rod force = pressure x
  area - Coulomb friction opposing the motion).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Annotated, ClassVar, Literal

import jax
import jax.numpy as jnp
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from hmid.loop.data import LoopData
from hmid.loop.design import Columns


class Base(BaseModel, ABC):
    """A base model: columns at a hyperparameter value from :attr:`grid` (``(None,)`` if none)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    hyper: ClassVar[tuple[str, str] | None] = None  # (name, unit) of the profiled value
    title: ClassVar[str] = ""

    @property
    def grid(self) -> tuple[float | None, ...]:
        return (None,)

    @abstractmethod
    def columns(self, data: LoopData, value: float | None, cache: dict | None = None) -> Columns:
        """Columns at ``value``; ``cache`` (one per data set) may keep work that depends only on
        x and t, which no candidate transforms."""

    def elastic(
        self,
        data: LoopData,
        value: float | None,
        params: dict[str, float],
        cache: dict | None = None,
    ) -> np.ndarray:
        """The elastic (elongation-dependent) force of the fitted base, for stiffness drift."""
        return np.zeros(len(data))

    def sensitivity(
        self,
        data: LoopData,
        value: float | None,
        params: dict[str, float],
        cache: dict | None = None,
    ) -> np.ndarray | None:
        """d(prediction)/d(ln value) of the fitted base, for the hyperparameter's interval and its
        share in the others' (None without a hyperparameter)."""
        return None

    @abstractmethod
    def equation(self) -> str: ...

    def friction_sign(self, params: dict[str, float]) -> float:
        """+1 if friction enters the target as -f sign(v) (the candidates' convention), -1 if a
        log's direction convention makes it +f sign(v)."""
        return 1.0


class SLSBase(Base):
    """Standard linear solid; the Maxwell arm's tau is profiled on ``n_tau`` log-spaced values."""

    kind: Literal["sls"] = "sls"
    spring: Literal["linear", "cubic"] = "cubic"
    tau_min: Annotated[float, Field(gt=0)] = 0.01
    tau_max: Annotated[float, Field(gt=0)] = 5.0
    n_tau: Annotated[int, Field(ge=4, le=200)] = 40
    hyper: ClassVar[tuple[str, str]] = ("tau", "s")
    title: ClassVar[str] = "standard linear solid (profile least squares)"

    @property
    def grid(self) -> tuple[float, ...]:
        return tuple(np.geomspace(self.tau_min, self.tau_max, self.n_tau))

    def arms(self, data: LoopData, cache: dict | None = None) -> np.ndarray:
        """g_tau(x) for every tau of the grid, shape (n_tau, n) (one row per tau, contiguous):
        one scan per segment."""
        if cache is not None and "sls arms" in cache:
            return cache["sls arms"]
        from hmid.models.sls._recursion import unit_response

        t, x, grid = data["t"], data["x"], np.asarray(self.grid)
        out = np.empty((len(grid), len(data)))
        with jax.enable_x64(True):
            for rows in data.segments():
                start = np.zeros(len(rows), dtype=bool)
                start[0] = True
                response = unit_response(
                    jnp.asarray(t[rows]),
                    jnp.asarray(x[rows]),
                    jnp.asarray(start),
                    jnp.asarray(grid),
                )
                out[:, rows] = np.asarray(response).T
        if cache is not None:
            cache["sls arms"] = out
        return out

    def arm(self, data: LoopData, tau: float, cache: dict | None = None) -> np.ndarray:
        """g_tau(x): a grid row, or between grid points cubic (Lagrange) interpolation in ln tau
        over the four nearest rows; g is smooth in tau, and on the default grid (ratio 1.17)
        the interpolation is within ~3e-5 of the exact scan relative to the arm's range."""
        log_grid = np.log(np.asarray(self.grid))
        lt = np.log(tau)
        if not log_grid[0] - 1e-12 <= lt <= log_grid[-1] + 1e-12:
            raise ValueError(f"tau={tau} s lies outside the grid [{self.tau_min}, {self.tau_max}]")
        arms = self.arms(data, cache)
        index = int(np.argmin(np.abs(log_grid - lt)))
        if abs(log_grid[index] - lt) < 1e-12:
            return arms[index]
        first = int(np.clip(np.searchsorted(log_grid, lt) - 2, 0, len(log_grid) - 4))
        nodes = range(first, first + 4)
        weights = [
            np.prod([(lt - log_grid[k]) / (log_grid[j] - log_grid[k]) for k in nodes if k != j])
            for j in nodes
        ]
        return np.tensordot(weights, arms[first : first + 4], axes=1)

    def sensitivity(self, data, value, params, cache=None):
        # d(-k2 g_tau)/d(ln tau) by a central difference, kept inside the grid
        log_grid = np.log(np.asarray(self.grid))
        h = 1e-3
        value = float(np.exp(np.clip(np.log(value), log_grid[0] + h, log_grid[-1] - h)))
        up = self.arm(data, float(value) * np.exp(h), cache)
        down = self.arm(data, float(value) * np.exp(-h), cache)
        return -params["k2"] * (up - down) / (2 * h)

    def columns(self, data, value, cache=None):
        x = data["x"]
        cols = {"A_eff": (data["P"], "m²"), "F0": (np.ones(len(data)), "N"), "k1": (-x, "N/m")}
        if self.spring == "cubic":
            cols["k3"] = (-(x**3), "N/m³")
        cols["k2"] = (-self.arm(data, float(value), cache), "N/m")
        return Columns.of(len(data), **cols)

    def elastic(self, data, value, params, cache=None):
        x = data["x"]
        force = params["k1"] * x + params.get("k3", 0.0) * x**3
        return force + params["k2"] * self.arm(data, float(value), cache)

    def equation(self) -> str:
        cubic = " - k3 x³" if self.spring == "cubic" else ""
        return f"F = A_eff P + F0 - k1 x{cubic} - k2 g_tau(x),  dg/dt = -g/tau + dx/dt"


class PistonBase(Base):
    """Pneumatic cylinder: effective area, offset and Coulomb friction, all fitted."""

    kind: Literal["piston"] = "piston"
    title: ClassVar[str] = "piston: pressure x area - Coulomb friction"

    def columns(self, data, value, cache=None):
        n = len(data)
        return Columns.of(
            n, A=(data["P"], "m²"), F0=(np.ones(n), "N"), Fc=(-np.sign(data["v"]), "N")
        )

    def equation(self) -> str:
        return "F = A P + F0 - Fc sign(v)"

    def friction_sign(self, params):
        # which way the rod force counts friction depends on the rig's sign conventions; the
        # fitted Coulomb level tells
        return 1.0 if params["Fc"] >= 0 else -1.0


BaseSpec = Annotated[SLSBase | PistonBase, Field(discriminator="kind")]
