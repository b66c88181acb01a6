"""The control study's report: its tables, figures and sections (``hmid control``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hmid.control.config import ControlConfig
from hmid.control.study import ControllerKind, Study, TaskResult
from hmid.report import Figure, Report, Section, Table

REDUCTION, ROBUST = 0.5, 1.5  # the targets: FF+PD at most half PD's RMSE; 1.5x spread
DIRECTIONS = ("step_up", "step_down")


def _tuning_row(task: TaskResult, tn, controller: str, valves: str) -> dict:
    return {"task": task.task, "controller": controller, "valves": valves,
            "kp (Pa/unit)": tn.kp, "ki (Pa/unit/s)": tn.ki, "kd (Pa s/unit)": tn.kd,
            "tf (s)": tn.tf, "crossover (Hz)": tn.crossover_hz,
            "gain margin (dB)": tn.gain_margin_db, "phase margin (deg)": tn.phase_margin_deg,
            "control.margin gain margin (dB)": tn.control_gain_margin_db,
            "control.margin phase margin (deg)": tn.control_phase_margin_deg,
            "slowest pole (s)": tn.slowest_pole_s, "stable": tn.stable}  # fmt: skip


def tables(study: Study) -> dict[str, pd.DataFrame]:
    """The study's tables by file name."""
    tuning, tracking, targets, robust = [], [], [], []
    for task in study.tasks:
        tuning.append(_tuning_row(task, task.tuning, "PD, FF+PD", "all"))
        tuning += [_tuning_row(task, tn, "FF+PID", v) for v, tn in task.integral.items()]
        tuning += [_tuning_row(task, tn, "FF+DOB", v)
                   | {"observer bandwidth (Hz)": tn.observer.bandwidth_hz}
                   for v, tn in task.observers.items()]  # fmt: skip
        for (kind, valves, controller), run in task.runs.items():
            m = run.metrics
            tracking.append({"task": task.task, "reference": kind, "valves": valves,
                             "controller": controller, "rmse": m.rmse,
                             "max error": m.max_error, "unit": task.unit,
                             "settling (s)": m.settling_s, "travel 90 % (s)": m.travel_s,
                             "switchings": m.switchings})  # fmt: skip
        kinds = sorted({k for k, _, _ in task.runs}, key=list(task.spreads).index)
        for kind in kinds:
            for valves in study.valves:
                pd_, ff = (task.runs[(kind, valves, c)].metrics.rmse for c in ("PD", "FF+PD"))
                cut = task.reduction(kind, valves)
                targets.append({"task": task.task, "reference": kind, "valves": valves,
                                "PD rmse": pd_,
                                "FF+PD rmse": ff, "unit": task.unit, "reduction": cut,
                                "met (>= 50 %)": bool(cut >= REDUCTION)})  # fmt: skip
            for spread in task.spreads[kind]:
                worst = float(np.max(spread.rmse))
                robust.append({"task": task.task, "reference": kind, "valves": spread.valves,
                               "controller": spread.controller, "plant": spread.case,
                               "nominal rmse": spread.nominal_rmse, "worst rmse": worst,
                               "unit": task.unit,
                               "worst rmse / sensor step": worst / task.resolution,
                               "median ratio": spread.median, "worst ratio": spread.worst,
                               "met (<= 1.5x)": bool(spread.worst <= ROBUST)})  # fmt: skip
    return {"tuning": pd.DataFrame(tuning), "tracking": pd.DataFrame(tracking),
            "targets": pd.DataFrame(targets), "robustness": pd.DataFrame(robust),
            "directions": directions(study)}  # fmt: skip


def directions(study: Study) -> pd.DataFrame:
    """Tracking by direction: per task, valves and controller, the travel time (to 90 % of the
    output's own travel: :func:`~hmid.control.metrics.travel_time`) and the settling time of
    step_up and of step_down, and the slower over the faster
    (thesis Ch. 6: the valves open and close at different speeds). Empty without both steps."""
    rows = []
    for task in study.tasks:
        controllers = list(dict.fromkeys(c for _, _, c in task.runs))
        for valves in study.valves:
            for controller in controllers:
                up, down = (task.runs.get((k, valves, controller)) for k in DIRECTIONS)
                if up is None or down is None:
                    continue
                times = (up.metrics.travel_s, down.metrics.travel_s)
                rows.append({"task": task.task, "valves": valves, "controller": controller,
                             "up: travel (s)": times[0], "down: travel (s)": times[1],
                             "slower / faster": max(times) / min(times),
                             "up: settling (s)": up.metrics.settling_s,
                             "down: settling (s)": down.metrics.settling_s,
                             "up: rmse": up.metrics.rmse, "down: rmse": down.metrics.rmse,
                             "unit": task.unit})  # fmt: skip
    return pd.DataFrame(rows)


def _seconds(value: float) -> str:
    return "never" if value == np.inf else ("—" if not np.isfinite(value) else f"{value:.3f} s")


def directions_markdown(frame: pd.DataFrame, task: str) -> str:
    """The tracking-by-direction table of ``task`` as Markdown (what the README shows, written
    by the run as ``tables/directions.md``): travel and settling times up and down per valves
    and controller. On the ankle up is a plantarflexion, down a dorsiflexion."""
    rows = frame[frame["task"] == task] if len(frame) else frame
    if not len(rows):
        return ""
    up, down = ("plantarflexion", "dorsiflexion") if task == "angle" else ("up", "down")
    lines = [
        f"| valves | controller | travel, {up} | travel, {down} | slower / faster | "
        f"settling, {up} | settling, {down} |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows.to_dict(orient="records"):
        values = [r[k] for k in ("up: travel (s)", "down: travel (s)")]
        settle = [r[k] for k in ("up: settling (s)", "down: settling (s)")]
        ratio = max(values) / min(values) if np.all(np.isfinite(values)) else float("nan")
        lines.append(
            f"| {r['valves']} | {r['controller']} | {_seconds(values[0])} | "
            f"{_seconds(values[1])} | {'—' if not np.isfinite(ratio) else f'{ratio:.2f}'} | "
            f"{_seconds(settle[0])} | {_seconds(settle[1])} |"
        )
    return "\n".join(lines) + "\n"


def robustness_markdown(frame: pd.DataFrame) -> str:
    """The robustness table in brief as Markdown (written by the run as
    ``tables/robustness.md``; docs/control.md shows it): per task, valves and controller, each
    perturbed plant's worst ratio to the nominal RMSE over the references, and that worst RMSE
    in sensor steps."""
    if not len(frame):
        return ""
    cases = list(dict.fromkeys(frame["plant"]))
    lines = [
        "| task | valves | controller | " + " | ".join(cases) + " |",
        "|---|---|---|" + "---|" * len(cases),
    ]
    keys = dict.fromkeys(zip(frame["task"], frame["valves"], frame["controller"], strict=True))
    for task, valves, controller in keys:
        rows = frame[(frame["task"] == task) & (frame["valves"] == valves)
                     & (frame["controller"] == controller)]  # fmt: skip
        cells = []
        for case in cases:
            of = rows[rows["plant"] == case]
            worst = of.loc[of["worst ratio"].idxmax()]
            cells.append(f"{worst['worst ratio']:.2f}× ({worst['worst rmse / sensor step']:.2g})")
        lines.append(f"| {task} | {valves} | {controller} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def ripple(task: TaskResult, valves: str) -> float:
    """RMS of the pressure about the model's demand (the feed-forward) over the FF+PD runs on
    ``valves`` (Pa): what the valves add to the force the model asked for."""
    runs = [r for (_, v, c), r in task.runs.items() if v == valves and c == "FF+PD"]
    gap = np.concatenate([r.pressure - r.demand for r in runs])
    return float(np.sqrt(np.mean(gap**2)))


def figures(study: Study, run_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for task in study.tasks:
        for valves in study.valves:
            kinds = list(task.spreads)
            fig, axes = plt.subplots(len(kinds), 1, figsize=(7, 1.9 * len(kinds)), sharex=True,
                                     squeeze=False)  # fmt: skip
            scale, unit = _display(task.unit)
            for ax, kind in zip(axes[:, 0], kinds, strict=True):
                ref = task.runs[(kind, valves, "PD")].reference
                ax.plot(ref.t, ref.y * scale, "k--", lw=1, label="reference")
                colours: tuple[tuple[ControllerKind, str], ...] = (
                    ("PD", "tab:orange"), ("FF+PD", "tab:blue"),
                )  # fmt: skip
                for controller, colour in colours:
                    r = task.runs[(kind, valves, controller)]
                    ax.plot(r.t, r.output * scale, color=colour, lw=1, label=controller)
                ax.set_ylabel(f"{kind}\n{task.task} ({unit})")
            axes[0, 0].legend(loc="upper right", fontsize=7, ncol=3)
            axes[-1, 0].set_xlabel("t (s)")
            fig.tight_layout()
            name = "proportional" if valves == "proportional" else "on_off"
            fig.savefig(_figure_dir(run_dir) / f"{task.task}_{name}.png", dpi=90)
            plt.close(fig)


def _display(unit: str) -> tuple[float, str]:
    """(scale, unit) a tracked unit is plotted and said in: mm for m, deg for rad."""
    return {"m": (1e3, "mm"), "rad": (180 / np.pi, "deg")}.get(unit, (1.0, unit))


def _resolutions(study: Study) -> str:
    said = []
    for task in study.tasks:
        scale, unit = _display(task.unit)
        said.append(f"{task.task} {task.resolution * scale:.3g} {unit}")
    return "Sensor resolution: " + ", ".join(said) + "."


def _directions(study: Study) -> str:
    """The ankle's steps by direction, in words."""
    if not any(task.task == "angle" for task in study.tasks):
        return ""
    return (
        " On the ankle step_up is a plantarflexion (the engaged fibres vented) and "
        "step_down a dorsiflexion (filled); the on/off valves open "
        "and close at different speeds, so the two directions differ (thesis Ch. 6)."
    )


def _scored(config: ControlConfig) -> str:
    """What a run scores, where the config holds the start first (nothing otherwise)."""
    if config.hold == 0:
        return ""
    return (
        f"Every run first holds the reference's start for {config.hold:g} s, the loop engaged "
        "(a pre-roll, the same for every controller, valve and plant); the RMSE is of the "
        f"{config.duration:g} s that follow. "
    )


def _figure_dir(run_dir: Path) -> Path:
    (run_dir / "figures").mkdir(parents=True, exist_ok=True)
    return run_dir / "figures"


def _observer_rule(study: Study) -> str:
    """FF+DOB's rule, where the study ran it (nothing otherwise: the text stays as it was)."""
    if not any(task.observers for task in study.tasks):
        return ""
    return (
        " FF+DOB (hmid/control/observer.py): the same PD and a disturbance observer, the "
        "model's linearised inverse low-passed by Q = 1/(s/w + 1)^n; the widest w whose loop "
        "keeps the asked margins (or costs the PD's own gain margin, by the closed loop's "
        "eigenvalues, at most 0.5 dB where the PD has less), per valve kind."
    )


def report(
    study: Study, config: ControlConfig, run_dir: Path, metrics: dict, provenance: dict
) -> Report:
    frames = tables(study)
    targets = metrics["targets"]
    sections = [
        _tuning_section(study, config, frames["tuning"]),
        Section(
            "PD alone vs model-based feed-forward + PD (same gains)",
            (
                "RMSE of the logged output against the reference; reduction = 1 - FF+PD / PD "
                f"(target >= 50 %). {_scored(config)}{_resolutions(study)}{_directions(study)}"
            ),
            tables=(
                Table(frames["targets"], "Tracking RMSE per task"),
                Table(frames["tracking"], "Every run", collapsed=True),
            ),
            figures=tuple(
                Figure(p, p.stem.replace("_", ", "))
                for p in sorted((run_dir / "figures").glob("*.png"))
            ),
        ),
        Section(
            "Robustness",
            (
                "The nominal model's controllers (FF+PD; FF+PID where asked) on plants they were "
                "not designed for, on every valve kind: muscles drawn from the model's "
                "posterior, and undeclared effects switched on (each alone). Target: RMSE <= "
                "1.5x the nominal plant's (same controller, same valves). Where the nominal "
                "RMSE is a fraction of the sensor's step the ratio runs large on errors the "
                "sensor cannot see: the worst RMSE in sensor steps stands beside it."
            ),
            tables=(Table(frames["robustness"], "RMSE ratio to the nominal plant"),),
        ),
    ]
    if len(frames["directions"]):
        sections.insert(2, _directions_section(study, frames["directions"]))
    if len(study.valves) > 1:
        sections.insert(2, _on_off_section(study, config))
    return Report(
        f"Control study: {config.name}",
        sections=tuple(sections),
        lead=_lead(study.model, targets),
        summary=(("model", study.model), ("valves", ", ".join(study.valves))),
        provenance=provenance,
    )


def _tuning_section(study: Study, config: ControlConfig, table) -> Section:
    """The PD's tuning rule, the PID's and the observer's where asked, and the gains."""
    return Section(
        "PD tuning",
        (
            "The rule (hmid/control/tuning.py): the stiffest PD whose sampled loop on the "
            "model's linearisation (valve lag included, friction left out) is stable with at "
            f"least {config.controller.gain_margin_db} dB gain and "
            f"{config.controller.phase_margin_deg} deg phase margin, the gain margin by the "
            "closed loop's eigenvalues (the smallest gain that moves a pole out of the unit "
            "circle; python-control's control.margin, beside it, misses a lightly damped "
            "resonance's peak and loses digits to polynomial roots), the phase margin on a "
            f"dense frequency grid; poles by python-control. {_resonances(study)} FF+PID "
            "(hmid/control/integral.py), where asked: the largest integral gain with the "
            "same margins (MIGO, by control.margin), per valve kind, the on/off loop "
            "behind the valves' switching delay (opening + closing)." + _observer_rule(study)
        ),
        tables=(
            Table(
                table,
                "Gains and margins (the closed loop's eigenvalues; "
                "python-control's control.margin beside them)",
            ),
        ),
    )


def _directions_section(study: Study, table) -> Section:
    """The steps each way, travel and settling times (the thesis's direction asymmetry)."""
    return Section(
        "Tracking by direction",
        ("The steps each way: travel time from the reference's first move to 90 % of the "
         "output's own travel (where it ends: PD alone stops short of the target), and "
         "settling time (2 % band, or two sensor steps)." + _directions(study)),
        tables=(Table(table, "Travel and settling by direction"),),
    )  # fmt: skip


def _lead(model: str, targets: dict) -> str:
    """The report's first lines: each target, met or not."""
    said = {True: "met", False: "not met", None: "n/a"}
    lead = (
        f"Model {model}: feed-forward + PD lowers PD alone's RMSE by >= 50 % on every "
        f"task with proportional valves: {said[targets['reduction_met_proportional']]}; with "
        f"on/off valves: {said[targets['reduction_met_on_off']]}; robustness (<= 1.5x): "
        f"{said[targets['robustness_met']]}."
    )
    if targets.get("robustness_met_by"):
        lead += (
            " Robustness by controller and valves: "
            + "; ".join(
                f"{name}: {said[met]}" for name, met in targets["robustness_met_by"].items()
            )
            + "."
        )
    return lead


def _resonances(study: Study) -> str:
    """The plants' least-damped modes as python-control finds them, in words."""
    said = [
        f"on the {t.task} task the linearised plant's least-damped mode is "
        f"{t.tuning.resonance_hz:.3g} Hz with damping ratio {t.tuning.resonance_damping:.2g}"
        for t in study.tasks
        if np.isfinite(t.tuning.resonance_hz)
    ]
    if not said:
        return "The linearised plants have no oscillatory mode."
    return (
        _sentence("; ".join(said)) + ". A lightly damped mode behind the valve's lag limits "
        "how stiff a PD can be with these margins: the loop must cross over below it, and the "
        "model's feed-forward does the tracking there."
    )


def _sentence(text: str) -> str:
    """``text`` with a capital first letter (str.capitalize would lower "Hz")."""
    return text[:1].upper() + text[1:]


def _on_off_section(study: Study, config: ControlConfig) -> Section:
    """Why on/off valves miss where they do: the pressure's ripple about the model's demand."""
    rows = []
    for task in study.tasks:
        on_off = [r for (_, v, c), r in task.runs.items() if v == study.valves[1]
                  and c == "FF+PD"]  # fmt: skip
        seconds = sum(float(r.t[-1] - r.t[0]) for r in on_off)
        rmse = {
            v: float(
                np.mean(
                    [
                        r.metrics.rmse
                        for (_, w, c), r in task.runs.items()
                        if w == v and c == "FF+PD"
                    ]
                )
            )
            for v in study.valves
        }
        ripples = {v: ripple(task, v) for v in study.valves}
        rows.append({"task": task.task, "unit": task.unit,
                     "FF+PD rmse, proportional": rmse["proportional"],
                     "FF+PD rmse, on/off": rmse[study.valves[1]],
                     "P about the demand, proportional (Pa rms)": ripples["proportional"],
                     "P about the demand, on/off (Pa rms)": ripples[study.valves[1]],
                     "on/off ripple x static gain": ripples[study.valves[1]] * abs(task.gain),
                     "switchings per s": sum(r.metrics.switchings or 0 for r in on_off)
                     / seconds})  # fmt: skip
    return Section("Why on/off valves miss", (
        "A solenoid valve is open or shut and takes "
        f"{config.on_off.valves.opening_time * 1e3:.0f} ms to open and "
        f"{config.on_off.valves.closing_time * 1e3:.0f} ms to close (config.on_off), so the "
        "pressure overshoots at every switching and cycles about the pressure the model "
        "demands. That ripple, through the plant's static gain, is an error no "
        "feed-forward removes: where it is larger than PD alone's error, the model's "
        "feed-forward has nothing left to win, and the target is met with proportional "
        "valves (thesis §8)."
    ) if config.on_off else "", tables=(Table(pd.DataFrame(rows), "Pressure ripple on "
                                              "on/off valves"),))  # fmt: skip
