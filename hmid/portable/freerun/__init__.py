"""Free run of a loaded model: the position simulated from the measured inputs and the initial
state alone, as a controller uses the model (MATLAB's ``compare`` in simulation mode).

One concept per module: :mod:`.equation` reads the balance as an equation of motion (and
regularises stick-slip); :mod:`.program` turns it into arrays and a JAX vector field that one
compiled program runs for every model of a shape; :mod:`.integrator` compiles diffrax's Tsit5
(error-controlled for a run, fixed steps for the band's draws); :mod:`.band` draws the
coefficients and a disturbance and calibrates the disturbance's scale on training blocks;
:mod:`.scores` scores a run against the measured motion; :mod:`.run` ties them over a log's
blocks.
"""

from hmid.portable.freerun.band import Calibration, calibrate, coefficient_draws, disturbances
from hmid.portable.freerun.equation import Equation, NotSimulable, equation
from hmid.portable.freerun.integrator import FreeTrajectory, Simulator, simulator
from hmid.portable.freerun.run import (
    FreeRunRows,
    block_spans,
    blocks,
    calibration_pieces,
    chunks,
    free_run,
    held_rows,
    simulate_signals,
    within_budget,
)
from hmid.portable.freerun.scores import COVERAGE_INTERVAL, BlockRun, FreeRun, coverage_interval

__all__ = [
    "COVERAGE_INTERVAL",
    "BlockRun",
    "Calibration",
    "Equation",
    "FreeRun",
    "FreeRunRows",
    "FreeTrajectory",
    "NotSimulable",
    "Simulator",
    "block_spans",
    "blocks",
    "calibrate",
    "calibration_pieces",
    "chunks",
    "coefficient_draws",
    "coverage_interval",
    "disturbances",
    "equation",
    "free_run",
    "held_rows",
    "simulate_signals",
    "simulator",
    "within_budget",
]
