"""Inverse dynamics: the pressure an identified model says gives a demanded force or motion.

A model file states its rig's balance as an equation of motion
(:func:`hmid.portable.freerun.equation`): the explained side (for the Ch. 4 rig
(M + m1) a + m1 g) equals the model's terms plus the known friction. A controller that knows the
motion it wants (x, v, a along the reference) knows every term but the pressure's, so the
balance is one equation in P per sample. Solving it is the model-based feed-forward of thesis
§1.3 (Fig. 1.3): no feedback is needed where the model is right.

The solve is exact for a balance affine in P (the SLS, SINDy's and the polynomial families'
P-linear maps: the usual case); a balance polynomial in P is solved by Newton's method from the
affine part's answer. A model without P, or with P behind a lag or a delay, has no inverse here
(:class:`NotInvertible`, one line: why). The memory arms' states follow the reference's motion
exactly (a step of dq/dt = -q/tau + v for the velocity held over each sample). Friction's sign
is the regularised tanh(v / v0) of the free run: at rest the model cannot say which way static
friction holds, and feedback takes what is left.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hmid.errors import HmidError
from hmid.portable.freerun import Equation, NotSimulable, equation
from hmid.simulate.params import RigParams


class NotInvertible(HmidError, ValueError):
    """The model cannot be solved for the pressure (one line: why)."""


@dataclass(frozen=True)
class ForceLaw:
    """A model's balance, evaluated in NumPy on a demanded motion; ``pressure`` names the input
    solved for."""

    eq: Equation
    pressure: str = "P"
    name: str = "model"

    @classmethod
    def of(cls, model, pressure: str = "P") -> ForceLaw:
        """The law of a loaded model (:class:`hmid.Model`)."""
        try:
            eq = equation(model)
        except NotSimulable as err:
            raise NotInvertible(f"model {model.name!r}: {err}") from None
        law = cls(eq, pressure, model.name)
        law._check()
        return law

    @classmethod
    def of_rig(cls, rig: RigParams, v0: float = 0.002) -> ForceLaw:
        """The simulator's own physics as a model: the perfect model of a noise-free plant."""
        m = rig.muscle
        rhs = (
            ("mono", (("P", 1),), m.A_eff),
            ("const", None, m.F0),
            ("mono", (("x", 1),), -m.k1),
            ("mono", (("x", 3),), -m.k3),
            ("memory", (0, m.tau), -m.k2),
            ("friction", (rig.friction.coulomb, 0.0, v0), -1.0),
        )
        lhs = (("accel", None, rig.M + rig.m1), ("const", None, rig.m1 * rig.g))
        return cls(Equation(rhs, lhs, ("P",), 1, (), v0), "P", "rig physics")

    def _check(self) -> None:
        if self.pressure not in self.eq.inputs:
            raise NotInvertible(
                f"model {self.name!r} has no term in {self.pressure}: it cannot say which "
                "pressure gives a force (choose a model with pressure terms, e.g. sls)"
            )
        others = [name for name in self.eq.inputs if name != self.pressure]
        if others:
            raise NotInvertible(
                f"model {self.name!r} reads {others} beside {self.pressure}: a controller that "
                "sets only the pressure does not know them"
            )
        for kind, data, _ in self.eq.rhs:
            if kind in ("lag", "delay"):
                raise NotInvertible(
                    f"model {self.name!r}: {self.pressure} acts through a {kind}; its inverse "
                    "would need the future of the reference"
                )
            if kind == "mono" and dict(data).get("a"):
                raise NotInvertible(f"model {self.name!r}: a term in a times an input")

    # --- the balance's parts --------------------------------------------------------------
    def _mono(self, data, values: dict[str, np.ndarray]) -> np.ndarray:
        out = np.ones_like(values["x"])
        for name, power in data:
            out = out * values[name] ** power
        return out

    def memory(self, t: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The memory arms' states (arms x samples) along the motion x(t), from rest."""
        taus = {data[0]: data[1] for kind, data, _ in self.eq.rhs if kind == "memory"}
        q = np.zeros((self.eq.n_memory, len(t)))
        dt = np.diff(t)
        v = np.diff(x) / dt
        for arm, tau in taus.items():
            decay = np.exp(-dt / tau)
            for k in range(len(dt)):  # a recursion; references are a few thousand samples
                q[arm, k + 1] = q[arm, k] * decay[k] + tau * (1 - decay[k]) * v[k]
        return q

    def coefficients(self, x, v, memory) -> list[np.ndarray]:
        """The model's force (friction left out) as a polynomial in the pressure: the
        coefficient of P^0, P^1, ... at each sample."""
        x, v = np.asarray(x, dtype=float), np.asarray(v, dtype=float)
        coefs = [np.zeros_like(x) for _ in range(5)]
        for kind, data, c in self.eq.rhs:
            if kind == "const":
                coefs[0] = coefs[0] + c
            elif kind == "mono":
                power = dict(data).get(self.pressure, 0)
                rest = tuple((n, p) for n, p in data if n != self.pressure)
                coefs[power] = coefs[power] + c * self._mono(rest, {"x": x, "v": v})
            elif kind == "memory":
                coefs[0] = coefs[0] + c * memory[data[0]]
        while len(coefs) > 2 and not np.any(coefs[-1]):
            coefs.pop()
        return coefs

    def force(self, x, v, P, memory) -> np.ndarray:
        """The model's force (its terms, friction left out) at the given state and pressure."""
        coefs = self.coefficients(x, v, memory)
        return sum(c * np.asarray(P, dtype=float) ** k for k, c in enumerate(coefs))

    def friction(self, v) -> np.ndarray:
        """The known friction on the model side (signed as it enters the balance)."""
        out = np.zeros_like(np.asarray(v, dtype=float))
        for kind, data, c in self.eq.rhs:
            if kind == "friction":
                fc, b, v0 = data
                out = out + c * (fc + b * np.abs(v)) * np.tanh(v / v0)
        return out

    def explained(self, a) -> np.ndarray:
        """The explained side for the acceleration a (for the Ch. 4 rig (M + m1) a + m1 g)."""
        a = np.asarray(a, dtype=float)
        out = np.zeros_like(a)
        for kind, _, c in self.eq.lhs:
            out = out + (c * a if kind == "accel" else c)
        return out

    # --- the inverse ----------------------------------------------------------------------
    def pressure_for(self, force, x, v, memory) -> np.ndarray:
        """The pressure at which the model's force is ``force`` (N) at the given state."""
        coefs = self.coefficients(x, v, memory)
        slope = coefs[1]
        if np.any(slope == 0):
            raise NotInvertible(f"model {self.name!r}: the force does not depend on P somewhere")
        P = (force - coefs[0]) / slope
        if len(coefs) > 2:  # Newton on the polynomial from the affine answer
            for _ in range(20):
                value = sum(c * P**k for k, c in enumerate(coefs)) - force
                deriv = sum(k * c * P ** (k - 1) for k, c in enumerate(coefs) if k)
                P = P - value / np.where(deriv == 0, 1.0, deriv)
        return P

    def pressure_for_motion(self, t, x, v, a) -> np.ndarray:
        """The pressure that moves the rig along x(t) (with v and a): the inverse dynamics."""
        need = self.explained(a) - self.friction(v)
        return self.pressure_for(need, x, v, self.memory(t, x))


def lead(P: np.ndarray, tau: float, dt: float) -> np.ndarray:
    """The command that brings a first-order lag (time constant ``tau``, command held over each
    sample ``dt``) along the pressures ``P`` at the sample instants: the lag's exact discrete
    inverse. One sample shorter than ``P`` (command k moves P[k] to P[k + 1])."""
    decay = np.exp(-dt / tau)
    return (P[1:] - decay * P[:-1]) / (1 - decay)
