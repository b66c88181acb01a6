"""Draw docs/figures/sign-conventions.png: which way x, v, the explained quantity and each term
of the balance count on the shipped rigs. Run: `python docs/figures/sign_conventions.py`.

Every arrow is a force on the moving body, drawn the way it acts when its parameter and its
regressor are positive. The balance is written ``explained = sum of sign x parameter x
regressor``: a term with sign +1 is a force the explained quantity must supply (it counts
*against* the direction the explained force pushes), a term with sign -1 one that helps it.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import Circle, FancyArrowPatch, Rectangle

BLUE, RED, GREEN, GREY = "#1f5fa8", "#b2302a", "#2a7d3a", "#555555"


def arrow(ax, x0, y, dx, color, label, above=True, size=9):
    ax.add_patch(FancyArrowPatch((x0, y), (x0 + dx, y), arrowstyle="-|>", mutation_scale=14,
                                 lw=2, color=color))  # fmt: skip
    ax.text(x0 + dx / 2, y + (0.05 if above else -0.05), label, color=color, size=size,
            ha="center", va="bottom" if above else "top")  # fmt: skip


def spring(ax, x0, x1, y, turns=7, amp=0.03, color=GREY, lw=1.5):
    xs = [x0 + (x1 - x0) * k / (2 * turns) for k in range(2 * turns + 1)]
    ys = [y + (amp if k % 2 else -amp) * (0 < k < 2 * turns) for k in range(2 * turns + 1)]
    ax.plot(xs, ys, color=color, lw=lw)


def axis(ax, x0, y, label="+x"):
    arrow(ax, x0, y, 0.12, "black", "")
    ax.text(x0 + 0.15, y, f"{label};  v = dx/dt, a = dv/dt count the same way", size=8.5,
            va="center")  # fmt: skip


def wall(ax, x, y0, y1):
    ax.plot([x, x], [y0, y1], color="black", lw=2)
    for k in range(6):
        yy = y0 + (y1 - y0) * k / 5
        ax.plot([x - 0.03, x], [yy - 0.03, yy], color="black", lw=1)


def block(ax, x, y, w, h, text):
    ax.add_patch(Rectangle((x, y), w, h, fc="#dde6f0", ec="black", lw=1.2))
    ax.text(x + w / 2, y + h / 2, text, ha="center", va="center", size=9)


def legend(ax, lines, y=0.34):
    for k, (text, color) in enumerate(lines):
        ax.text(0.0, y - 0.062 * k, text, color=color, size=8.3, va="top", family="monospace")


def hydro_muscle(ax):
    ax.set_title("Hydro Muscle, thesis Ch. 4 rig (configs/demo.yaml)", size=10)
    ax.plot([0.05, 0.95], [0.6, 0.6], color=GREY, lw=3)  # rail
    wall(ax, 0.18, 0.62, 0.86)
    ax.add_patch(Circle((0.08, 0.66), 0.035, fc="white", ec="black"))  # pulley
    ax.plot([0.08, 0.08], [0.66, 0.5], color="black", lw=1)
    block(ax, 0.035, 0.42, 0.09, 0.08, "m1")
    ax.plot([0.08, 0.55], [0.695, 0.695], color="black", lw=1)  # string, under the muscle
    ax.add_patch(Rectangle((0.18, 0.72), 0.37, 0.07, fc="#f3d9b1", ec="black"))  # muscle
    ax.text(0.365, 0.755, "muscle (P)", ha="center", va="center", size=8.5)
    block(ax, 0.55, 0.62, 0.14, 0.2, "M")
    arrow(ax, 0.70, 0.79, 0.2, BLUE, "F_m")
    arrow(ax, 0.70, 0.66, 0.2, "black", "v > 0")
    arrow(ax, 0.55, 0.53, -0.2, GREY, "m1 g (string, pulley)", above=False)
    arrow(ax, 0.89, 0.53, -0.19, RED, "Fc sign(v)", above=False)
    axis(ax, 0.05, 0.97, "+x: elongation")
    legend(ax, [
        ("explained  F = (M + m1) a + m1 g   (load cell)", "black"),
        ("         = F_m  - Fc sign(v)", "black"),
        ("F_m  {kind: model}            sign +1", BLUE),
        ("  = A_eff P + F0 - k1 x - k3 x^3 - q", BLUE),
        ("Fc   {kind: coulomb} sign -1: friction", RED),
        ("     opposes v, so it lowers F", RED),
        ("knee rig (configs/knee.yaml): the same, F", GREY),
        ("from (M + m1) a + m1 g without a load cell", GREY),
    ])  # fmt: skip


def linear_motor(ax):
    ax.set_title("Linear-motor stage (configs/linear-motor.yaml)", size=10)
    ax.plot([0.05, 0.95], [0.6, 0.6], color=GREY, lw=3)  # guide
    block(ax, 0.38, 0.62, 0.2, 0.2, "carriage M\n(motor)")
    arrow(ax, 0.59, 0.78, 0.2, BLUE, "u (drive)")
    arrow(ax, 0.59, 0.66, 0.2, "black", "v > 0")
    arrow(ax, 0.37, 0.74, -0.25, RED, "Fv v + Fc sign(v)")
    arrow(ax, 0.37, 0.53, -0.25, GREEN, "offset > 0 (cable, tilt)", above=False)
    axis(ax, 0.05, 0.97, "+x: encoder")
    legend(ax, [
        ("explained  u = motor force, > 0 pushes +x", "black"),
        ("u = M a + Fv v + Fc sign(v) + offset", "black"),
        ("M    {kind: channel, channel: a}  +1", BLUE),
        ("Fv   {kind: channel, channel: v}  +1", RED),
        ("Fc   {kind: coulomb}              +1", RED),
        ("offset {kind: constant}           +1", GREEN),
        ("every term is what u must overcome:", GREY),
        ("friction opposes v, so it ADDS to u", GREY),
    ])  # fmt: skip


def mass_spring_damper(ax):
    ax.set_title("Mass-spring-damper (docs/examples/mass-spring-damper)", size=10)
    ax.plot([0.05, 0.95], [0.6, 0.6], color=GREY, lw=3)
    wall(ax, 0.08, 0.61, 0.86)
    spring(ax, 0.08, 0.45, 0.8)
    ax.plot([0.08, 0.22], [0.68, 0.68], color=GREY, lw=1.5)  # damper
    ax.add_patch(Rectangle((0.22, 0.65), 0.12, 0.06, fc="white", ec=GREY))
    ax.plot([0.28, 0.45], [0.68, 0.68], color=GREY, lw=1.5)
    ax.text(0.26, 0.86, "k", size=9, color=GREY)
    ax.text(0.26, 0.715, "c", size=9, color=GREY, va="bottom")
    block(ax, 0.45, 0.62, 0.16, 0.2, "m")
    arrow(ax, 0.62, 0.78, 0.2, BLUE, "u (applied)")
    arrow(ax, 0.62, 0.66, 0.2, "black", "v > 0")
    arrow(ax, 0.44, 0.53, -0.3, RED, "k x + c v  (x, v > 0)", above=False)
    axis(ax, 0.05, 0.97, "+x: as u pushes")
    legend(ax, [
        ("explained  u = applied force, > 0 pushes +x", "black"),
        ("u = m a + c v + k x", "black"),
        ("m  {kind: channel, channel: a}  +1", BLUE),
        ("c  {kind: channel, channel: v}  +1", RED),
        ("k  {kind: channel, channel: x}  +1", RED),
        ("(+ {kind: coulomb} +1 for friction)", GREY),
        ("spring and damper pull back, so", GREY),
        ("u must supply them: sign +1", GREY),
    ])  # fmt: skip


def main(path: Path) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.6))
    for ax, draw in zip(axes, (hydro_muscle, linear_motor, mass_spring_damper), strict=True):
        ax.set_xlim(0, 1)
        ax.set_ylim(-0.18, 1.05)
        ax.set_aspect("auto")
        ax.axis("off")
        draw(ax)
    fig.text(0.5, 0.015, "Arrows: forces on the moving body when their parameter and regressor "
             "are positive. explained = sum of sign x parameter x regressor; a channel logged "
             "the other way is declared rig.channels.<c>: {sign: -1}.", ha="center",
             size=9)  # fmt: skip
    fig.subplots_adjust(left=0.01, right=0.99, top=0.93, bottom=0.06, wspace=0.06)
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main(Path(__file__).resolve().parent / "sign-conventions.png")
