"""What a simulated rig is: the interface every rig implements, one integrator, one trajectory.

A rig (:mod:`hmid.simulate.rigs`) states its physics and nothing else:

* its parameters, traced as a pytree (``prepare``: new values do not recompile);
* its state and one sample's step (``sample``): the state after the sampling interval and the
  outputs logged for it, advanced in the rig's own ``substeps`` (in JAX, float64);
* what a trajectory holds (``signals``) and how raw outputs become those signals, with the rig's
  physical checks (``trajectory``).

:func:`integrate` does the rest, once for every rig: the scan over samples under ``jax.jit``
(compiled once per rig, log length and substep count), float64, the sample times, and the check
that the run stayed finite. :func:`closed_loop` runs the same rig under a controller that reads
the rig's outputs and sets its inputs at every sample (the control of :mod:`hmid.control`). The
rig's data sets (its logs, sensors and truth record) follow the
contract of :mod:`hmid.simulate.dataset`; :mod:`hmid.simulate.write` writes any of them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from hmid.errors import SimulationError


@dataclass(frozen=True)
class Trajectory:
    """True signals of a simulated rig at the sample instants ``t`` (SI units), by name.

    ``traj.x`` reads the signal ``x``; which signals there are is the rig's ``signals``.
    """

    t: np.ndarray
    signals: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __getattr__(self, name: str) -> np.ndarray:
        if name.startswith("__") or name == "signals":  # copy/pickle probes, early lookups
            raise AttributeError(name)
        try:
            return self.signals[name]
        except KeyError:
            raise AttributeError(f"the trajectory has no signal {name!r}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.signals)

    def replace(self, **changes: np.ndarray) -> Trajectory:
        """A copy with some signals (or ``t``) replaced."""
        t = changes.pop("t", self.t)
        unknown = set(changes) - set(self.signals)
        if unknown:
            raise KeyError(f"the trajectory has no signals {sorted(unknown)}")
        return Trajectory(t, {**self.signals, **changes})


class SimulatedRig(ABC):
    """A rig that :func:`integrate` can run; subclass it for a new rig.

    Class attributes: ``name`` (for messages), ``inputs`` (the per-sample inputs it reads; the
    first is required, the others default), ``signals`` (what its trajectory holds: name ->
    meaning), ``first_sample`` (sample k is logged at t = (k + first_sample) / rate: 1 for a rig
    that logs the state at the end of each interval, 0 at its start), ``finite`` (the raw outputs
    that must stay finite) and ``diverged`` (what to check when they do not).
    """

    name: ClassVar[str]
    inputs: ClassVar[tuple[str, ...]]
    signals: ClassVar[Mapping[str, str]]
    first_sample: ClassVar[int] = 0
    finite: ClassVar[tuple[str, ...]]
    diverged: ClassVar[str]

    @abstractmethod
    def prepare(
        self, inputs: Mapping[str, np.ndarray], rate: float, substeps: int
    ) -> tuple[Any, Any, Any]:
        """(params, initial state, per-sample inputs), each a pytree of float64 values.

        ``inputs`` holds the rig's per-sample inputs as NumPy arrays of one length; params carry
        everything :meth:`sample` needs beside the state, the time steps included. The
        per-sample inputs are a tuple in the order of ``inputs`` (what :func:`closed_loop`
        replaces a controller's commands into).
        """

    @staticmethod
    @abstractmethod
    def sample(params: Any, state: Any, inputs: Any, substeps: int) -> tuple[Any, dict]:
        """One sampling interval in JAX: the new state, and the outputs logged for the sample."""

    def initial_outputs(self, inputs: Mapping[str, np.ndarray], rate: float) -> Mapping[str, Any]:
        """What a sample would log for the initial state: what :func:`closed_loop`'s controller
        reads before the first sample. A rig that runs in a closed loop implements it."""
        raise NotImplementedError(f"the {self.name} rig does not run in a closed loop")

    @abstractmethod
    def trajectory(
        self,
        t: np.ndarray,
        rate: float,
        inputs: Mapping[str, np.ndarray],
        out: Mapping[str, np.ndarray],
    ) -> Trajectory:
        """The trajectory from the raw outputs (NumPy); raises :class:`SimulationError` where
        the run breaks the rig's physics."""


def _scan(sample: Callable, params, init, inputs, substeps: int):
    def step(state, xs):
        return sample(params, state, xs, substeps)

    _, out = jax.lax.scan(step, init, inputs)
    return out


_scan_jit = jax.jit(_scan, static_argnames=("sample", "substeps"))


def integrate(
    rig: SimulatedRig, inputs: Mapping[str, Any], rate: float, *, substeps: int = 20
) -> Trajectory:
    """Run ``rig`` for its per-sample ``inputs`` (arrays of one length, by the names the rig
    reads; None: the rig's default) at ``rate`` Hz, ``substeps`` steps per sample.

    Raises :class:`SimulationError` if the run leaves finite values or breaks the rig's physics.
    """
    inputs = {k: np.asarray(v) for k, v in inputs.items() if v is not None}
    unknown = sorted(set(inputs) - set(rig.inputs))
    if unknown or rig.inputs[0] not in inputs:
        raise ValueError(
            f"the {rig.name} rig reads the inputs {list(rig.inputs)} (the first required); "
            f"got {sorted(inputs)}"
        )
    with jax.enable_x64(True):
        params, init, xs = rig.prepare(inputs, rate, substeps)
        out = _scan_jit(type(rig).sample, params, init, xs, substeps)
        out = {k: np.asarray(v) for k, v in out.items()}
    t = _sample_times(rig, out, rate, "simulation", rig.diverged)
    return rig.trajectory(t, rate, inputs, out)


def _sample_times(rig: SimulatedRig, out: Mapping[str, np.ndarray], rate: float, run: str,
                  advice: str) -> np.ndarray:  # fmt: skip
    """The samples' times; :class:`SimulationError` at the first sample whose raw outputs left
    finite values."""
    n = len(out[rig.finite[0]])
    t = np.arange(rig.first_sample, n + rig.first_sample) / rate
    bad = ~np.logical_and.reduce([np.isfinite(out[k]) for k in rig.finite])
    if bad.any():
        raise SimulationError(
            f"the {rig.name} {run} left finite values at t = {t[np.argmax(bad)]:.4f} s; {advice}"
        )
    return t


class Controller(Protocol):
    """A discrete-time controller that :func:`closed_loop` runs inside the rig's scan (JAX).

    ``init()`` is its state at t = 0; ``step(state, measured, reference)`` reads the rig's
    outputs of the previous sample (name -> value; at k = 0 the rig's initial outputs as
    ``initial_outputs`` gives them) and sample k's reference (a pytree slice of the references),
    and returns its new state and the commands for sample k (input name -> value).
    """

    def init(self) -> Any: ...

    def step(
        self, state: Any, measured: Mapping[str, Any], reference: Any
    ) -> tuple[Any, Mapping[str, Any]]: ...


@eqx.filter_jit
def _closed_scan(sample: Callable, controller, params, init, inputs, refs, names, out0,
                 substeps: int):  # fmt: skip
    where = {name: i for i, name in enumerate(names)}

    def body(carry, xs):
        state, memory, last = carry
        given, ref = xs
        memory, commands = controller.step(memory, last, ref)
        given = list(given)
        for name, value in commands.items():
            given[where[name]] = jnp.asarray(value, dtype=given[where[name]].dtype)
        state, out = sample(params, state, tuple(given), substeps)
        return (state, memory, out), (out, commands)

    _, (out, commands) = jax.lax.scan(body, (init, controller.init(), out0), (inputs, refs))
    return out, commands


def _traced(leaf: Any) -> Any:
    return jnp.asarray(leaf, dtype=float) if type(leaf) is float else leaf


def closed_loop(
    rig: SimulatedRig,
    controller: Controller,
    references: Any,
    rate: float,
    *,
    initial_inputs: Mapping[str, Any],
    initial_outputs: Mapping[str, Any] | None = None,
    substeps: int = 20,
) -> tuple[Trajectory, dict[str, np.ndarray]]:
    """Run ``rig`` under ``controller`` at ``rate`` Hz: the trajectory and the commands it gave.

    ``initial_inputs`` are per-sample arrays as :func:`integrate` takes them (the first input
    sets the length and the rig's initial state; inputs the controller does not command keep
    these values); ``initial_outputs`` are what the controller reads before the first sample
    (the rig's outputs by name, every one the rig's ``sample`` returns; default: the rig's
    :meth:`~SimulatedRig.initial_outputs`). ``references`` is a
    pytree of NumPy arrays of that length. Compiled once per rig, controller and length: a
    controller's array fields are traced (new gains as arrays do not recompile), its other fields
    are static (equinox's ``filter_jit``).
    """
    inputs = {k: np.asarray(v) for k, v in initial_inputs.items() if v is not None}
    if initial_outputs is None:
        initial_outputs = rig.initial_outputs(inputs, rate)
    with jax.enable_x64(True):
        params, init, xs = rig.prepare(inputs, rate, substeps)
        # the rig's numbers traced, as integrate traces them (filter_jit would compile every
        # Python float in: each new muscle, e.g. a posterior draw, would compile again)
        params = jax.tree.map(_traced, params)
        # float64 only inside the x64 context: a reference made outside it would be float32
        references = jax.tree.map(lambda a: jnp.asarray(np.asarray(a)), references)
        out0 = {k: jnp.asarray(v, dtype=float) for k, v in initial_outputs.items()}
        probe = jax.eval_shape(
            lambda: type(rig).sample(params, init, jax.tree.map(lambda a: a[0], xs), substeps)
        )[1]
        missing = sorted(set(probe) - set(out0))
        if missing:
            raise ValueError(f"initial_outputs lacks the {rig.name} rig's outputs {missing}")
        out0 = {k: jnp.asarray(out0[k], dtype=probe[k].dtype) for k in probe}
        out, commands = _closed_scan(
            type(rig).sample, controller, params, init, xs, references, rig.inputs, out0,
            substeps,
        )  # fmt: skip
        out = {k: np.asarray(v) for k, v in out.items()}
        commands = {k: np.asarray(v) for k, v in commands.items()}
    t = _sample_times(rig, out, rate, "closed loop", f"{rig.diverged}, and the controller's gains")
    driven = {**inputs, **commands}
    return rig.trajectory(t, rate, driven, out), commands
