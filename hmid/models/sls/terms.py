"""The standard linear solid as terms of a force balance: the one place its force is written.

F = A_eff P + F0 - k1 x [- k3 x³] - sum_i k2_i g_tau_i(x), each parameter but F0 positive. For
given relaxation times tau_i the force is linear in beta = (A_eff, F0, k1, [k3], k2_1, ...):
F = sum_j beta_j c_j, the columns c_j being a parameter's regressor (P, 1, x, x³, or the arm's
unit response g_tau) times the sign with which it enters. :class:`SLSForce` declares these
parameters once (in the spirit of diffrax's *terms*, which the solvers only use); the rest read
them:

* the JAX mean force of the likelihood (:meth:`SLSForce.mean`, :mod:`.likelihood`);
* the fixed columns of the exact posterior (:mod:`.collapsed`) and of the sandwich's Jacobian
  (:mod:`._sandwich`) (:meth:`SLSForce.fixed_columns`), and their count (``n_linear``);
* the parameter space's names and units (:class:`~hmid.models.sls.SLSSpace`);
* the terms of the rig's balance language (:meth:`SLSForce.terms`): the start
  (:mod:`.start`), the physical-sign check, the loop and the balance family's example fit the
  same terms by least squares, ``sign`` being the sign with which the SLS force enters the rig's
  balance;
* the family's sizes (:attr:`hmid.families.sls.SLSSpec.dimension`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import jax.numpy as jnp
import numpy as np

from hmid.balance.kinds import ChannelTerm, ConstantTerm, Grid, MemoryTerm, TermSpec

#: tau grid of the least-squares structure (1 ms to 10 s, ratio 1.17 between points)
TAU_GRID = Grid(min=1e-3, max=10.0, points=60)

#: a regressor's channel in the balance language (x stands for the rig's position)
_CHANNELS = {"P": "{pressure}", "x": "{x}", "x^3": "{x}^3"}


@dataclass(frozen=True)
class LinearParameter:
    """One parameter that enters the SLS force linearly: ``sign * name * regressor``.

    ``regressor`` is ``"P"`` (pressure), ``"1"`` (a constant), ``"x"`` (the elongation),
    ``"x^3"`` (its cube, as :class:`~.SLSData` holds it) or ``"g_tau"`` (a Maxwell arm's
    response per unit stiffness to x, of relaxation time ``tau``: ``tau`` names it).
    """

    name: str
    regressor: Literal["P", "1", "x", "x^3", "g_tau"]
    sign: Literal[1, -1]
    positive: bool
    unit: str  # SI, of the parameter (a force per unit regressor)
    tau: str | None = None  # the arm's relaxation time (regressor "g_tau"), in s


@dataclass(frozen=True)
class SLSForce:
    """The SLS force of one configuration: ``spring`` ``"linear"`` (k1 x) or ``"cubic"``
    (k1 x + k3 x³) and ``arms`` Maxwell arms (k2_i, tau_i); see the module docstring."""

    spring: Literal["linear", "cubic"] = "cubic"
    arms: int = 1

    @property
    def fixed(self) -> tuple[LinearParameter, ...]:
        """The parameters whose column has no relaxation time: A_eff, F0, k1, [k3]."""
        out: tuple[LinearParameter, ...] = (
            LinearParameter("A_eff", "P", 1, positive=True, unit="m²"),
            LinearParameter("F0", "1", 1, positive=False, unit="N"),
            LinearParameter("k1", "x", -1, positive=True, unit="N/m"),
        )
        if self.spring == "cubic":
            out += (LinearParameter("k3", "x^3", -1, positive=True, unit="N/m³"),)
        return out

    @property
    def memory(self) -> tuple[LinearParameter, ...]:
        """The arms' stiffnesses k2 (or k2_i), each with its relaxation time tau (or tau_i)."""
        if self.arms == 1:
            return (LinearParameter("k2", "g_tau", -1, positive=True, unit="N/m", tau="tau"),)
        return tuple(
            LinearParameter(f"k2_{i}", "g_tau", -1, positive=True, unit="N/m", tau=f"tau_{i}")
            for i in range(1, self.arms + 1)
        )

    @property
    def linear(self) -> tuple[LinearParameter, ...]:
        """Every linear parameter, in the order of beta: the fixed ones, then the arms."""
        return self.fixed + self.memory

    @property
    def n_fixed(self) -> int:
        return len(self.fixed)

    @property
    def n_linear(self) -> int:
        """Size of beta (the exact posterior's and the sandwich's linear parameters)."""
        return len(self.linear)

    @property
    def n_relaxation(self) -> int:
        """Relaxation times: one per arm."""
        return len(self.memory)

    def arm_names(self) -> list[tuple[str, str]]:
        """``(k2, tau)`` physical names of each arm: ``k2``/``tau`` or ``k2_i``/``tau_i``."""
        names = []
        for p in self.memory:
            assert p.tau is not None  # an arm's stiffness names its relaxation time
            names.append((p.name, p.tau))
        return names

    # -- the columns ----------------------------------------------------------------------------
    def fixed_columns(self, P, x, x3) -> list[np.ndarray]:
        """The columns c_j of :attr:`fixed` on samples P, x, x3 (NumPy): ``[P, 1, -x, [-x³]]``.
        An arm's column is ``-g_tau``."""
        P = np.asarray(P)
        regressors = {"P": P, "1": np.ones_like(P), "x": np.asarray(x), "x^3": np.asarray(x3)}
        return [
            regressors[p.regressor] if p.sign > 0 else -regressors[p.regressor] for p in self.fixed
        ]

    def mean(self, mech, x, x3, P, g):
        """The force (rows, W) in JAX for :class:`~._space.Mechanics` ``mech`` (walkers W), x, x3
        (the spring's cube, see SLSData), P (rows,) and the unit arm responses g (rows, W, m):
        the columns entering positively, less those entering negatively, less the arms."""
        values = {"A_eff": mech.A_eff, "F0": mech.F0, "k1": mech.k1, "k3": mech.k3}
        regressors = {"P": P[:, None], "x": x[:, None], "x^3": x3[:, None]}
        plus = minus = None
        for p in self.fixed:
            value = values[p.name]
            term = value if p.regressor == "1" else value * regressors[p.regressor]
            if p.sign > 0:
                plus = term if plus is None else plus + term
            else:
                minus = term if minus is None else minus + term
        q = jnp.einsum("nwm,wm->nw", g, mech.k2) if self.arms > 1 else g[..., 0] * mech.k2[:, 0]
        return plus - minus - q

    # -- the balance language -------------------------------------------------------------------
    def terms(
        self,
        *,
        position: str = "x",
        pressure: str = "P",
        sign: int = 1,
        tau: Grid = TAU_GRID,
        warmup_s: float = 0.0,
    ) -> list[TermSpec]:
        """The SLS as balance terms, in the order of beta: the fixed ones (the elastic ones after
        A_eff and F0), then the arms; ``sign``: that of the SLS force in the rig's balance."""
        names = {"pressure": pressure, "x": position}
        terms: list[TermSpec] = []
        for p in self.linear:
            common = {"name": p.name, "sign": p.sign * sign}
            if p.regressor == "1":
                terms.append(ConstantTerm(**common))
            elif p.regressor == "g_tau":
                terms.append(MemoryTerm(**common, channel=position, positive=p.positive,
                                        tau=tau, warmup_s=warmup_s))  # fmt: skip
            else:
                channel = _CHANNELS[p.regressor].format(**names)
                terms.append(ChannelTerm(**common, channel=channel, positive=p.positive))
        return terms
