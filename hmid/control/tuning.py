"""The PD's tuning rule, by linear analysis with python-control (not by hand).

The plant is linearised at the reference's start (:meth:`~hmid.control.plant.Plant.linear`,
from the identified model and the valve's lag) and sampled as the controller sees it (zero-order
hold at the control rate: the command is held over a sample, the output read at its end). The
PD (:class:`~hmid.control.controllers.PD`) in discrete time is

    C(z) = kp + kd (1 - a) / dt (z - 1) / (z - a),   a = exp(-dt / tf).

**Rule: the stiffest PD with the asked margins.** Over a grid of kd (none, then a log grid), the
largest kp on a log grid whose loop C G is stable with at least the asked gain and phase
margins; of those, the largest kp (the static stiffness of the loop, what a set-point tracker
lives on); the gains take the sign of the plant's static gain (the ankle's angle falls as the
pressure rises: its gains are negative), "largest" meaning in size. A crossover rule (gain 1 and
a phase at one frequency) does not fit the Ch. 4 rig: the mass on the muscle's spring is a
resonance of about 12 Hz damped by 1 % (the Maxwell arm damps at 1/tau, far below it) behind the
valve's 30 ms lag, so the loop must cross over below the resonance, where the plant's phase
needs no lead, with the resonance's peak under the gain margin, and the D part is what damps
that peak. The grid is scored from the loop's frequency response and the closed loop's
eigenvalues (fast); the gain margin that decides is the closed loop's eigenvalues'
(:func:`eigen_gain_margin_db`: the smallest gain that moves a pole out of the unit circle), not
a frequency grid's nor ``control.margin``'s: the resonance's peak is sharper than a grid, and a
transfer function's polynomial roots lose digits (the PD a grid-scored rule chose for the demo
model's position: ``control.margin`` 6.4 dB, the eigenvalues 5.7 dB; its force loop: none,
3.1 dB). The report gives ``control.margin``'s beside them, and python-control's closed-loop
poles (``control.feedback``).
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from hmid.errors import HmidError


class TuningError(HmidError, ValueError):
    """No PD on the rule's grid meets the asked margins (one line: why)."""


@dataclass(frozen=True)
class Tuning:
    """The gains the rule chose and the loop's margins (a PD's, or with ``ki`` a PID's): the
    gain margin by the closed loop's eigenvalues, the phase margin on a dense grid
    (:func:`loop_margins`), python-control's ``control.margin`` beside them (the PD's, the
    PID's: FF+PID's rule checks those)."""

    kp: float
    kd: float
    tf: float
    dt: float
    crossover_hz: float  # where the loop's gain is 1
    phase_margin_deg: float  # achieved
    gain_margin_db: float  # by the closed loop's eigenvalues (eigen_gain_margin_db)
    poles: np.ndarray  # of the discrete closed loop (z-plane)
    resonance_hz: float  # the plant's least-damped oscillatory mode (NaN: none)
    resonance_damping: float  # its damping ratio
    ki: float = 0.0  # the integral gain (0: a PD; :mod:`hmid.control.integral`'s rule sets it)
    observer: Any = None  # FF+DOB's disturbance observer (:mod:`hmid.control.observer`)
    control_gain_margin_db: float = float("nan")  # python-control's control.margin (NaN: not
    control_phase_margin_deg: float = float("nan")  # asked of it)

    @property
    def stable(self) -> bool:
        return bool(np.all(np.abs(self.poles) < 1.0))

    @property
    def slowest_pole_s(self) -> float:
        """The closed loop's slowest time constant, -dt / ln|z| of its slowest pole."""
        return float(-self.dt / np.log(np.max(np.abs(self.poles))))


def pd_filter(tf: float, dt: float) -> Any:
    """The PD's filtered derivative (1 - a) / dt (z - 1) / (z - a) as a discrete transfer
    function."""
    import control

    a = np.exp(-dt / tf)
    return control.tf([(1 - a) / dt, -(1 - a) / dt], [1.0, -a], dt)


def pd_transfer(kp: float, kd: float, tf: float, dt: float) -> Any:
    """C(z) of :class:`~hmid.control.controllers.PD`."""
    return kp + kd * pd_filter(tf, dt)


def closed_loop_poles(plant: Any, kp: float, kd: float, tf: float, dt: float) -> np.ndarray:
    """Poles of the sampled plant (continuous ``plant`` held over ``dt``) under the PD, by
    python-control's feedback."""
    import control

    loop = pd_transfer(kp, kd, tf, dt) * control.c2d(plant, dt, "zoh")
    return np.asarray(control.feedback(loop, 1).poles())


def _closed_matrix(Ad, Bd, Cd, kp: float, kd: float, a: float, b: float) -> np.ndarray:
    """The sampled loop's state matrix: plant state, last error, filtered derivative."""
    n = Ad.shape[0]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = Ad - Bd @ Cd * (kp + kd * b)
    M[:n, n] = -(Bd * kd * b)[:, 0]
    M[:n, n + 1] = (Bd * kd * a)[:, 0]
    M[n, :n] = -Cd[0]
    M[n + 1, :n] = -b * Cd[0]
    M[n + 1, n], M[n + 1, n + 1] = -b, a
    return M


def closed_poles(plant: Any, kp: float, kd: float, tf: float, dt: float) -> np.ndarray:
    """The same poles from the loop's own state matrix (plus one at 0: the last error's
    state), as :class:`~hmid.control.controllers.PD` runs it."""
    import control

    sampled = control.ss(control.c2d(control.ss(plant), dt, "zoh"))
    a = np.exp(-dt / tf)
    M = _closed_matrix(np.asarray(sampled.A), np.asarray(sampled.B), np.asarray(sampled.C),
                       kp, kd, a, (1 - a) / dt)  # fmt: skip
    return np.linalg.eigvals(M)


def grid_margins(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(gain margin dB, phase margin deg) of each loop response along ``L``'s last axis (a
    phase below -180 deg at a gain crossover counts as a negative margin): estimates, a grid
    misses a sharp resonance's peak (:func:`eigen_gain_margin_db` has the gain margin)."""
    re, im, mag = L.real, L.imag, np.abs(L)
    cross = (np.sign(im[..., 1:]) != np.sign(im[..., :-1])) & (re[..., 1:] < 0)
    peak = np.max(np.where(cross, mag[..., 1:], 0.0), axis=-1)
    with np.errstate(divide="ignore"):
        gm = np.where(peak > 0, -20 * np.log10(peak), np.inf)
    unit = (mag[..., 1:] - 1) * (mag[..., :-1] - 1) <= 0
    phase = 180 + np.angle(L[..., 1:], deg=True)
    phase = np.where(phase > 180, phase - 360, phase)
    pm = np.min(np.where(unit, phase, 180.0), axis=-1)
    return gm, pm


def eigen_gain_margin_db(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> float:
    """The sampled loop (A, B, C)'s gain margin (dB) from its closed loop's eigenvalues: the
    smallest gain k > 1 up to 40 dB at which A - k B C has a pole on or outside the unit circle
    (a quarter-dB grid, then bisection to 0.01 dB; inf if none). Not ``control.margin``'s, nor a
    frequency grid's: a 1 %-damped resonance's peak is sharper than a grid, and a transfer
    function's polynomial roots lose digits where poles nearly cancel."""

    def stable(k: float) -> bool:
        return bool(np.max(np.abs(np.linalg.eigvals(A - k * B @ C))) < 1.0)

    grid = np.geomspace(1.0, 100.0, 161)
    for low, high in itertools.pairwise(grid):
        if not stable(high):
            while 20 * np.log10(high / low) > 0.01:
                mid = np.sqrt(low * high)
                low, high = (mid, high) if stable(mid) else (low, mid)
            return float(20 * np.log10(high))
    return float("inf")


def loop_margins(loop: Any, dt: float) -> tuple[float, float, float]:
    """(gain margin dB, phase margin deg, crossover Hz) of the sampled ``loop`` (a strictly
    proper discrete ``control.StateSpace``): the gain margin by :func:`eigen_gain_margin_db`,
    the phase margin and crossover from its response on a dense grid (the crossover is far
    below a resonance; inf and NaN where the gain never reaches 1), C (zI - A)^-1 B at every
    point at once."""
    A, B, C = (np.asarray(m) for m in (loop.A, loop.B, loop.C))
    assert np.allclose(np.asarray(loop.D), 0.0), "the sampled plant is strictly proper"
    hz = np.geomspace(1e-3, 0.5 / dt, 2000)
    z = np.exp(2j * np.pi * hz * dt)
    L = (C @ np.linalg.solve(z[:, None, None] * np.eye(len(A)) - A, B))[:, 0, 0]
    unit = np.flatnonzero((np.abs(L[1:]) - 1) * (np.abs(L[:-1]) - 1) <= 0)
    if not unit.size:  # no gain crossover: no phase margin to speak of
        return eigen_gain_margin_db(A, B, C), float("inf"), float("nan")
    pm = float(grid_margins(L)[1])
    return eigen_gain_margin_db(A, B, C), pm, float(hz[unit[-1] + 1])


def pd_loop(plant: Any, kp: float, kd: float, tf: float, dt: float) -> Any:
    """The PD's sampled loop C G in state space (``plant`` continuous, held over ``dt``)."""
    import control

    return control.series(control.ss(pd_transfer(kp, kd, tf, dt)),
                          control.c2d(control.ss(plant), dt, "zoh"))  # fmt: skip


def pd_gain_margin_db(plant: Any, kp: float, kd: float, tf: float, dt: float) -> float:
    """The PD's loop's gain margin by its closed loop's eigenvalues."""
    loop = pd_loop(plant, kp, kd, tf, dt)
    return eigen_gain_margin_db(*(np.asarray(m) for m in (loop.A, loop.B, loop.C)))


def sampled_response(plant: Any, dt: float, tf: float, points: int):
    """``plant`` (a continuous ``control.StateSpace``) sampled at ``dt`` (zero-order hold):
    its matrices (A, B, C), and on ``points`` frequencies up to Nyquist the grid z, its
    response there and the derivative filter's (time constant ``tf``)."""
    import control

    sampled = control.ss(control.c2d(control.ss(plant), dt, "zoh"))
    matrices = tuple(np.asarray(m) for m in (sampled.A, sampled.B, sampled.C))
    z = np.exp(2j * np.pi * np.geomspace(0.01, 0.5 / dt, points) * dt)
    g = np.asarray(sampled(z)).reshape(-1)
    return matrices, z, g, np.asarray(pd_filter(tf, dt)(z)).reshape(-1)


def tune(
    plant: Any,
    dt: float,
    *,
    gain_margin_db: float = 6.0,
    phase_margin_deg: float = 45.0,
    tf: float = 0.005,
) -> Tuning:
    """The PD gains for ``plant`` (a continuous ``control.StateSpace``) by the rule of the
    module's docstring; :class:`TuningError` if no PD on the grid meets the margins."""
    (Ad, Bd, Cd), _, g, d = sampled_response(plant, dt, tf, 3000)
    static = np.sign(g[0].real) / abs(g[0])  # the gains take the plant's sign (the ankle's < 0)
    a = np.exp(-dt / tf)
    candidates: list[tuple[float, float]] = []
    for kd in (0.0, *np.geomspace(1e-5, 1.0, 31) * static):
        for kp in np.geomspace(1e-3, 1e3, 97)[::-1] * static:
            gm, pm = grid_margins((kp + kd * d) * g)
            if gm < gain_margin_db or pm < phase_margin_deg:
                continue
            M = _closed_matrix(Ad, Bd, Cd, kp, kd, a, (1 - a) / dt)
            if np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
                continue
            # the grid's gain margin is an estimate (a 1 %-damped resonance is sharper than
            # the grid): the closed loop's eigenvalues decide
            if pd_gain_margin_db(plant, kp, kd, tf, dt) >= gain_margin_db - 1e-9:
                candidates.append((float(kp), float(kd)))
                break
    # the stiffest candidate whose loop keeps the margins (its phase margin on a denser grid)
    for kp, kd in sorted(candidates, key=lambda c: (-abs(c[0]), abs(c[1]))):
        tuning = _report(plant, kp, kd, tf, dt)
        if (
            tuning.stable
            and tuning.gain_margin_db >= gain_margin_db - 1e-9
            and (tuning.phase_margin_deg >= phase_margin_deg - 1e-9)
        ):
            return tuning
    raise TuningError(
        f"no PD meets a {gain_margin_db} dB gain margin and a {phase_margin_deg} deg "
        "phase margin on this plant: ask for smaller margins"
    )


def _report(plant: Any, kp: float, kd: float, tf: float, dt: float) -> Tuning:
    """The loop's margins with these gains (:func:`loop_margins`), python-control's
    (``control.margin``) beside them, and its closed-loop poles (``control.feedback``)."""
    import control

    gm, pm, crossover = loop_margins(pd_loop(plant, kp, kd, tf, dt), dt)
    loop = pd_transfer(kp, kd, tf, dt) * control.c2d(plant, dt, "zoh")
    with warnings.catch_warnings():  # its note that it falls back to the frequency response
        warnings.simplefilter("ignore", UserWarning)
        theirs, their_pm, _, _ = control.margin(loop)
    poles = np.asarray(control.feedback(loop, 1).poles())
    their_gm = float(20 * np.log10(theirs)) if np.isfinite(theirs) and theirs > 0 else np.inf
    return Tuning(kp, kd, tf, dt, crossover, pm, gm, poles, *resonance(plant),
                  control_gain_margin_db=float(their_gm),
                  control_phase_margin_deg=float(their_pm))  # fmt: skip


def resonance(plant: Any) -> tuple[float, float]:
    """(frequency in Hz, damping ratio) of the continuous plant's least-damped oscillatory
    mode, from python-control's ``damp``; (NaN, NaN) where every mode is real."""
    import control

    wn, zeta, poles = control.damp(control.ss(plant), doprint=False)
    oscillatory = np.abs(np.imag(poles)) > 1e-9
    if not oscillatory.any():
        return float("nan"), float("nan")
    i = np.flatnonzero(oscillatory)[np.argmin(zeta[oscillatory])]
    return float(wn[i] / (2 * np.pi)), float(zeta[i])
