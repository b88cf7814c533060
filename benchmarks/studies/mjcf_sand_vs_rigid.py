"""A gymnasium model with an open-loop gait on the bed of glass beads and on MuJoCo's rigid floor:
the mean forward speed of its centre of mass after the pause on each, their ratio, the feet's
sinkage, and a figure of both paths (docs/mjcf.md).

    python benchmarks/studies/mjcf_sand_vs_rigid.py [--spacing 0.015] [--t-end 2.5] [--out cheetah.h5]

The model file is gymnasium's, as shipped (gymnasium/envs/mujoco/assets/half_cheetah.xml). The
gait: every motor a sine of half its range (ctrl ±0.5) and period 0.4 s, the back leg's three in
phase, the front leg's half a period later; it starts after a 0.5 s pause. The rigid run takes
the sand run's mean step.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import gymnasium
from matplotlib.figure import Figure
from terrasph.scenes.mjcf_scene import MjcfScene, rigid_floor_run, run_mjcf

PERIOD = 0.4
GAIT = tuple(f"{name}=sin:0.5,{PERIOD},{phase}" for name, phase in
             (("bthigh", 0), ("bshin", 0), ("bfoot", 0), ("fthigh", 180), ("fshin", 180), ("ffoot", 180)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", default="half_cheetah.xml", help="a gymnasium asset (default %(default)s)")
    parser.add_argument("--spacing", type=float, default=0.015)
    parser.add_argument("--bed-width", type=float, default=2.5)
    parser.add_argument("--bed-depth", type=float, default=0.3)
    parser.add_argument("--start-x", type=float, default=0.9)
    parser.add_argument("--settle-time", type=float, default=0.5)
    parser.add_argument("--t-end", type=float, default=2.5)
    parser.add_argument("--couple-below", type=float, default=1.0, help="1 m: every body meets the grains")
    parser.add_argument("--out", default=None, help="the sand run's HDF5 file")
    parser.add_argument("--figure", default=None, help="PNG of both paths of the centre of mass")
    args = parser.parse_args()
    model = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", args.model)
    config = MjcfScene(model=model, bed_width=args.bed_width, bed_depth=args.bed_depth, spacing=args.spacing,
                       start_x=args.start_x, settle_time=args.settle_time, t_end=args.t_end, ctrl=GAIT,
                       couple_below=args.couple_below)
    start = time.perf_counter()
    sand = run_mjcf(config, args.out, plot=False)
    wall = time.perf_counter() - start
    summary = sand.summary()
    rigid, path = rigid_floor_run(model, None, args.t_end, args.settle_time, timestep=args.t_end / summary["steps"],
                                  ctrl=GAIT)
    print(json.dumps({"sand": summary, "rigid": rigid, "speed_ratio_sand_over_rigid":
                      summary["mean_speed"] / rigid["mean_speed"], "sand_wall_s": round(wall, 1)}, indent=2))
    if args.figure:
        actuators = sand.series["robot/actuators"]
        figure = Figure(figsize=(6.4, 3.6), layout="constrained")
        ax = figure.subplots()
        ax.plot(path[:, 0], (path[:, 1] - path[0, 1]) * 100, label=f"rigid floor: {rigid['mean_speed']:.3f} m/s")
        ax.plot(actuators["time"], (actuators["com"][:, 0] - actuators["com"][0, 0]) * 100,
                label=f"glass beads, dx = {args.spacing * 1000:g} mm: {summary['mean_speed']:.3f} m/s")
        ax.axvline(args.settle_time, color="0.5", linestyle=":", linewidth=1)
        ax.set(xlabel="t (s)", ylabel="centre of mass x travelled (cm)",
               title=f"{args.model}, same gait: speed on sand / rigid = "
                     f"{summary['mean_speed'] / rigid['mean_speed']:.2f}")
        ax.legend()
        figure.savefig(args.figure, dpi=120)


if __name__ == "__main__":
    main()
