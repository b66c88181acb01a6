"""Integral action on top of FF+PD: the PID's tuning rule, by linear analysis with python-control.

The feed-forward is the identified model's; whatever the model misses (an undeclared effect, a
fibre unlike its type's model) reaches the loop as a disturbance, and a PD leaves a constant one
as a steady error of d / (1 + kp G(0)): on the ankle, whose PD keeps its loop gain below 1 (a
lightly damped mode behind the valve's lag), that is most of it. An integral takes it back: for
a loop with an integrator, a step d of load disturbance leaves an integrated error of exactly
d / ki (the final-value theorem on e / s), so the larger the integral gain the less error.

**Rule: the largest integral gain with the asked margins** (Åström and Hägglund's MIGO design,
*Advanced PID Control*, 2006, §7: maximise ki under a robustness constraint, here the PD's gain
and phase margins). The loop is the PD's (:mod:`hmid.control.tuning`: the plant linearised
at the reference's start, sampled with a zero-order hold) with

    C(z) = kp + kd (1 - a) / dt (z - 1) / (z - a) + ki dt z / (z - 1),

as :class:`~hmid.control.controllers.PID` runs it. Over a grid of kd, kp and ki (each a log grid
times the plant's sign), the triples whose loop's frequency response has the margins and whose
closed loop's eigenvalues are inside the unit circle; of those the largest ki, then the largest
kp; python-control (``control.margin``, ``control.feedback``) has the last word on the margins
and poles. The report gives the chosen loop's gain margin by its closed loop's eigenvalues
(:func:`~hmid.control.tuning.loop_margins`, as the PD's) beside ``control.margin``'s. The PD's
own gains stay as tuned: FF+PD is compared with PD alone at the same gains.

**On/off valves** switch the effort on the pressure's error (:mod:`hmid.control.actuation`):
a reversal waits for one valve to close and the other to open, so the loop sees a dead time of
about the opening plus the closing time (80 ms for the thesis's valves) on top of the line's lag.
An integral tuned without it drives the switching into a limit cycle of the size of PD alone's
error; the on/off loop's PID is tuned on the plant behind that dead time (:func:`delayed`, a
third-order Padé approximant), so it is slower, and it holds.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from hmid.control.tuning import (
    Tuning,
    TuningError,
    _closed_matrix,
    grid_margins,
    loop_margins,
    pd_filter,
    resonance,
    sampled_response,
)

KD_GRID = np.r_[0.0, np.geomspace(1e-5, 1.0, 16)]  # times the plant's sign / static gain
KP_GRID = np.geomspace(1e-3, 1e3, 49)
KI_GRID = np.geomspace(1e-2, 1e4, 61)  # 1/s, times the same


def delayed(plant: Any, delay: float) -> Any:
    """``plant`` behind a dead time of ``delay`` s (Padé, third order); ``plant`` for 0."""
    import control

    if delay <= 0:
        return plant
    num, den = control.pade(delay, 3)
    return control.ss(control.series(control.tf(num, den), plant))


def integrator(dt: float) -> Any:
    """The PID's integral, dt z / (z - 1) (forward rectangles: the current error counts)."""
    import control

    return control.tf([dt, 0.0], [1.0, -1.0], dt)


def pid_transfer(kp: float, ki: float, kd: float, tf: float, dt: float) -> Any:
    """C(z) of :class:`~hmid.control.controllers.PID` (without its anti-windup)."""
    return kp + kd * pd_filter(tf, dt) + ki * integrator(dt)


def pid_matrix(Ad, Bd, Cd, kp: float, ki: float, kd: float, tf: float, dt: float) -> np.ndarray:
    """The sampled loop's state matrix: the PD's (plant, last error, filtered derivative) and
    the integral I_k = I_(k-1) + ki dt e_k, which adds to the command."""
    a = np.exp(-dt / tf)
    n = Ad.shape[0]
    M = np.zeros((n + 3, n + 3))
    M[: n + 2, : n + 2] = _closed_matrix(Ad, Bd, Cd, kp, kd, a, (1 - a) / dt)
    M[:n, :n] -= Bd @ Cd * ki * dt
    M[:n, n + 2] = Bd[:, 0]
    M[n + 2, :n] = -ki * dt * Cd[0]
    M[n + 2, n + 2] = 1.0
    return M


def pid_poles(plant: Any, kp: float, ki: float, kd: float, tf: float, dt: float) -> np.ndarray:
    """The closed loop's poles from its own state matrix (one at 0: the last error's state)."""
    import control

    sampled = control.ss(control.c2d(control.ss(plant), dt, "zoh"))
    A, B, C = (np.asarray(m) for m in (sampled.A, sampled.B, sampled.C))
    return np.linalg.eigvals(pid_matrix(A, B, C, kp, ki, kd, tf, dt))


def tune_pid(
    plant: Any,
    dt: float,
    *,
    gain_margin_db: float = 6.0,
    phase_margin_deg: float = 45.0,
    tf: float = 0.005,
) -> Tuning:
    """The PID for ``plant`` (a continuous ``control.StateSpace``) by the rule of the module's
    docstring: a :class:`~hmid.control.tuning.Tuning` with its ``ki``; :class:`TuningError` if
    no PID on the grid meets the margins."""
    (Ad, Bd, Cd), z, g, d = sampled_response(plant, dt, tf, 2000)
    i = dt * z / (z - 1)
    static = np.sign(g[0].real) / abs(g[0])  # the gains take the plant's sign
    kps, kis = KP_GRID * static, KI_GRID * static
    passing: list[tuple[float, float, float]] = []
    for kd in KD_GRID * static:
        L = (kps[:, None, None] + kd * d + kis[None, :, None] * i) * g
        gm, pm = grid_margins(L)
        for p, q in zip(*np.nonzero((gm >= gain_margin_db) & (pm >= phase_margin_deg)),
                        strict=True):  # fmt: skip
            passing.append((float(kps[p]), float(kis[q]), float(kd)))
    # the largest ki, then the stiffest kp; the eigenvalues, then python-control, decide
    for kp, ki, kd in sorted(passing, key=lambda c: (-abs(c[1]), -abs(c[0]), abs(c[2]))):
        if np.max(np.abs(np.linalg.eigvals(pid_matrix(Ad, Bd, Cd, kp, ki, kd, tf, dt)))) >= 1:
            continue
        tuning = pid_report(plant, kp, ki, kd, tf, dt)
        if (
            tuning.stable
            and tuning.control_gain_margin_db >= gain_margin_db - 1e-9
            and tuning.control_phase_margin_deg >= phase_margin_deg - 1e-9
        ):
            return tuning
    raise TuningError(
        f"no PID meets a {gain_margin_db} dB gain margin and a {phase_margin_deg} deg "
        "phase margin on this plant: ask for smaller margins"
    )


def pid_report(plant: Any, kp: float, ki: float, kd: float, tf: float, dt: float) -> Tuning:
    """What python-control says of the loop with these gains (``control.margin``, the rule's
    margins, and its poles), and the loop's margins by :func:`~hmid.control.tuning.loop_margins`
    (the gain margin by the closed loop's eigenvalues)."""
    import control

    # in state space: the integrator's pole at 1 beside the plant's slow ones makes the
    # transfer function's polynomial roots lose digits
    sampled = control.c2d(control.ss(plant), dt, "zoh")
    loop = control.series(control.ss(pid_transfer(kp, ki, kd, tf, dt)), sampled)
    with warnings.catch_warnings():  # its note that it falls back to the frequency response
        warnings.simplefilter("ignore", UserWarning)
        theirs, their_pm, _, _ = control.margin(loop)
    poles = np.asarray(control.feedback(loop, 1).poles())
    their_gm = float(20 * np.log10(theirs)) if np.isfinite(theirs) and theirs > 0 else np.inf
    gm, pm, crossover = loop_margins(loop, dt)
    return Tuning(kp, kd, tf, dt, crossover, pm, gm, poles, *resonance(plant), ki=ki,
                  control_gain_margin_db=float(their_gm),
                  control_phase_margin_deg=float(their_pm))  # fmt: skip
