"""A disturbance observer (DOB) on top of FF+PD: the model's inverse estimates what it misses.

The feed-forward is the identified model's inverse dynamics along the reference; what the model
misses (an undeclared friction, a fibre unlike its type's model) moves the output off the
reference. Around the reference the plant is the model's linearisation G (pressure command ->
tracked output, :meth:`~hmid.control.plant.Plant.linear`), and the miss is an input
disturbance d in the effort's units (Pa): y - r = G (u_fb + d), u_fb the feedback's share of the
command. The model's inverse turns the measured deviation back into the input that would have
made it, and the difference from the input given is the disturbance (Ohnishi's observer; Sariyildiz
and Ohnishi, *IEEE Trans. Ind. Electron.* 62, 2015):

    d_hat = Q (G^-1 (y - r) - u_fb),    u_fb = PD(e) - d_hat,    e = r - y,

Q(s) = 1 / (s / w + 1)^n a low-pass of unit static gain and of the plant's relative degree
plus one (so Q G^-1 is strictly proper: no sample's quantisation step reaches the effort at
once). Equivalently the feedback is K = (C + Q G^-1) / (1 - Q), C the PD: with Q(0) = 1 it
integrates, so a constant miss leaves no steady error, and within Q's bandwidth whatever the
miss's shape it is estimated and cancelled (a PID's integral takes back only what persists
over its slowest pole: on the Ch. 4 rig a Maxwell arm's 1.9 s).

**Rule: the widest observer with the asked margins.** The PD keeps its gains (FF+DOB vs FF+PD
at the same PD); up a log grid of Q's bandwidth from 0.2 Hz, the widest before the first whose
loop K G (K as the tracker runs it: Q and Q G^-1 in continuous time, sampled with a zero-order
hold) loses the phase margin asked, the gain margin asked (or, where the PD's own loop has less,
more than ``GAIN_MARGIN_COST`` dB of the PD's) or a stable closed loop (above it the margins come
back in islands: on the Ch. 4 rig a 25 Hz observer has 13 dB and tracks the gait twice as badly).
The loop is python-control's (``control.series``, ``control.feedback``, its frequency response);
the gain margin is the closed loop's eigenvalues' (the smallest gain that moves a pole out of the
unit circle: :func:`~hmid.control.tuning.eigen_gain_margin_db`, the PD's rule's too), not
``control.margin``'s: a 1 %-damped resonance's peak is sharper than a frequency grid, and the
observer's inverse nearly cancels the plant's poles, which costs a transfer function's
polynomial roots their digits. Besides the margins, the
quantised sensor bounds it: G^-1 differentiates the reading n - 1 times, and Q's roll-off is
what is left.

Three details, the PID's (:mod:`hmid.control.integral`) for the same reasons: errors within half
a sensor step are none (a deadband: the quantised reading of a target between two steps is never
zero); the observer is fed the feedback the valve can give (the effort clipped to the valves'
limits), so it does not wind up; and its estimate stays within the span of those limits. On
on/off valves the loop is tuned behind their switching delay (:func:`~hmid.control.integral.
delayed`), as the PID is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from hmid.control.controllers import PD
from hmid.control.integral import delayed
from hmid.control.tuning import (
    Tuning,
    TuningError,
    loop_margins,
    pd_gain_margin_db,
    pd_transfer,
    resonance,
)

BANDWIDTH_GRID = np.geomspace(0.2, 100.0, 55)  # Hz
#: dB of the PD's own gain margin the observer may cost where the PD has less than asked
GAIN_MARGIN_COST = 0.5


@dataclass(frozen=True)
class Observer:
    """The observer's filters as the tracker runs them: a discrete state space (A, B, C) whose
    inputs are the error e = r - y and the feedback u_fb, whose output is d_hat (strictly
    proper in both: d_hat_k depends on inputs before k), and Q's bandwidth and order."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    bandwidth_hz: float
    order: int


def _polynomials(plant: Any) -> tuple[np.ndarray, np.ndarray]:
    """The continuous ``plant``'s transfer function as (numerator, denominator), scaled to a unit
    static gain (the coefficients keep their digits), the numerator's leading coefficients that
    are rounding's (below 1e-9 of its largest) dropped."""
    import control

    G = control.tf(control.ss(plant))
    num = np.atleast_1d(np.squeeze(G.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(G.den[0][0])).astype(float)
    num = num[np.argmax(np.abs(num) > 1e-9 * np.max(np.abs(num))) :]
    return num / float(np.real(G(0))), den


def relative_degree(plant: Any) -> int:
    """Poles minus zeros of the continuous ``plant``."""
    num, den = _polynomials(plant)
    return len(den) - len(num)


def observer(plant: Any, bandwidth_hz: float, dt: float, order: int | None = None) -> Observer:
    """The DOB of the module's docstring for the continuous ``plant`` (``control.StateSpace``:
    effort -> tracked output), Q of ``bandwidth_hz`` and ``order`` (default: the plant's relative
    degree plus one), sampled at ``dt`` (zero-order hold)."""
    import control
    from scipy.linalg import block_diag

    gain = float(np.real(control.ss(plant).dcgain()))
    num, den = _polynomials(plant)
    n = len(den) - len(num) + 1 if order is None else order
    if n < len(den) - len(num) + 1:
        raise ValueError(f"Q of order {n} leaves Q G^-1 improper: want the plant's relative "
                         "degree plus one")  # fmt: skip
    w = 2 * np.pi * bandwidth_hz
    q_den = np.poly(np.full(n, -w)) / w**n  # (s / w + 1)^n
    # d_hat = Q G^-1 (y - r) - Q u_fb = -(Q G^-1 / gain) e - Q u_fb
    paths = [control.ss(control.tf(-den / gain, np.polymul(q_den, num))),
             control.ss(control.tf([-1.0], q_den))]  # fmt: skip
    A = block_diag(*(np.asarray(p.A) for p in paths))
    B = block_diag(*(np.asarray(p.B) for p in paths))
    C = np.hstack([np.asarray(p.C) for p in paths])
    sampled = control.c2d(control.ss(A, B, C, np.zeros((1, 2))), dt, "zoh")
    assert all(np.allclose(np.asarray(p.D), 0.0) for p in paths), "strictly proper"
    return Observer(np.asarray(sampled.A), np.asarray(sampled.B), np.asarray(sampled.C),
                    float(bandwidth_hz), n)  # fmt: skip


def observer_transfer(obs: Observer, kp: float, kd: float, tf: float, dt: float) -> Any:
    """The feedback K(z) = (C - H_e) / (1 + H_u) the tracker runs (e -> u_fb), C the PD, H_e and
    H_u the observer's paths from e and from u_fb to d_hat."""
    import control

    H = control.ss(obs.A, obs.B, obs.C, np.zeros((1, 2)), dt)
    H_e, H_u = H[0, 0], H[0, 1]
    one = control.ss([], [], [], [[1.0]], dt)
    return control.series(control.ss(pd_transfer(kp, kd, tf, dt)) - H_e,
                          control.feedback(one, H_u))  # fmt: skip


def observer_report(plant: Any, pd: Tuning, obs: Observer, dt: float) -> Tuning:
    """The margins and poles of the loop of the PD ``pd`` with the observer ``obs``."""
    import control

    loop = control.series(observer_transfer(obs, pd.kp, pd.kd, pd.tf, dt),
                          control.c2d(control.ss(plant), dt, "zoh"))  # fmt: skip
    # the observer's inverse nearly cancels the plant's poles: a transfer function's polynomial
    # roots (control.margin's) lose those digits, and a frequency grid misses the 1 %-damped
    # resonance's peak: the gain margin from the closed loop's eigenvalues, the phase margin
    # from the loop's response on a dense grid (its crossover is far below the resonance)
    gm, pm, crossover = loop_margins(loop, dt)
    poles = np.asarray(control.feedback(loop, 1).poles())
    return Tuning(pd.kp, pd.kd, pd.tf, dt, crossover, pm, gm, poles, *resonance(plant),
                  observer=obs)  # fmt: skip


def tune_dob(
    plant: Any,
    pd: Tuning,
    dt: float,
    *,
    delay: float = 0.0,
    gain_margin_db: float = 6.0,
    phase_margin_deg: float = 45.0,
    order: int | None = None,
) -> Tuning:
    """The PD ``pd`` (its gains kept) with the widest observer of ``plant`` (continuous) whose
    loop, behind a dead time of ``delay`` s (the on/off valves' switching; the observer inverts
    the model without it, whose Padé zeros would make G^-1 unstable), keeps the phase margin and
    the gain margin asked, or where the PD's own loop has less gain margin than asked, costs it
    at most ``GAIN_MARGIN_COST`` dB: a :class:`~hmid.control.tuning.Tuning` with its
    ``observer``; :class:`TuningError` if none on the grid does."""
    loop = delayed(plant, delay)
    own = pd_gain_margin_db(loop, pd.kp, pd.kd, pd.tf, dt)
    if own <= GAIN_MARGIN_COST:
        raise TuningError(f"the PD's own loop has {own:.1f} dB of gain margin here: no "
                          "disturbance observer keeps one")  # fmt: skip
    floor = min(gain_margin_db, own - GAIN_MARGIN_COST)
    chosen = None
    for bandwidth in BANDWIDTH_GRID:  # upwards, to the first that fails: margins are not
        tuning = observer_report(loop, pd, observer(plant, bandwidth, dt, order), dt)  # monotone
        if not (
            tuning.stable
            and tuning.gain_margin_db >= floor - 1e-9
            and tuning.phase_margin_deg >= phase_margin_deg - 1e-9
        ):
            break
        chosen = tuning
    if chosen is not None:
        return chosen
    raise TuningError(
        f"no disturbance observer keeps a {floor:.1f} dB gain margin and a "
        f"{phase_margin_deg} deg phase margin with this PD: ask for smaller margins"
    )


class DOB(eqx.Module):
    """The PD ``pd`` and the observer's discrete filters (``A``, ``B``, ``C``; inputs e and
    u_fb, output d_hat): u_fb = PD(e) - d_hat, the observer fed the u_fb the valves can give
    (ff + u_fb within [low, high]), d_hat within +-(high - low), errors within ``deadband``
    none (see the module's docstring)."""

    pd: PD
    A: Any
    B: Any
    C: Any
    low: Any
    high: Any
    deadband: Any = 0.0

    def init(self) -> Any:
        return (self.pd.init(), jnp.zeros(self.A.shape[0]))

    def step(self, state: Any, error: Any, ff: Any = 0.0) -> tuple[Any, Any]:
        pd_state, x = state
        pd_state, u = self.pd.step(pd_state, error)
        span = self.high - self.low
        estimate = jnp.clip(self.C[0] @ x, -span, span)
        u = u - estimate
        given = jnp.clip(ff + u, self.low, self.high) - ff
        seen = jnp.where(jnp.abs(error) > self.deadband, error, 0.0)
        x = self.A @ x + self.B @ jnp.stack([seen, given])
        return (pd_state, x), u
