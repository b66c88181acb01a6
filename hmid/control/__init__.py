"""Model-based control in simulation: what an identified model is worth where it matters.

The thesis identifies the Hydro Muscle in order to control it (§1.3-1.4, Fig. 1.3): feed-forward
from the model's inverse dynamics plus feedback. This package runs that on the simulator's rigs:

* :mod:`~hmid.control.controllers`: the PD set-point tracker, feed-forward + the same PD, and
  that plus integral action (a PID with anti-windup); :mod:`~hmid.control.observer`: or plus a
  disturbance observer (the model's inverse estimates what the model misses);
* :mod:`~hmid.control.inverse`: a loaded model solved for the pressure a motion or force needs;
* :mod:`~hmid.control.actuation`: a pressure command on proportional or on/off valves;
* :mod:`~hmid.control.tuning`: the PD's tuning rule on the linearised plant (python-control);
  :mod:`~hmid.control.integral`: the PID's (the largest integral gain with the same margins);
* :mod:`~hmid.control.plant`: the seam to a rig (the Ch. 4 rig's adaptor);
  :mod:`~hmid.control.ankle`: the Ch. 6 ankle's (recruitment, the joint's balance inverted);
* :mod:`~hmid.control.references`, :mod:`~hmid.control.experiments`,
  :mod:`~hmid.control.metrics`, :mod:`~hmid.control.robustness`: the tasks, one run, its
  scores, the perturbed plants;
* :mod:`~hmid.control.study` and :mod:`~hmid.control.config`: ``hmid control CONFIG``.

Importing this package imports nothing heavy; the names load on first access.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from hmid._lazy import lazy_exports

if TYPE_CHECKING:
    from hmid.control.actuation import PWM, Proportional, Switching, switchings
    from hmid.control.ankle import AnkleRig, FibreLaws, recruit
    from hmid.control.config import ControlConfig, load_control_config
    from hmid.control.controllers import PD, PID, Tracker
    from hmid.control.experiments import Tracking, feedforward, track
    from hmid.control.integral import tune_pid
    from hmid.control.inverse import ForceLaw, NotInvertible
    from hmid.control.metrics import Metrics
    from hmid.control.observer import DOB, tune_dob
    from hmid.control.plant import MuscleRig, Plant
    from hmid.control.references import Reference, reference
    from hmid.control.study import Study, run_study
    from hmid.control.tuning import Tuning, TuningError, tune

_LAZY = {
    "PWM": "hmid.control.actuation",
    "Proportional": "hmid.control.actuation",
    "Switching": "hmid.control.actuation",
    "switchings": "hmid.control.actuation",
    "AnkleRig": "hmid.control.ankle",
    "FibreLaws": "hmid.control.ankle",
    "recruit": "hmid.control.ankle",
    "ControlConfig": "hmid.control.config",
    "load_control_config": "hmid.control.config",
    "PD": "hmid.control.controllers",
    "PID": "hmid.control.controllers",
    "Tracker": "hmid.control.controllers",
    "Tracking": "hmid.control.experiments",
    "feedforward": "hmid.control.experiments",
    "track": "hmid.control.experiments",
    "tune_pid": "hmid.control.integral",
    "ForceLaw": "hmid.control.inverse",
    "NotInvertible": "hmid.control.inverse",
    "Metrics": "hmid.control.metrics",
    "DOB": "hmid.control.observer",
    "tune_dob": "hmid.control.observer",
    "MuscleRig": "hmid.control.plant",
    "Plant": "hmid.control.plant",
    "Reference": "hmid.control.references",
    "reference": "hmid.control.references",
    "Study": "hmid.control.study",
    "run_study": "hmid.control.study",
    "Tuning": "hmid.control.tuning",
    "TuningError": "hmid.control.tuning",
    "tune": "hmid.control.tuning",
}
__all__ = [
    "DOB",
    "PD",
    "PID",
    "PWM",
    "AnkleRig",
    "ControlConfig",
    "FibreLaws",
    "ForceLaw",
    "Metrics",
    "MuscleRig",
    "NotInvertible",
    "Plant",
    "Proportional",
    "Reference",
    "Study",
    "Switching",
    "Tracker",
    "Tracking",
    "Tuning",
    "TuningError",
    "feedforward",
    "load_control_config",
    "recruit",
    "reference",
    "run_study",
    "switchings",
    "track",
    "tune",
    "tune_dob",
    "tune_pid",
]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
