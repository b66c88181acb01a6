"""The Ch. 4 rig without friction, linearised about a step: the plant the control tests tune on
(the PD's and the PID's rules read the same linearisation)."""

from hmid.control import ForceLaw, MuscleRig, reference
from hmid.simulate.params import FrictionParams, RigParams

FRICTIONLESS = RigParams(friction=FrictionParams(F_block=0.0, F_pulley=0.0))


def linearised(task: str, t, low: float, high: float, step_at: float, transition: float):
    """(law, plant, reference, the plant linearised about that step) for ``task``."""
    law = ForceLaw.of_rig(FRICTIONLESS)
    plant = MuscleRig(FRICTIONLESS, task, sensor_step=0.0)  # type: ignore[arg-type]
    ref = reference("step_up", t, low, high, step_at=step_at, transition=transition)
    return law, plant, ref, plant.linear(law, ref, 0.03)
