"""Ensemble MCMC of a posterior with emcee: seeded, checkpointed to HDF5 as it runs, resumable.

:func:`run_sampler` samples any *vectorised* log-probability ``log_prob(theta) -> (W,)`` with
``theta`` of shape ``(W, D)`` and returns a :class:`SamplerResult`. ``log_prob`` is only called
with ``n_walkers // 2`` rows (the sub-ensemble the DE and stretch moves update; start checks are
padded to it) or ``n_walkers // 4`` (snooker), so a jitted likelihood compiles twice. A NaN
log-probability counts as ``-inf`` (the proposal is rejected) and is counted in
``SamplerResult.n_nan``; ``+inf`` is an error.

Randomness: ``np.random.SeedSequence(seed)`` spawns one stream for the initial walker ball and one
``MT19937`` state for emcee's moves, handed to the sampler explicitly (emcee keeps its own
``RandomState``; NumPy's global generator is neither read for randomness nor advanced).

Chain file: the walkers are kept in memory and written every ``check_every`` steps (and on an
interruption) to ``backend_path``, in emcee's ``HDFBackend`` layout (group ``mcmc``, readable with
``emcee.backends.HDFBackend(path, read_only=True)``) plus a group ``hmid`` holding the
configuration hash and checkpoints (:mod:`hmid.models.sls._chainfile`: a digest over every stored
row, verified before resuming; a lock while writing). emcee's own ``HDFBackend`` is not used
while sampling: it opens the file on every step (~5 ms a step here) and rewrites its random
state attribute by attribute, so an interruption can leave a state that does not match the chain.
"N1 steps, interrupt or stop, resume to N2" gives the same chain, bit for bit, as N2 at once.

Convergence (emcee's recommendation), checked at fixed steps (every ``check_every`` and at
``max_steps``): tau, the integrated autocorrelation time, is estimated on the whole chain; the run
stops when ``N > min_tau_factor * max(tau)`` and every tau changed by less than ``tau_rtol`` since
the previous check. The rule reads only the chain, and a stored chain is replayed through it
(:mod:`hmid.models.sls._convergence`), so a file left by a run with a larger budget or other
settings gives the numbers a fresh run gives (``SamplerResult.reused_steps`` says what was read
back). Only ``max_seconds``, a wall-clock guard, can stop a run off these steps. Burn-in is then
``2 * max(tau)`` steps and thinning ``max(1, min(tau) / 2)``; the effective sample size of each
parameter is ``n_walkers * (N - burn_in) / tau``.

Ctrl-C while sampling saves the steps done and raises :class:`SamplingInterrupted` (one line:
the step and the file); an error inside ``log_prob`` is raised after the step it hit is dropped,
without emcee's parameter dump.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import emcee
import numpy as np
from tqdm.auto import tqdm

from hmid.errors import ConfigError
from hmid.models.sls._chainfile import FIX, ChainStore, state_from_json
from hmid.models.sls._convergence import acceptance, converged, replay, tau_of
from hmid.models.sls._errors import SamplerError, SamplingInterrupted
from hmid.models.sls._logprob import LogProb
from hmid.models.sls._moves import SnookerMove
from hmid.models.sls._sampler_result import SamplerResult
from hmid.progress import bars_wanted

__all__ = [
    "STOP_REASONS",
    "SamplerConfig",
    "SamplerError",
    "SamplerResult",
    "SamplingInterrupted",
    "SnookerMove",
    "run_sampler",
]

STOP_REASONS = ("converged", "step budget", "time budget", "exact")
BALL_REDRAWS = 3  # non-finite walkers of the initial ball are re-drawn this often before failing
_FORMAT = 2  # 2: a digest over every stored row


@dataclass(frozen=True)
class SamplerConfig:
    """Settings of :func:`run_sampler`, checked at construction (:class:`ConfigError`).

    ``moves``: ``"de"`` (default) proposes with differential evolution (``DEMove``, weight 0.8)
    and its snooker variant (:class:`SnookerMove`, emcee's ``DESnookerMove`` corrected, 0.2):
    proposals are differences of other walkers, so they take the posterior's scale and linear
    correlations without tuning and open a small start ball quickly; the snooker move helps with
    curved posteriors. ``"stretch"`` is emcee's default affine-invariant stretch move (robust;
    on the toy problems here its autocorrelation time is 3-4 times DE's).

    ``n_walkers`` must be even (the ensemble splits into two equal halves, each proposing from
    the other) and at least ``2 * D`` (checked by :func:`run_sampler`). ``max_steps`` bounds the
    chain's total length (over resumed runs too); ``max_seconds`` bounds one call's wall time.
    ``init_scale`` is the walker ball's standard deviation relative to ``|theta0|`` (absolute
    where a component of ``theta0`` is 0); :func:`run_sampler`'s ``ball_scale`` overrides it.
    ``n_walkers``, ``moves``, ``seed`` and the ball define the chain (with ``theta0``, the names
    and a fingerprint): a chain file made with others is refused; the other settings may change
    between resumed runs.
    """

    n_walkers: int = 32
    moves: Literal["de", "stretch"] = "de"
    max_steps: int = 20_000
    max_seconds: float = 3600.0
    min_tau_factor: float = 50.0
    tau_rtol: float = 0.01
    check_every: int = 200
    seed: int = 0
    init_scale: float = 1e-3
    progress: bool = False

    def __post_init__(self) -> None:
        for name, low in (("n_walkers", 4), ("max_steps", 1), ("check_every", 1), ("seed", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ConfigError(f"sampler: {name} must be an integer >= {low}, got {value!r}")
        if self.n_walkers % 2:
            raise ConfigError(
                f"sampler: n_walkers must be even (the ensemble splits into two equal halves "
                f"that propose from each other), got {self.n_walkers}"
            )
        for name in ("max_seconds", "min_tau_factor", "tau_rtol", "init_scale"):
            value = getattr(self, name)
            ok = isinstance(value, int | float) and not isinstance(value, bool) and value > 0
            if not ok or (name != "max_seconds" and not math.isfinite(value)):
                raise ConfigError(f"sampler: {name} must be a positive number, got {value!r}")
        if self.moves not in ("de", "stretch"):
            raise ConfigError(f"sampler: moves must be 'de' or 'stretch', got {self.moves!r}")
        if not isinstance(self.progress, bool):
            raise ConfigError(f"sampler: progress must be true or false, got {self.progress!r}")

    def emcee_moves(self) -> list[tuple[emcee.moves.Move, float]]:
        if self.moves == "stretch":
            return [(emcee.moves.StretchMove(), 1.0)]
        return [(emcee.moves.DEMove(), 0.8), (SnookerMove(), 0.2)]


def run_sampler(
    log_prob: Callable[[np.ndarray], np.ndarray],
    theta0: np.ndarray,
    config: SamplerConfig | None = None,
    *,
    backend_path: str | Path | None = None,
    names: Sequence[str],
    fingerprint: str = "",
    ball_scale: np.ndarray | None = None,
    fresh: bool = False,
) -> SamplerResult:
    """Sample ``log_prob`` from a ball around ``theta0`` until converged or out of budget.

    With ``backend_path`` the chain is saved as it runs; a file holding a chain of the same
    configuration (``config``'s chain-defining fields, ``theta0``, ``names`` and
    ``fingerprint``, e.g. a hash of the data and model settings) is resumed, anything else is
    refused with :class:`SamplerError`; ``fresh`` starts it anew. On resume ``log_prob`` is
    re-evaluated at the last walkers and must reproduce the stored values (else the target
    changed: an error).

    ``ball_scale`` (D,), if given, is the walker ball's standard deviation per coordinate (e.g.
    the start fit's standard errors) instead of ``config.init_scale * |theta0|``.
    """
    cfg = config if config is not None else SamplerConfig()
    theta0 = np.asarray(theta0, dtype=float)
    names = tuple(names)
    if theta0.ndim != 1 or len(names) != theta0.size or len(set(names)) != len(names):
        raise ConfigError(f"sampler: theta0 {theta0.shape} needs one distinct name each: {names}")
    if not np.all(np.isfinite(theta0)):
        raise SamplerError(f"sampler: theta0 is not finite: {_format(theta0, names)}")
    n_walkers, dim = cfg.n_walkers, theta0.size
    if n_walkers < 2 * dim:
        raise ConfigError(
            f"sampler: n_walkers={n_walkers} is fewer than 2·D = {2 * dim}: each half of the "
            f"ensemble must span the {dim}-dimensional space the other half moves in"
        )
    if ball_scale is None:
        radius = cfg.init_scale * np.where(theta0 != 0, np.abs(theta0), 1.0)
    else:
        radius = np.asarray(ball_scale, dtype=float)
        if radius.shape != theta0.shape or not np.all(np.isfinite(radius) & (radius > 0)):
            raise ConfigError(f"sampler: ball_scale must be {dim} positive numbers: {radius}")
    target = LogProb(log_prob, theta0, n_walkers // 2)
    meta = {
        "format": _FORMAT,
        "n_walkers": n_walkers,
        "moves": cfg.moves,
        "seed": int(cfg.seed),
        "ball_scale": [float(v).hex() for v in radius],
        "theta0": [float(v).hex() for v in theta0],
        "names": list(names),
        "fingerprint": fingerprint,
    }
    store = None if backend_path is None else ChainStore(Path(backend_path), meta, n_walkers, dim)
    with contextlib.ExitStack() as stack:
        if store is not None:
            stack.enter_context(store.lock())
        return _sample(target, theta0, radius, names, cfg, store, fresh)


@dataclass
class _Walk:
    """Where a run stands: emcee's backend and last whole step (``state``, after ``it`` steps),
    tau at the checks so far (``history``; ``tau`` the last, ``tau_ref`` the last at a multiple
    of ``check_every``), why it stopped (None: it goes on) and the steps read back from a file."""

    backend: emcee.backends.Backend
    state: emcee.State
    it: int
    history: list[list[float]]
    tau: np.ndarray | None = None
    tau_ref: np.ndarray | None = None
    stop: str | None = None
    reused: int = 0


def _sample(target, theta0, radius, names, cfg, store, fresh) -> SamplerResult:
    checkpoint = None if store is None else store.prepare(fresh=fresh)
    backend = emcee.backends.Backend()
    backend.reset(cfg.n_walkers, theta0.size)
    if checkpoint is None:
        walk = _fresh(backend, target, theta0, radius, names, cfg, store)
    else:
        walk = _resumed(backend, target, checkpoint, cfg, store)
    sampler = _ensemble(walk, target, cfg)
    start = time.perf_counter()
    bar = tqdm(
        total=cfg.max_steps,
        initial=min(walk.it, cfg.max_steps),
        disable=not (cfg.progress or bars_wanted()),
        desc="SLS posterior (MCMC)",
        unit="step",
    )
    with bar:
        while walk.stop is None:
            if walk.it >= cfg.max_steps:
                walk.stop = "step budget"
                break
            if time.perf_counter() - start >= cfg.max_seconds:
                walk.stop = "time budget"
                break
            _to_next_check(sampler, walk, target, cfg, store, bar, start)
    return _result(
        walk.backend,
        walk.tau,
        walk.history,
        names,
        walk.stop,
        time.perf_counter() - start,
        store,
        target.n_nan,
        min(walk.reused, walk.backend.iteration),
    )


def _fresh(backend, target, theta0, radius, names, cfg, store) -> _Walk:
    """A new chain: the seeded initial ball and the moves' seeded random state."""
    ball_seed, move_seed = np.random.SeedSequence(cfg.seed).spawn(2)
    ball_rng = np.random.default_rng(ball_seed)
    coords, logp = _initial_ball(target, theta0, radius, cfg.n_walkers, ball_rng, names)
    random_state = np.random.RandomState(np.random.MT19937(move_seed)).get_state()
    if store is not None:
        store.initialise()
    state = emcee.State(coords, log_prob=logp, random_state=random_state)
    return _Walk(backend, state, it=backend.iteration, history=[])


def _resumed(backend, target, checkpoint, cfg, store) -> _Walk:
    """The stored chain, replayed through the convergence rule: a fresh run's numbers."""
    stored, stored_logp = store.read(checkpoint)
    _check_same_target(target, stored[-1], stored_logp[-1], store.path)
    replayed = replay(stored, cfg)  # what a fresh run stops with, whatever the file holds
    backend.chain, backend.log_prob = stored[: replayed.n], stored_logp[: replayed.n]
    backend.iteration = replayed.n
    if replayed.reason is None:  # sampling goes on: emcee's counts go on from the file's
        backend.accepted = np.asarray(checkpoint["accepted"], dtype=float)
    random_state = state_from_json(checkpoint["random_state"])
    target.n_nan = checkpoint["n_nan"]
    state = emcee.State(backend.chain[-1], log_prob=backend.log_prob[-1], random_state=random_state)
    return _Walk(backend, state, backend.iteration, replayed.history, replayed.tau,
                 replayed.tau_ref, replayed.reason, len(stored))  # fmt: skip


def _ensemble(walk: _Walk, target, cfg) -> emcee.EnsembleSampler:
    """emcee's sampler on ``walk``'s backend, with the walk's random state (verified)."""
    random_state = walk.state.random_state
    walk.backend.random_state = random_state
    dim = walk.state.coords.shape[1]
    sampler = emcee.EnsembleSampler(
        cfg.n_walkers, dim, target, moves=cfg.emcee_moves(), backend=walk.backend, vectorize=True
    )
    sampler.random_state = random_state  # emcee's setter fails silently: verify it took
    if not np.array_equal(sampler.random_state[1], random_state[1]):
        raise SamplerError("sampler: emcee did not accept the seeded random state")
    return sampler


def _to_next_check(sampler, walk: _Walk, target, cfg, store, bar, start: float) -> None:
    """Sample up to the next check (or the time budget), keeping the steps done on an error or
    Ctrl-C; at a check, tau and the convergence rule."""
    saved, n_nan, accepted = walk.it, target.n_nan, walk.backend.accepted.copy()
    end = min(cfg.max_steps, (walk.it // cfg.check_every + 1) * cfg.check_every)
    steps = sampler.sample(walk.state, iterations=end - walk.it, skip_initial_state_check=True)
    try:
        for new_state in steps:
            target.reraise()  # a step that saw an error or Ctrl-C is not kept
            # emcee updates its state in place: keep a copy of the last whole step
            walk.state = emcee.State(new_state, copy=True)
            walk.it, n_nan, accepted = walk.it + 1, target.n_nan, walk.backend.accepted.copy()
            bar.update(1)
            if time.perf_counter() - start >= cfg.max_seconds:
                break
        target.reraise()
    except BaseException as err:  # keep the steps done; the last kept state is consistent
        if store is not None and walk.it > saved:
            store.save(walk.backend, walk.state, saved, walk.it, n_nan, walk.history, accepted)
        if isinstance(err, KeyboardInterrupt):
            raise SamplingInterrupted(walk.it, None if store is None else store.path) from None
        raise
    if walk.it not in (end, cfg.max_steps):  # stopped by the time budget between checks
        if store is not None:
            store.save(walk.backend, walk.state, saved, walk.it, n_nan, walk.history, accepted)
        return
    tau_prior, walk.tau = walk.tau_ref, tau_of(walk.backend.get_chain())
    if walk.it % cfg.check_every == 0:
        walk.tau_ref = walk.tau
    walk.history.append([walk.it, *walk.tau])
    bar.set_postfix(tau_max=f"{walk.tau.max():.1f}")
    if store is not None:
        store.save(walk.backend, walk.state, saved, walk.it, target.n_nan, walk.history, accepted)
    if converged(walk.tau, tau_prior, walk.it, cfg):
        walk.stop = "converged"


def _initial_ball(target, theta0, radius, n_walkers, rng, names):
    start = target.padded(theta0[None, :])[0]
    if not np.isfinite(start):
        raise SamplerError(
            f"sampler: log_prob at theta0 ({_format(theta0, names)}) is {start}; start from a "
            f"point inside the prior support (e.g. the least-squares fit)"
        )
    coords = theta0 + radius * rng.standard_normal((n_walkers, theta0.size))
    logp = target.padded(coords)
    for _ in range(BALL_REDRAWS):
        bad = ~np.isfinite(logp)
        if not bad.any():
            break
        coords[bad] = theta0 + radius * rng.standard_normal((int(bad.sum()), theta0.size))
        logp[bad] = target.padded(coords[bad])
    bad = np.flatnonzero(~np.isfinite(logp))
    if bad.size:
        shown = "; ".join(_format(coords[i], names) for i in bad[:3])
        raise SamplerError(
            f"sampler: {bad.size} of {n_walkers} walkers of the initial ball have a non-finite "
            f"log_prob after {BALL_REDRAWS} re-draws, e.g. at {shown}; move theta0 away from the "
            f"support's edge or shrink the ball (init_scale or ball_scale)"
        )
    if not emcee.walkers_independent(coords):
        raise SamplerError(
            "sampler: the initial walkers are linearly dependent; enlarge the ball (init_scale or "
            "ball_scale)"
        )
    return coords, logp


def _check_same_target(target, coords, logp, path):
    now = target.padded(coords)
    same = np.isclose(now, logp, rtol=1e-6, atol=1e-6) | ((now == logp) & np.isinf(now))
    if not same.all():
        delta = np.nanmax(np.abs(now - logp))
        raise SamplerError(
            f"{path}: log_prob at the stored chain's last walkers differs from the stored values "
            f"(max |difference| {delta:.3g}): the data or model changed; {FIX}"
        )


def _result(backend, tau, history, names, stop, wall, store, n_nan, reused) -> SamplerResult:
    chain, logp = backend.get_chain(), backend.get_log_prob()
    n, n_walkers, dim = chain.shape
    tau = tau_of(chain) if tau is None else tau
    burn = min(int(2 * np.max(tau)), n // 2)
    thin = max(1, int(0.5 * np.min(tau)))
    return SamplerResult(
        names=names,
        chain=chain[burn::thin].reshape(-1, dim),
        log_prob=logp[burn::thin].reshape(-1),
        acceptance=acceptance(chain),
        tau=tau,
        ess=n_walkers * (n - burn) / tau,
        n_steps=n,
        burn_in=burn,
        thin=thin,
        stop_reason=stop,
        wall_s=wall,
        backend_path=None if store is None else store.path,
        walkers=chain,
        walkers_log_prob=logp,
        tau_history=np.asarray(history, dtype=float).reshape(-1, dim + 1),
        n_nan=n_nan,
        reused_steps=reused,
    )


def _format(theta: np.ndarray, names: Sequence[str]) -> str:
    return ", ".join(f"{name}={value:.6g}" for name, value in zip(names, theta, strict=True))


def _array(values) -> np.ndarray | None:
    return None if values is None else np.asarray(values, dtype=float)
