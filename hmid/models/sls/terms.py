"""The standard linear solid as terms of a force balance: the one place its design is written.

F = A_eff P + F0 - k1 x [- k3 x³] - sum_i k2_i g_tau_i(x), each parameter positive; ``sign``
is the sign with which the SLS force enters the rig's balance. The Bayesian family samples these
parameters (:mod:`.model`); its start (:mod:`.start`), its physical-sign check and the loop fit
the same terms by least squares.
"""

from __future__ import annotations

from hmid.balance.kinds import ChannelTerm, ConstantTerm, Grid, MemoryTerm, TermSpec

#: tau grid of the least-squares structure (1 ms to 10 s, ratio 1.17 between points)
TAU_GRID = Grid(min=1e-3, max=10.0, points=60)


def arm_names(arms: int) -> list[str]:
    return ["k2"] if arms == 1 else [f"k2_{i}" for i in range(1, arms + 1)]


def sls_terms(
    spring: str = "cubic",
    arms: int = 1,
    *,
    position: str = "x",
    pressure: str = "P",
    sign: int = 1,
    tau: Grid = TAU_GRID,
    warmup_s: float = 0.0,
) -> list[TermSpec]:
    """The SLS's terms: the elastic ones (k1, [k3]) first after A_eff and F0, then the arms."""
    x = position
    terms: list[TermSpec] = [
        ChannelTerm(name="A_eff", channel=pressure, sign=sign, positive=True),
        ConstantTerm(name="F0", sign=sign),
        ChannelTerm(name="k1", channel=x, sign=-sign, positive=True),
    ]
    if spring == "cubic":
        terms.append(ChannelTerm(name="k3", channel=f"{x}^3", sign=-sign, positive=True))
    for name in arm_names(arms):
        terms.append(
            MemoryTerm(name=name, channel=x, sign=-sign, positive=True, tau=tau, warmup_s=warmup_s)
        )
    return terms
