"""A round's candidate screens, shared between the run and its worker (:mod:`hmid.workers`).

Each screen is independent of the others (it runs in a cache scope and profiles every parameter
afresh), so a worker can take some of them. The worker is sent the round once, in a file: the
signals without their cache, the model's terms at their values, the candidates. It refits the
model, screens, and sends back where each screen ended (every term's value) with its test; the
run refits the joint model there on its own signals. Both are the same least squares on the same
columns, so a screen's numbers do not depend on where it ran (tested).
"""

from __future__ import annotations

import itertools
import pickle
import tempfile
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from threadpoolctl import threadpool_limits

from hmid.balance import Signals, Structure, StructureFit, fit_structure
from hmid.balance.structure import Placed
from hmid.loop.candidates import Candidate
from hmid.loop.screen import Screen, screen
from hmid.stats import NestedTest
from hmid.workers import Tasks

#: in a worker: the round it screens (its file's path and what the file holds)
_ROUND: dict[str, tuple] = {}
_ROUNDS = itertools.count()  # a round's file name: unique in this process


@dataclass(frozen=True)
class _Outcome:
    """A screen as a worker sends it back: small, and free of the worker's objects."""

    values: tuple[float | None, ...]  # every term's value in the joint model
    test: NestedTest
    interval: tuple[float, float] | None
    physical: bool
    n_eff: float
    collinear: bool

    def screen(self, current: StructureFit, candidate: Candidate, signals: Signals) -> Screen:
        terms = (*(p.term for p in current.structure.terms), candidate)
        structure = Structure(tuple(Placed(t, v) for t, v in zip(terms, self.values, strict=True)))
        with signals.scoped():
            joint = fit_structure(structure, signals)
        return Screen(candidate, joint, self.test, self.interval, self.physical, self.n_eff,
                      self.collinear)  # fmt: skip


def screen_round(
    current: StructureFit, candidates: list[Candidate], signals: Signals, confidence: float,
    tasks=None,
) -> list[Screen]:  # fmt: skip
    """Every candidate screened against ``current`` (in order), shared with ``tasks``' workers
    (:class:`~hmid.workers.Tasks`; default: as many as :func:`~hmid.workers.default_workers`)."""
    tasks = Tasks(ahead=1) if tasks is None else tasks
    if not tasks.workers or len(candidates) < 2:
        return [_screen_here(current, c, signals, confidence) for c in candidates]
    # dearest first (a screen fits the model at every value of the candidate's grid): each
    # process takes the next when it is free, so the last to finish is a cheap one
    order = sorted(range(len(candidates)), key=lambda i: -_grid_size(candidates[i]))
    with tempfile.TemporaryDirectory(prefix="hmid-round-") as folder:
        path = Path(folder) / f"round-{next(_ROUNDS)}.pickle"
        placed = tuple((p.term, p.value) for p in current.structure.terms)
        with path.open("wb") as file:
            pickle.dump((signals, placed, candidates, confidence), file, protocol=5)
        for i in order:
            here = partial(_screen_here, current, candidates[i], signals, confidence)
            tasks.submit(_screen_there, str(path), i, here=here)
        found = dict(zip(order, tasks.results(), strict=True))
    return [
        found[i] if isinstance(found[i], Screen) else found[i].screen(current, c, signals)
        for i, c in enumerate(candidates)
    ]


def _grid_size(candidate: Candidate) -> int:
    return 1 if candidate.hyper is None else len(candidate.hyper.grid)


def _screen_here(current, candidate, signals, confidence) -> Screen:
    with signals.scoped():  # its transforms and columns: of no use to the next
        return screen(current, candidate, signals, confidence)


def _screen_there(path: str, index: int) -> _Outcome:
    """In a worker: screen candidate ``index`` of the round in ``path``."""
    if path not in _ROUND:
        _ROUND.clear()  # an earlier round's signals and caches
        with open(path, "rb") as file:
            signals, placed, candidates, confidence = pickle.load(file)
        structure = Structure(tuple(Placed(term, value) for term, value in placed))
        with threadpool_limits(limits=1, user_api="blas"):
            current = fit_structure(structure, signals)
        _ROUND[path] = (signals, current, candidates, confidence)
    signals, current, candidates, confidence = _ROUND[path]
    with threadpool_limits(limits=1, user_api="blas"):  # as the run's loop: see run_loop
        s = _screen_here(current, candidates[index], signals, confidence)
    values = tuple(p.value for p in s.joint.structure.terms)
    return _Outcome(values, s.test, s.interval, s.physical, s.n_eff, s.collinear)
