"""Thesis Chapter 6 reproduced on the simulated ankle: the table (thesis vs hmid) and figures.

Every experiment runs the plant of :mod:`hmid.simulate.rigs.ankle` through
:func:`~hmid.simulate.rig.integrate`, as the thesis ran its rig (open-loop valve commands, the
potentiometer for the angle); no number is read off the parameters.

* **Full force** (thesis: a fibre elongated by pressure, then vented with its relaxation
  blocked, so the peak force is read): every active fibre filled, the foot held where they
  put it (full dorsiflexion), then vented; each fibre's tension and the fibres' ankle torque.
* **Rotational stiffness** for every combination of engaged rear fibres (a fibre is
  disengaged by filling it: elongated more than the others, it goes slack), each test from
  full plantarflexion, 9.1 kg hung at the heel with only gastrocnemius engaged, 18.1 kg
  otherwise: the hung torque over the potentiometer's rotation.
* **Sequential recruitment**: the foot held in full plantarflexion, every fibre filled, the
  solei vented one after another; the step in the rear fibres' force at each.
* **Direction asymmetry**: the same 30 deg travelled each way under on/off valves (all rear
  fibres filled from full plantarflexion, vented from full dorsiflexion), to the 10 deg mark.

What is calibrated to the thesis: the fibre forces (bores from the designed forces, area
factors from the measured ones) and the heel lever (its derived 0.065 m); the end stops are
set. Everything else follows, with the tolerance of its row.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from hmid.simulate.rig import Trajectory, integrate
from hmid.simulate.rigs.ankle import Ankle, statics
from hmid.simulate.rigs.ankle_params import DESIGNED, MEASURED, AnkleParams

RATE = 1000.0  # Hz
SUBSTEPS = 10
BODY_MASS = 62.0  # kg, the thesis's adult
WALKING = 1.5  # N m/kg, level walking's need
LOADS = (9.1, 18.1)  # kg: gastrocnemius only, the others
THESIS_TORQUE = 109.0  # N m
THESIS_STEP = 40.0  # N, one more soleus relaxed

Status = Literal["calibrated", "follows"]


@dataclass(frozen=True)
class Row:
    """One quantity of Ch. 6: the thesis's value (None for a claim without a number), hmid's,
    the band hmid's must fall in, and whether it was calibrated to the thesis or follows."""

    quantity: str
    unit: str
    thesis: float | None
    hmid: float
    low: float
    high: float
    status: Status
    basis: str

    @property
    def within(self) -> bool:
        return bool(self.low <= self.hmid <= self.high)

    @property
    def tolerance(self) -> str:
        if self.thesis is not None and math.isfinite(self.high) and self.thesis > 0:
            rel = max(self.high - self.thesis, self.thesis - self.low) / self.thesis
            return f"±{100 * rel:.3g} %"
        if not math.isfinite(self.high):
            return f">= {self.low:g}"
        return f"[{self.low:g}, {self.high:g}]"


@dataclass(frozen=True)
class Ch6Table:
    """The Ch. 6 table: thesis vs hmid, with tolerances and what is calibrated."""

    rows: tuple[Row, ...]

    @property
    def all_within(self) -> bool:
        return all(row.within for row in self.rows)

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame(
            {
                "quantity": [r.quantity for r in self.rows],
                "unit": [r.unit for r in self.rows],
                "thesis": [r.thesis for r in self.rows],
                "hmid": [r.hmid for r in self.rows],
                "tolerance": [r.tolerance for r in self.rows],
                "within": [r.within for r in self.rows],
                "status": [r.status for r in self.rows],
                "basis": [r.basis for r in self.rows],
            }
        )

    def markdown(self) -> str:
        lines = [
            "| quantity | thesis | hmid | tolerance | within | calibrated / follows |",
            "|---|---|---|---|---|---|",
        ]
        for r in self.rows:
            thesis = "—" if r.thesis is None else f"{r.thesis:.4g} {r.unit}".strip()
            lines.append(
                f"| {r.quantity} | {thesis} | {r.hmid:.4g} {r.unit} | {r.tolerance} | "
                f"{'yes' if r.within else 'NO'} | {r.status}: {r.basis} |"
            )
        return "\n".join(lines)


@dataclass(frozen=True)
class Ch6Result:
    """The table and the experiments behind it."""

    table: Ch6Table
    full_force: pd.DataFrame  # per fibre: designed, simulated force, moment arm
    stiffness: pd.DataFrame  # per combination: engaged fibres, load, rotation, stiffness
    recruitment: Trajectory
    recruitment_steps: tuple[float, ...]  # N, one per soleus vented
    travel: dict[str, Trajectory] = field(default_factory=dict)  # "dorsiflexion"/"plantarflexion"
    travel_time: dict[str, float] = field(default_factory=dict)  # s


def _constant(n: int, commands) -> np.ndarray:
    return np.tile(np.asarray(commands, dtype=float), (n, 1))


def full_force(params: AnkleParams) -> tuple[pd.DataFrame, float]:
    """Every active fibre filled, the foot held where they put it, then vented: each fibre's
    tension after 3 s, and the active fibres' joint torque there (N m)."""
    n, vent = int(4.0 * RATE), int(0.5 * RATE)
    commands = _constant(n, np.ones(params.n_active))
    commands[vent:] = -1.0
    traj = integrate(Ankle(params), {"valves": commands, "held": np.ones(n, bool)}, RATE,
                     substeps=SUBSTEPS)  # fmt: skip
    arms = statics(params, float(traj.theta[-1]), 0.0)["r"]
    force = traj.F[-1]
    active = slice(0, params.n_active)
    frame = pd.DataFrame(
        {
            "fibre": params.fibre_names,
            "designed": [g.designed_force(params.supply) if name != "tibialis" else math.nan
                         for name, g in params.groups.items() for _ in range(g.count)],
            "force": force,
            "arm": arms,
            "angle_deg": math.degrees(float(traj.theta[-1])),
        }
    )  # fmt: skip
    return frame, float(np.sum(force[active] * arms[active]))


def _combinations(params: AnkleParams) -> list[tuple[int, int]]:
    g, s = params.gastrocnemius.count, params.soleus.count
    return [(a, b) for a, b in itertools.product(range(g + 1), range(s + 1)) if a + b > 0]


def stiffness(params: AnkleParams) -> pd.DataFrame:
    """Rotational stiffness for every combination of engaged rear fibres (counts of engaged
    gastrocnemius and soleus): from full plantarflexion, the mass hung at 1.5 s; stiffness is
    the hung torque over the potentiometer's rotation at 6 s."""
    n, hang = int(6.0 * RATE), int(1.5 * RATE)
    g_count = params.gastrocnemius.count
    rows = []
    for gastro, soleus in _combinations(params):
        engaged = np.r_[np.arange(g_count) < gastro, np.arange(params.soleus.count) < soleus]
        command = np.where(engaged, -1.0, 1.0)
        mass = LOADS[0] if soleus == 0 else LOADS[1]
        hung = np.where(np.arange(n) >= hang, mass, 0.0)
        rig = Ankle(params, P0=tuple(np.where(engaged, 0.0, params.supply)),
                    theta0=params.theta_range[1])  # fmt: skip
        traj = integrate(rig, {"valves": _constant(n, command), "hung_mass": hung}, RATE,
                         substeps=SUBSTEPS)  # fmt: skip
        before, after = float(traj.theta_pot[hang - 1]), float(traj.theta_pot[-1])
        hx, hy = params.hook
        lever = -(hx * math.cos(after) + hy * math.sin(after))
        torque = mass * params.g * lever
        rotation = before - after
        rows.append(
            {
                "engaged": f"{gastro} G + {soleus} S",
                "gastrocnemius": gastro,
                "soleus": soleus,
                "mass": mass,
                "start_deg": math.degrees(before),
                "rotation_deg": math.degrees(rotation),
                "torque": torque,
                "stiffness": torque / rotation if rotation > 0 else math.inf,
            }
        )
    return pd.DataFrame(rows)


def ordered(table: pd.DataFrame) -> tuple[int, int]:
    """(pairs in order, pairs): over every pair of combinations where one engages a superset
    of the other's fibres, the larger set must be the stiffer."""
    good = total = 0
    for a, b in itertools.permutations(table.itertuples(), 2):
        if a.gastrocnemius <= b.gastrocnemius and a.soleus <= b.soleus and a.Index != b.Index:
            total += 1
            good += int(a.stiffness < b.stiffness)
    return good, total


def recruitment(params: AnkleParams) -> tuple[Trajectory, tuple[float, ...]]:
    """The foot held in full plantarflexion, every fibre filled, the solei vented at 1, 2, 3 s:
    the steps in the rear fibres' summed force (N), each read 0.9 s after its vent."""
    soleus = params.soleus.count
    n = int((soleus + 1) * RATE)
    commands = _constant(n, np.ones(params.n_active))
    for k in range(soleus):
        commands[int((k + 1) * RATE) :, params.gastrocnemius.count + k] = -1.0
    rig = Ankle(params, P0=(params.supply,) * params.n_active, theta0=params.theta_range[1])
    traj = integrate(rig, {"valves": commands, "held": np.ones(n, bool)}, RATE,
                     substeps=SUBSTEPS)  # fmt: skip
    rear = traj.F[:, : params.n_active].sum(axis=1)
    levels = [rear[int((k + 1) * RATE) - 1] for k in range(soleus)] + [rear[-1]]
    return traj, tuple(float(b - a) for a, b in itertools.pairwise(levels))


def travel(params: AnkleParams, mark_deg: float = 10.0) -> tuple[dict, dict]:
    """The same travel each way under the valves: every rear fibre filled from full
    plantarflexion (the foot dorsiflexes) and vented from full dorsiflexion (it plantarflexes);
    the time to pass ``mark_deg``."""
    n = int(2.0 * RATE)
    lo, hi = params.theta_range
    mark = math.radians(mark_deg)
    runs, times = {}, {}
    for direction, command, P0, start in (
        ("dorsiflexion", 1.0, 0.0, hi),
        ("plantarflexion", -1.0, params.supply, lo),
    ):
        rig = Ankle(params, P0=(P0,) * params.n_active, theta0=start)
        traj = integrate(rig, {"valves": _constant(n, [command] * params.n_active)}, RATE,
                         substeps=SUBSTEPS)  # fmt: skip
        passed = (traj.theta_pot < mark) if command > 0 else (traj.theta_pot > mark)
        runs[direction] = traj
        times[direction] = float(traj.t[np.argmax(passed)]) if passed.any() else math.inf
    return runs, times


def reproduce_ch6(params: AnkleParams | None = None) -> Ch6Result:
    """Run the Ch. 6 experiments on the ankle and compare them with the thesis."""
    params = AnkleParams() if params is None else params
    forces, torque = full_force(params)
    stiff = stiffness(params)
    trace, steps = recruitment(params)
    runs, times = travel(params)
    good, total = ordered(stiff)

    def first(name: str, column: str) -> float:
        return float(forces.loc[forces.fibre == f"{name} 1", column].iloc[0])

    rows = []
    for name in ("gastrocnemius", "soleus"):
        designed, measured = DESIGNED[name], MEASURED[name]
        rows.append(Row(f"{name} designed force", "N", designed, first(name, "designed"),
                        designed * 0.995, designed * 1.005, "calibrated",
                        "bore sized for it at the 600 kPa supply"))  # fmt: skip
        rows.append(Row(f"{name} full force", "N", measured, first(name, "force"),
                        measured * 0.99, measured * 1.01, "calibrated",
                        "area factor set to it; simulated vent, joint held"))  # fmt: skip
    rear = float(forces.force[: params.n_active].sum())
    thesis_sum = 2 * MEASURED["gastrocnemius"] + 3 * MEASURED["soleus"]
    per_kg = torque / BODY_MASS
    rows += [
        Row("rear fibres at full force", "N", thesis_sum, rear, thesis_sum * 0.99,
            thesis_sum * 1.01, "follows", "sum of the calibrated fibres"),
        Row("ankle torque at full force", "N m", THESIS_TORQUE, torque, THESIS_TORQUE * 0.95,
            THESIS_TORQUE * 1.05, "follows",
            f"fibres x moment arms at {forces.angle_deg[0]:.0f} deg; heel lever set to the "
            "thesis-derived ~0.065 m"),
        Row("torque per body mass (62 kg)", "N m/kg", THESIS_TORQUE / BODY_MASS, per_kg,
            THESIS_TORQUE / BODY_MASS * 0.95, THESIS_TORQUE / BODY_MASS * 1.05, "follows",
            "the torque / 62 kg"),
        Row("margin over level walking (1.5 N m/kg)", "N m/kg", None, per_kg, WALKING,
            math.inf, "follows", "must exceed 1.5"),
        Row("dorsiflexion reached, all rear fibres filled", "deg", 20.0,
            -math.degrees(float(runs["dorsiflexion"].theta[-1])), 19.5, 20.5, "calibrated",
            "end stop set; that the fibres reach it follows from the mounting"),
        Row("plantarflexion reached, all rear fibres vented", "deg", 40.0,
            math.degrees(float(runs["plantarflexion"].theta[-1])), 39.5, 40.5, "calibrated",
            "end stop set; that the fibres reach it follows from the mounting"),
        Row("stiffness ordering (superset stiffer)", "of pairs", None, good / total, 1.0, 1.0,
            "follows", f"{total} pairs of the {len(stiff)} combinations; 9.1 / 18.1 kg hung"),
        Row("one more soleus relaxed", "N", THESIS_STEP, float(np.mean(steps)),
            THESIS_STEP * 0.75, THESIS_STEP * 1.25, "follows",
            "mean step, foot held in full plantarflexion; fibre stiffness from the build "
            "(2 mm latex wall, 0.12 m core) and the mounting"),
        Row("travel time ratio, slower / faster direction", "", None,
            max(times.values()) / min(times.values()), 1.1, math.inf, "follows",
            "30 deg each way under the on/off valves "
            f"(dorsiflexion {times['dorsiflexion']:.3f} s, "
            f"plantarflexion {times['plantarflexion']:.3f} s)"),
    ]  # fmt: skip
    return Ch6Result(Ch6Table(tuple(rows)), forces, stiff, trace, steps, runs, times)


def plot_ch6(result: Ch6Result, folder: str | Path) -> list[Path]:
    """The Ch. 6 figures as PNGs in ``folder``: full forces, stiffness per combination,
    sequential recruitment, travel by direction."""
    from hmid.plots import new_figure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []

    fig = new_figure(figsize=(6.5, 3.5))
    ax = fig.add_subplot()
    names = ["gastrocnemius", "soleus"]
    x = np.arange(len(names))
    sim = [result.full_force.force[result.full_force.fibre == f"{n} 1"].iloc[0] for n in names]
    ax.bar(x - 0.27, [DESIGNED[n] for n in names], 0.27, label="thesis, designed")
    ax.bar(x, [MEASURED[n] for n in names], 0.27, label="thesis, measured")
    ax.bar(x + 0.27, sim, 0.27, label="hmid, simulated")
    ax.set_xticks(x, names)
    ax.set_ylabel("full force (N)")
    ax.set_title("Full-force test per fibre")
    ax.legend(fontsize=8)
    paths.append(_save(fig, folder / "ch6-full-force.png"))

    fig = new_figure(figsize=(7.5, 3.8))
    ax = fig.add_subplot()
    table = result.stiffness.sort_values("stiffness")
    colors = ["tab:orange" if m == LOADS[0] else "tab:blue" for m in table.mass]
    ax.bar(table.engaged, table.stiffness * math.pi / 180, color=colors)
    ax.set_yscale("log")
    ax.set_ylabel("stiffness (N m/deg, log)")
    ax.set_title("Rotational stiffness per engaged rear fibres (orange 9.1 kg, blue 18.1 kg)")
    ax.tick_params(axis="x", labelrotation=45, labelsize=8)
    paths.append(_save(fig, folder / "ch6-stiffness.png"))

    fig = new_figure(figsize=(6.5, 3.5))
    ax = fig.add_subplot()
    trace = result.recruitment
    ax.plot(trace.t, trace.F[:, : trace.P.shape[1]].sum(axis=1))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("rear fibres' force (N)")
    steps = ", ".join(f"{s:.0f}" for s in result.recruitment_steps)
    ax.set_title(f"Sequential recruitment, foot held: steps {steps} N (thesis ~40 N)")
    paths.append(_save(fig, folder / "ch6-recruitment.png"))

    fig = new_figure(figsize=(6.5, 3.5))
    ax = fig.add_subplot()
    for direction, traj in result.travel.items():
        ax.plot(traj.t, np.degrees(traj.theta_pot),
                label=f"{direction}: {result.travel_time[direction]:.3f} s")  # fmt: skip
    ax.axhline(10.0, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("angle (deg, + plantarflexion)")
    ax.set_title("30 deg each way under on/off valves")
    ax.legend(fontsize=8)
    paths.append(_save(fig, folder / "ch6-travel.png"))
    return paths


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def write_ch6(folder: str | Path, params: AnkleParams | None = None) -> Ch6Result:
    """Reproduce Ch. 6 and write ``ch6.md`` (the table), ``ch6.csv``, ``ch6-stiffness.csv``
    and the figures into ``folder``."""
    result = reproduce_ch6(params)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "ch6.md").write_text(result.table.markdown() + "\n", encoding="utf-8")
    result.table.frame().to_csv(folder / "ch6.csv", index=False)
    result.stiffness.to_csv(folder / "ch6-stiffness.csv", index=False)
    plot_ch6(result, folder)
    return result
