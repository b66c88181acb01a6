"""When the sampler stops, decided from the chain alone, so a stored chain is read as a fresh run.

The stopping rule looks only at the chain's prefix at fixed check points (every ``check_every``
steps and at ``max_steps``), never at what a file happens to hold. :func:`replay` applies it to a
stored chain: the result is the chain a fresh run with the same settings would stop with (shorter
than what is stored when a longer-budget run left it), or says where sampling must go on.
"""

from __future__ import annotations

from dataclasses import dataclass

import emcee
import numpy as np


def tau_of(chain: np.ndarray) -> np.ndarray:
    """Integrated autocorrelation time per parameter; ``N`` where it cannot be estimated."""
    n = len(chain)
    if n < 2:
        return np.full(chain.shape[-1], float(max(n, 1)))
    with np.errstate(all="ignore"):
        tau = emcee.autocorr.integrated_time(chain, tol=0)
    return np.where(np.isfinite(tau) & (tau > 0), tau, float(n))


def converged(tau, tau_prior, n: int, cfg) -> bool:
    """emcee's rule: ``n > min_tau_factor * max(tau)`` and every tau settled to ``tau_rtol``."""
    if tau is None or tau_prior is None or n <= cfg.min_tau_factor * np.max(tau):
        return False
    return bool(np.all(np.abs(tau_prior - tau) / tau < cfg.tau_rtol))


def acceptance(chain: np.ndarray) -> np.ndarray:
    """Per walker, the fraction of steps after the first that moved it (a rejected proposal
    repeats the position exactly; an accepted continuous one never does)."""
    if len(chain) < 2:
        return np.full(chain.shape[1], np.nan)
    moved = np.any(chain[1:] != chain[:-1], axis=-1)
    return moved.mean(axis=0)


@dataclass(frozen=True)
class Replay:
    """The rule applied to a stored chain: ``stop`` at ``n`` steps (``reason``), or go on from
    ``n`` (``reason`` None) with the references the live loop would hold."""

    n: int
    reason: str | None
    tau: np.ndarray | None
    tau_ref: np.ndarray | None
    history: list[list[float]]


def check_points(cfg, upto: int) -> list[int]:
    """The steps at which a run with ``cfg`` checks convergence, up to ``upto``."""
    points = list(range(cfg.check_every, min(upto, cfg.max_steps) + 1, cfg.check_every))
    if cfg.max_steps <= upto and cfg.max_steps % cfg.check_every:
        points.append(cfg.max_steps)
    return points


def replay(chain: np.ndarray, cfg) -> Replay:
    """Where a fresh run with ``cfg`` stops within ``chain`` (steps, walkers, D), if it does."""
    tau: np.ndarray | None = None
    tau_ref: np.ndarray | None = None
    history: list[list[float]] = []
    for n in check_points(cfg, len(chain)):
        tau_prior, tau = tau_ref, tau_of(chain[:n])
        if n % cfg.check_every == 0:
            tau_ref = tau
        history.append([n, *tau])
        if converged(tau, tau_prior, n, cfg):
            return Replay(n, "converged", tau, tau_ref, history)
        if n >= cfg.max_steps:
            return Replay(n, "step budget", tau, tau_ref, history)
    return Replay(len(chain), None, tau, tau_ref, history)
