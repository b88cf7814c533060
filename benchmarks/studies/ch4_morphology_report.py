"""Chapter 4's morphology study from its sweeps: the six wheels' figures with error bars, the
dissertation's three statements checked against them, and two figures (the wheels as built, with
the side that leads into the sand marked; the figures per wheel with their bars).

    terrasph sweep benchmarks/studies/sweep_leg_wheel_ch4_morphologies.yaml --out ch4_morphologies
    terrasph sweep benchmarks/studies/sweep_leg_wheel_ch4_morphologies_coarse.yaml --out ch4_morphologies_coarse
    python benchmarks/studies/ch4_morphology_report.py ch4_morphologies ch4_morphologies_coarse \
        [--tier-error 0.005] [--figures docs/img]

Each figure's bar is the resolution's difference (the two sweeps) and the fidelity tier's relative
error (``--tier-error``, measured in docs/fidelity.md) added in quadrature. Prints Markdown.
"""

from __future__ import annotations

import argparse
import itertools
import math
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from matplotlib.figure import Figure
from terrasph.scenes.leg_wheel import WHEELS, LegWheel, wheel_shape
from terrasph.sweeps.report import finished_cases

#: summary key → (column title, scale to the printed unit)
FIGURES = {"mean_forward_speed": ("mean v_x (cm/s)", 100.0), "mean_slip": ("mean slip", 1.0),
           "mean_sinkage": ("mean sinkage (cm)", 100.0), "max_sinkage": ("max sinkage (cm)", 100.0),
           "cost_of_transport": ("CoT", 1.0)}
LATE_WINDOW = 1.0  # s: the end of the run over which "still moving" is judged


def by_wheel(sweep_dir: Path) -> dict[str, dict[str, Any]]:
    """The finished case of each wheel in a morphology sweep: its summary, wall time and the mean
    forward speed of its last LATE_WINDOW seconds (from the run file)."""
    cases = {}
    for case in finished_cases(sweep_dir):
        with h5py.File(sweep_dir / "runs" / f"{case['case_id']}.h5", "r") as f:
            group = f["series/robot/wheel"]
            time, vx = group["time"][()], group["velocity"][()][:, 0]
        late = time >= time[-1] - LATE_WINDOW
        cases[case["config"]["wheel"]] = {**case["summary"], "late_speed": float(np.mean(vx[late])),
                                          "wall": case.get("wall_time", math.nan)}
    return cases


def error_bars(fine: dict[str, dict[str, Any]], coarse: dict[str, dict[str, Any]],
               tier_error: float) -> dict[str, dict[str, float]]:
    """Per wheel and figure: |fine − coarse| ⊕ tier_error·|fine| (NaN where the coarse run is missing)."""
    bars: dict[str, dict[str, float]] = {}
    for wheel, values in fine.items():
        other = coarse.get(wheel)
        bars[wheel] = {key: math.hypot(abs(values[key] - other[key]) if other else math.nan, tier_error * values[key])
                       for key in FIGURES}
    return bars


def table(fine: dict[str, dict[str, Any]], bars: dict[str, dict[str, float]]) -> str:
    """Markdown: one row per wheel, each figure ± its bar."""
    head = "| wheel | " + " | ".join(title for title, _ in FIGURES.values()) + " | v_x, last 1 s (cm/s) | leaks |"
    lines = [head, "|" + "---|" * (len(FIGURES) + 3)]
    for wheel in WHEELS:
        if wheel not in fine:
            continue
        cells = [f"{scale * fine[wheel][key]:.3g} ± {scale * bars[wheel][key]:.2g}"
                 for key, (_, scale) in FIGURES.items()]
        lines.append(f"| {wheel} | " + " | ".join(cells) + f" | {100 * fine[wheel]['late_speed']:.3g} | "
                     f"{fine[wheel]['leaked_particles']} |")
    return "\n".join(lines)


def ranking(fine: dict[str, dict[str, Any]], bars: dict[str, dict[str, float]], key: str,
            descending: bool) -> str:
    """The wheels ordered by `key`, with '≈' between neighbours whose bars overlap."""
    order = sorted(fine, key=lambda w: fine[w][key], reverse=descending)
    text = order[0]
    for before, after in itertools.pairwise(order):
        apart = abs(fine[before][key] - fine[after][key]) > bars[before][key] + bars[after][key]
        text += (" > " if apart else " ≈ ") + after
    return text


def statements(fine: dict[str, dict[str, Any]], bars: dict[str, dict[str, float]]) -> str:
    """The dissertation's three statements of §4 against the figures."""
    legs = [w for w in fine if w != "wheel"]
    speed = ranking(fine, bars, "mean_forward_speed", descending=True)
    sinkage = ranking(fine, bars, "mean_sinkage", descending=True)
    lines = ["| statement (ch. 4) | here |", "|---|---|",
             f"| the reversed C leg-wheel has the best mobility | by mean v_x: {speed} |",
             f"| the flat-leg wheel has the worst mobility, from the largest sinkage (it \"swims\") | "
             f"by mean sinkage: {sinkage} |"]
    if "wheel" in fine and legs:
        faster = [w for w in legs if fine[w]["mean_forward_speed"] > fine["wheel"]["mean_forward_speed"]]
        lines.append(f"| the plain wheel gets stuck where the legs pull themselves out | the wheel's v_x over the "
                     f"last second {100 * fine['wheel']['late_speed']:.3g} cm/s (mean {100 * fine['wheel']['mean_forward_speed']:.3g}); "
                     f"{len(faster)} of {len(legs)} leg-wheels faster on average |")
    return "\n".join(lines)


def draw_wheels(path: Path) -> None:
    """The six wheels as built (legs at their start pose, sand below z = 0 drawn at the pause's typical
    sinkage), travel +x, clockwise spin: which side of each leg leads into the sand."""
    figure = Figure(figsize=(12.0, 2.6), layout="constrained")
    axes = figure.subplots(1, len(WHEELS))
    for ax, wheel in zip(axes, WHEELS):
        shape = wheel_shape(LegWheel(wheel=wheel))  # the scene's default geometry
        axle_z = -shape.lowest_point() - 0.02  # the axle with the lowest point 2 cm deep
        ax.axhspan(-12, 0, color="#e8d9b0")
        for loop in shape.transformed_outline(0.0, (0.0, axle_z)):
            closed = np.vstack([loop, loop[:1]]) * 100
            ax.fill(closed[:, 0], closed[:, 1], color="0.35")
        ax.annotate("", xy=(9.5, 12.0), xytext=(3.5, 12.0), arrowprops={"arrowstyle": "->"})
        ax.text(6.5, 12.6, "travel", ha="center", fontsize=8)
        toe_z = 100 * (axle_z + shape.lowest_point())
        ax.annotate("", xy=(-6.0, toe_z - 1.5), xytext=(-1.0, toe_z - 1.5), arrowprops={"arrowstyle": "->", "color": "C0"})
        ax.text(-3.5, toe_z - 3.5, "sweep", ha="center", fontsize=8, color="C0")
        theta = np.linspace(2.4, 0.9, 30)  # clockwise arc over the hub
        ax.plot(3.0 * np.cos(theta), 100 * axle_z + 3.0 * np.sin(theta), "C3")
        ax.annotate("", xy=(3.0 * math.cos(0.8), 100 * axle_z + 3.0 * math.sin(0.8)),
                    xytext=(3.0 * math.cos(0.95), 100 * axle_z + 3.0 * math.sin(0.95)),
                    arrowprops={"arrowstyle": "->", "color": "C3"})
        ax.set(title=wheel, xlim=(-10, 10), ylim=(-12, 14), aspect="equal", xticks=[], yticks=[])
    figure.suptitle("the wheels as built (terrasph.bodies): clockwise spin, travel +x; the leg at the bottom "
                    "sweeps backwards (−x) through the sand (blue): the face on its −x side leads", fontsize=9)
    figure.savefig(path, dpi=120)


def draw_figures(fine: dict[str, dict[str, Any]], bars: dict[str, dict[str, float]], path: Path) -> None:
    """Each figure per wheel as a bar with its error bar."""
    wheels = [w for w in WHEELS if w in fine]
    figure = Figure(figsize=(3.0 * len(FIGURES), 3.0), layout="constrained")
    for ax, (key, (title, scale)) in zip(figure.subplots(1, len(FIGURES)), FIGURES.items()):
        ax.bar(range(len(wheels)), [scale * fine[w][key] for w in wheels],
               yerr=[scale * bars[w][key] for w in wheels], color="0.8", edgecolor="0.3", capsize=3)
        ax.set_xticks(range(len(wheels)), wheels, rotation=35, ha="right", fontsize=8)
        ax.set_title(title, fontsize=9)
    figure.savefig(path, dpi=120)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fine", type=Path, help="the sweep at the default resolution")
    parser.add_argument("coarse", type=Path, nargs="?", default=None, help="the sweep at the second resolution")
    parser.add_argument("--tier-error", type=float, default=0.005,
                        help="relative error of the fine sweep's fidelity tier against the reference tier")
    parser.add_argument("--figures", type=Path, default=None, help="directory for the two PNG figures")
    args = parser.parse_args()
    fine = by_wheel(args.fine)
    coarse = by_wheel(args.coarse) if args.coarse else {}
    bars = error_bars(fine, coarse, args.tier_error)
    print(table(fine, bars))
    print()
    print(statements(fine, bars))
    print()
    print("| wheel | wall (s), fine | wall (s), coarse |\n|---|---|---|")
    for wheel in (w for w in WHEELS if w in fine):
        print(f"| {wheel} | {fine[wheel]['wall']:.0f} | {coarse.get(wheel, {}).get('wall', math.nan):.0f} |")
    if args.figures:
        args.figures.mkdir(parents=True, exist_ok=True)
        draw_wheels(args.figures / "ch4_wheels_as_built.png")
        draw_figures(fine, bars, args.figures / "ch4_morphology_figures.png")
