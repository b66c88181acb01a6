"""A model's free runs over a log's blocks, with their band: the driver that ties the equation,
the integrator, the band and the scores together (what the pipeline's ``freerun`` stage and
:meth:`Model.free_run <hmid.portable.Model.free_run>` call).

Each block starts from the measured state at its first row (the memory arms' states from the
measured position before it: the arm's response to the motion up to there) and is driven by the
measured inputs alone.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from hmid.portable.freerun.band import (
    DRIFT,
    Calibration,
    choose,
    coefficient_draws,
    disturbances,
    drifts,
    posterior_draws,
    quantile_band,
)
from hmid.portable.freerun.equation import NotSimulable
from hmid.portable.freerun.integrator import Simulator, padded_size, simulator
from hmid.portable.freerun.scores import FreeRun, score_block

#: A block's rows: their numbers, or a range of them (:func:`block_spans`)
Span = np.ndarray | range


def blocks(signals, role: str = "validation") -> list[np.ndarray]:
    """Row spans to simulate: within each segment, from the first to the last row of ``role``,
    split where the role's rows stop for longer than a second (another block of the split)."""
    return [np.arange(span.start, span.stop) for span in block_spans(signals, role)]


def block_spans(signals, role: str = "validation") -> list[range]:
    """:func:`blocks` as ranges: a long log's blocks are not held as row numbers (the training
    blocks of 10 M rows would be ~60 MB of them, of which the band keeps a few)."""
    mask = signals.rows(role)
    t = signals["t"]
    out = []
    for start, stop in signals.bounds():
        chosen = start + np.flatnonzero(mask[start:stop])
        if len(chosen) < 10:
            continue
        edges = [0, *_breaks(t, chosen), len(chosen)]
        out += [range(int(chosen[a]), int(chosen[b - 1]) + 1)
                for a, b in itertools.pairwise(edges) if b - a >= 10]  # fmt: skip
    return out


def _breaks(t: np.ndarray, chosen: np.ndarray, block: int = 1 << 20) -> list[int]:
    """Where the rows ``chosen`` stop for longer than a second: the index of the row after each
    pause (by blocks of rows: a long log's times there are not copied whole)."""
    found: list[int] = []
    for lo in range(0, len(chosen) - 1, block):
        steps = np.diff(t[chosen[lo : lo + block + 1]])
        found += (np.flatnonzero(steps > 1.0) + lo + 1).tolist()
    return found


#: Held-out time a model runs free for, at most (s): a free run costs in proportion to the time
#: it simulates, and its scores settle within tens of blocks; a long log's blocks are sampled
FREE_RUN_BUDGET_S = 60.0


def within_budget(spans: Sequence[Span], dt: float) -> tuple[list[Span], str]:
    """Every ``stride``-th span, the least stride whose spans last at most
    :data:`FREE_RUN_BUDGET_S` (evenly spread over the log: the same blocks every run), or the
    first span's first :data:`FREE_RUN_BUDGET_S` where no stride fits; and what was left out,
    in words ("" when every span is kept)."""
    total = sum(len(rows) for rows in spans) * dt
    if total <= FREE_RUN_BUDGET_S:
        return list(spans), ""
    budget = f"at most {FREE_RUN_BUDGET_S:g} s of held-out time per model; {total:.0f} s in all"
    for stride in range(2, len(spans) + 1):
        kept = list(spans[::stride])
        if sum(len(rows) for rows in kept) * dt <= FREE_RUN_BUDGET_S:
            return kept, (
                f"free run on {len(kept)} of {len(spans)} held-out blocks (every "
                f"{_nth(stride)}: {budget})"
            )
    first = spans[0][: max(int(FREE_RUN_BUDGET_S / dt), 10)]
    return [first], f"free run on the first {len(first) * dt:.0f} s of the held-out rows ({budget})"


def _nth(n: int) -> str:
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


def chunks(spans: list[Span], length: int) -> list[Span]:
    """``spans`` cut into runs of ``length`` rows (the remainder a shorter run; at least ten
    rows each): the training blocks as long as the held-out ones, so that the band is
    calibrated on the horizon it is checked on (a free run's error grows with it)."""
    length = max(length, 10)
    out = []
    for rows in spans:
        out += [rows[i : i + length] for i in range(0, len(rows), length)]
    return [part for part in out if len(part) >= 10]


def simulate_signals(
    model, signals, spans, *, v0: float | None = None, draws: int = 0, level: float = 0.9,
    seed: int = 0, calibration: list[np.ndarray] | None = None,
    held: FreeRunRows | None = None,
) -> FreeRun:  # fmt: skip
    """Free runs of ``model`` on ``signals`` over each span of rows (see :func:`blocks`); with
    ``draws``, a ``level`` band of the position from as many draws of the coefficients and of a
    disturbance (a force or a drift: :mod:`~hmid.portable.freerun.band`), whose shape and scale
    are chosen on the ``calibration`` spans (the training blocks; without them, a force at the
    training residual's scale).
    ``held`` (:func:`held_rows`) instead of ``signals``, ``spans`` and ``calibration``: the
    same runs on the rows they read alone."""
    if held is not None:
        signals, spans = held.signals, held.spans
    try:
        sim = simulator(model, v0)
    except NotSimulable as err:
        return FreeRun(model.name, (), str(err))
    memory_rows = _memory_states(model, signals) if held is None else held.memory[model.name]
    band, sampled, scale, calibrated, stride = "", None, 1.0, None, 1
    pieces: Sequence[Span] = []
    if draws and spans:
        sampled = coefficient_draws(model, sim, draws, seed)
        has = posterior_draws(model) is not None
        band = "posterior draws" if has else "coefficient covariance"
        if sampled is None:
            sampled, band = [sim.coefficients()] * draws, "no coefficient uncertainty in the file"
        pieces = calibration_pieces(spans, calibration) if held is None else held.pieces
    # one padded size for every block: one compiled program (and one trace) per model shape
    size = padded_size(max(len(rows) for rows in (*spans, *pieces))) if spans else None
    if sampled:
        stride = _stride(sim, _start(sim, signals, max(spans, key=len)[:2000], memory_rows),
                         len(sampled), size)  # fmt: skip
    if pieces:
        calibrated = _calibrate(model, sim, signals, pieces, sampled, memory_rows, level, seed,
                                stride, size)  # fmt: skip
        scale = calibrated.scale
    rng = np.random.default_rng([seed, 1])
    drift = calibrated is not None and calibrated.kind == DRIFT
    # a band no scale calibrates is not drawn: its coverage would read as a check of nothing
    banded = sampled and (calibrated is None or calibrated.reachable)
    out = []
    for rows in spans:
        start = _start(sim, signals, rows, memory_rows)
        run = sim.integrate(*start, size=size)
        bounds = None
        if banded:
            runs = _draws(model, sim, start, run.x, sampled, scale, drift, rng, stride, size)
            bounds = quantile_band(runs, level)
        out.append(score_block(model.rig, signals, rows, run, bounds))
    return FreeRun(model.name, tuple(out), level=level if sampled else None,
                   band=_describe(band, calibrated) if sampled else "",
                   calibration=calibrated)  # fmt: skip


def _draws(model, sim, start, nominal, sampled, scale, drift, rng, stride,
           size) -> np.ndarray:  # fmt: skip
    """The position of a block's band draws (draws, samples): each coefficient draw run with
    its disturbance force (scale ``scale``), or run without one and a drift of that scale
    added (``drift``), about the error-controlled ``nominal`` run (:func:`_about`)."""
    n, count = len(start[0]), len(sampled)
    noise = np.zeros((count, n)) if drift else scale * disturbances(model, n, count, rng)
    runs = sim.positions(*start, [sim.coefficients(), *sampled],
                         np.concatenate([np.zeros((1, n)), noise]), stride=stride,
                         size=size)  # fmt: skip
    runs = _about(runs[1:], runs[0], nominal)
    return runs + scale * drifts(start[0], count, rng) if drift else runs


def _about(runs: np.ndarray, fixed: np.ndarray, nominal: np.ndarray) -> np.ndarray:
    """Draws taken at the band's fixed steps, moved onto the error-controlled ``nominal`` run:
    each draw's deviation from the nominal coefficients' run at the same fixed steps
    (``fixed``), added to ``nominal``. The fixed steps' own error, common to every row, cancels:
    on the linear stage, where the stiff friction near v = 0 makes a 4-sample step miss the
    error-controlled run by up to 1.4 mm (its free run misses the measured position by at most
    0.1 mm), the band was made of that miss and its disturbance scaled to cover it."""
    with np.errstate(invalid="ignore"):  # a diverged draw's inf less a finite run stays inf
        return nominal + (runs - fixed)


#: What a block's free run starts from: its times, inputs, first position, speed, memory states
Start = tuple[np.ndarray, dict[str, np.ndarray], float, float, list[float]]

#: The band's draws step at most this long (in whole samples, at least one): a fifth of the
#: steps of a 1 kHz log, checked against the error-controlled run (:func:`_stride`)
BAND_STEP = 0.005
#: The training samples the band is calibrated on, at most, as a multiple of the held-out ones:
#: all of a 70/30 split's (2.3 times); at 2, every other piece of the shipped rigs' was left out
CALIBRATION_SHARE = 3.0


def _stride(sim: Simulator, start: Start, draws: int, size: int | None) -> int:
    """Samples per step of the band's draws: the longest, of at most :data:`BAND_STEP`, at
    which the nominal run leaves the error-controlled one by no more than 1 % of the motion
    there (a stiff model takes shorter steps, one sample at the least: a model that fails at
    five samples often passes at four, at a quarter of one sample's cost). The check runs as
    many rows as a band (one compiled program)."""
    t = start[0]
    longest = max(1, int(BAND_STEP / np.median(np.diff(t))))
    if longest == 1:
        return 1
    exact = sim.integrate(*start, size=size).x
    rows = [sim.coefficients()] * (1 + draws)
    for stride in range(longest, 1, -1):
        fixed = sim.positions(*start, rows, np.zeros((1 + draws, len(t))), stride=stride,
                              size=size)[0]  # fmt: skip
        gap = np.max(np.abs(fixed - exact)) if np.all(np.isfinite(fixed)) else np.inf
        if gap <= 0.01 * (np.ptp(exact) or 1e-3):
            return stride
    return 1


def calibration_pieces(spans: list[Span], calibration) -> list[Span]:
    """The training rows a band over ``spans`` is calibrated on: the ``calibration`` spans cut
    as long as the longest of ``spans`` and spread to at most :data:`CALIBRATION_SHARE` times
    their rows (none without spans or calibration)."""
    if not spans or not calibration:
        return []
    length = max(len(rows) for rows in spans)
    total = sum(len(rows) for rows in spans)
    return _spread(chunks(calibration, length), CALIBRATION_SHARE * total)


@dataclass(frozen=True)
class FreeRunRows:
    """The rows free runs read, as signals of their own: a long log's whole signals need not be
    held while they run (they import and compile JAX). ``spans`` (the blocks to run) and
    ``pieces`` (the training rows the band is calibrated on) count rows of ``signals``;
    ``memory`` holds each model's memory states on those rows, found on the whole log (an
    arm's state is its response to all the motion before)."""

    signals: object  # hmid.balance.Signals
    spans: list[np.ndarray]
    pieces: list[np.ndarray]
    memory: Mapping[str, list[np.ndarray]] = field(default_factory=dict)


def held_rows(signals, spans, calibration=None, models=()) -> FreeRunRows:
    """The rows of ``signals`` that free runs over ``spans`` (with a band calibrated on the
    ``calibration`` spans) read, for each of ``models``: :func:`simulate_signals` gives the same
    runs with ``rows=`` as with the whole signals. Spans are row numbers or ranges of them
    (:func:`block_spans`: only the rows of those kept are made)."""
    pieces = [_rows(rows) for rows in calibration_pieces(spans, calibration)]
    spans = [_rows(rows) for rows in spans]
    parts = [*spans, *pieces]
    index = np.unique(np.concatenate(parts)) if parts else np.zeros(0, dtype=int)
    frame = signals.frame.iloc[index].reset_index(drop=True)
    own = type(signals)(frame, signals.units, signals.channels, signals.position,
                        signals.smoother)  # fmt: skip
    memory = {m.name: [state[index] for state in _memory_states(m, signals)] for m in models}
    return FreeRunRows(own, [np.searchsorted(index, rows) for rows in spans],
                       [np.searchsorted(index, rows) for rows in pieces], memory)  # fmt: skip


def _rows(span: Span) -> np.ndarray:
    """A span's row numbers (a range of :func:`block_spans` made an array)."""
    return np.arange(span.start, span.stop) if isinstance(span, range) else np.asarray(span)


def _spread(pieces: list[Span], samples: float) -> list[Span]:
    """At most ``samples`` rows of ``pieces``, taken evenly across them (every k-th piece)."""
    total = sum(len(p) for p in pieces)
    if total <= samples:
        return pieces
    every = int(np.ceil(total / samples))
    return pieces[::every]


def _start(sim: Simulator, signals, rows, memory_rows) -> Start:
    """A block's times, inputs and measured first state: what a free run starts from."""
    first = rows[0]
    inputs = {name: signals[name][rows] for name in sim.equation.inputs}
    return (signals["t"][rows], inputs, signals[sim.position][first], signals["v"][first],
            [m[first] for m in memory_rows])  # fmt: skip


def _calibrate(model, sim, signals, spans, sampled, memory_rows, level, seed, stride,
               size) -> Calibration:  # fmt: skip
    """The disturbance's shape and scale from the training ``spans`` (:func:`~.band.choose`):
    per span, the nominal coefficients, every coefficient draw without disturbance, and the
    nominal coefficients under every disturbance force of scale 1 (one vectorised call), and as
    many drifts of the position (no run); and the share of the coefficient draws that diverge
    there."""
    rng = np.random.default_rng([seed, 2])
    nominal = sim.coefficients()
    forced, drifted = [], []
    count = len(sampled)
    diverged = np.zeros(count, dtype=bool)
    for rows in spans:
        start = _start(sim, signals, rows, memory_rows)
        # one call: the nominal run, each coefficient draw, the nominal under each disturbance
        noise = np.zeros((1 + 2 * count, len(rows)))
        noise[1 + count :] = disturbances(model, len(rows), count, rng)
        runs = sim.positions(*start, [nominal, *sampled, *[nominal] * count], noise,
                             stride=stride, size=size)  # fmt: skip
        # the band is centred on the error-controlled run, as the held-out blocks' (_about)
        x, x0 = signals[sim.position][rows], sim.integrate(*start, size=size).x
        fixed = runs[0]
        with np.errstate(invalid="ignore"):
            c, d = runs[1 : 1 + count] - fixed, runs[1 + count :] - fixed
        # judged at the band's own steps, between which its draws are linear: a stride's
        # samples tell no more of its coverage, and cost the scale's search as many passes
        step = slice(None, None, stride)
        forced.append((x[step], x0[step], c[:, step], d[:, step]))
        drifted.append((x[step], x0[step], c[:, step], drifts(start[0][step], count, rng)))
        diverged |= ~np.all(np.isfinite(runs[1 : 1 + count]), axis=1)
    return replace(choose(forced, drifted, level), diverging=float(np.mean(diverged)))


def _describe(band: str, calibrated: Calibration | None) -> str:
    """What the band is made of, in a few words (the scale and coverages are the table's)."""
    if calibrated is None:
        return band + " + the training residual as a disturbance force (not calibrated)"
    if not calibrated.reachable:
        return band + ": " + calibrated.why_not()
    if calibrated.scale == 0:
        return band + " alone (it covers the training blocks without a disturbance)"
    shape = "a drift of the position" if calibrated.kind == DRIFT else "a disturbance force"
    return f"{band} + {shape}, calibrated on the training blocks"


def _memory_states(model, signals) -> list[np.ndarray]:
    """Each memory arm's state g_tau(x) on every row, from the measured position (the block's
    initial state: the arm's response to the motion before it)."""
    from hmid.balance import Structure
    from hmid.balance.kinds import MemoryTerm

    out = []
    for term in model.terms:
        if isinstance(term, MemoryTerm):
            column = Structure.of((term,)).columns(signals).values[:, 0]
            out.append(column / term.sign)
    return out


def free_run(model, log, *, v0: float | None = None) -> FreeRun:
    """Free run of ``model`` over ``log`` (from its first usable row to its last) from the
    measured state there, driven by the log's inputs."""
    signals = model.signals(log)
    usable = np.flatnonzero(signals["usable"])
    spans = [np.arange(usable[0], usable[-1] + 1)] if len(usable) else []
    return simulate_signals(model, signals, spans, v0=v0)
