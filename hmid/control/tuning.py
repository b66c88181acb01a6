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
eigenvalues (fast); python-control then reports the chosen loop's margins (``control.margin``)
and closed-loop poles (``control.feedback``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from hmid.errors import HmidError


class TuningError(HmidError, ValueError):
    """No PD on the rule's grid meets the asked margins (one line: why)."""


@dataclass(frozen=True)
class Tuning:
    """The gains the rule chose and what python-control says of the loop (a PD's, or with
    ``ki`` a PID's)."""

    kp: float
    kd: float
    tf: float
    dt: float
    crossover_hz: float  # where the loop's gain is 1 (python-control's margin)
    phase_margin_deg: float  # achieved
    gain_margin_db: float
    poles: np.ndarray  # of the discrete closed loop (z-plane)
    resonance_hz: float  # the plant's least-damped oscillatory mode (NaN: none)
    resonance_damping: float  # its damping ratio
    ki: float = 0.0  # the integral gain (0: a PD; :mod:`hmid.control.integral`'s rule sets it)
    observer: Any = None  # FF+DOB's disturbance observer (:mod:`hmid.control.observer`)

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


def _margins(L: np.ndarray) -> tuple[float, float]:
    """(gain margin dB, phase margin deg) of the loop's response ``L`` on a frequency grid."""
    gm = np.inf
    cross = np.flatnonzero((np.sign(L.imag[1:]) != np.sign(L.imag[:-1])) & (L.real[1:] < 0))
    if cross.size:
        gm = float(-20 * np.log10(np.max(np.abs(L[cross + 1]))))
    mag = np.abs(L)
    unit = np.flatnonzero((mag[1:] - 1) * (mag[:-1] - 1) <= 0)
    pm = 180.0 if not unit.size else float(np.min(180 + np.angle(L[unit + 1], deg=True)))
    return gm, pm


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
            gm, pm = _margins((kp + kd * d) * g)
            if gm < gain_margin_db or pm < phase_margin_deg:
                continue
            M = _closed_matrix(Ad, Bd, Cd, kp, kd, a, (1 - a) / dt)
            if np.max(np.abs(np.linalg.eigvals(M))) < 1.0:
                candidates.append((float(kp), float(kd)))
                break
    # the grid's margins are estimates (a 1 %-damped resonance is sharp): python-control has
    # the last word, the stiffest candidate it passes wins
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
    """What python-control says of the loop with these gains."""
    import control

    loop = pd_transfer(kp, kd, tf, dt) * control.c2d(plant, dt, "zoh")
    with warnings.catch_warnings():  # its note that it falls back to the frequency response
        warnings.simplefilter("ignore", UserWarning)
        gm, pm, _, wc = control.margin(loop)
    poles = np.asarray(control.feedback(loop, 1).poles())
    gm_db = float(20 * np.log10(gm)) if np.isfinite(gm) and gm > 0 else float("inf")
    crossover = float(wc / (2 * np.pi)) if np.isfinite(wc) else float("nan")
    return Tuning(kp, kd, tf, dt, crossover, float(pm), gm_db, poles, *resonance(plant))


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
