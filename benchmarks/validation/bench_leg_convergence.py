"""Error against run time for the rotating C-leg.

Runs the leg-rotation scene at several resolutions (rows of particles across the 6.4 mm leg:
3, 4, 5 → Δx = 2.13, 1.60, 1.28 mm) and prints a table of grains, steps, wall time, peak lift
and peak thrust and their change against the finest run; writes the rows as JSON and a plot of
the load curves.

    python benchmarks/validation/bench_leg_convergence.py [--levels coarse fine finer] [--omega 0.8]
        [--settle 0.3] [--bed-depth 0.15] [--threads 2]

The settling pause is shortened from the scene's 2 s (the bed starts at its hydrostatic density);
ω = 0.8 rad/s keeps the sweep to 2 s of simulated time.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from terrasph import _core
from terrasph.plotting import plot_leg_loads
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--levels", nargs="+", default=["coarse", "fine", "finer"])
    parser.add_argument("--leg", default="c-leg")
    parser.add_argument("--omega", type=float, default=0.8)
    parser.add_argument("--settle", type=float, default=0.3)
    parser.add_argument("--bed-depth", type=float, default=0.15)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "results")
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    rows, curves = [], []
    for level in args.levels:
        config = LegRotation(leg=args.leg, omega=args.omega, resolution=level, settle_time=args.settle,
                             bed_depth=args.bed_depth)
        result = run_leg_rotation(config, output=None, progress=False, plot=False)
        row = {"level": level, **result.summary()}
        rows.append(row)
        curves.append((result.theta, result.lift, result.thrust, f"{level}, Δx = {1e3 * config.grid_spacing:.2f} mm"))
        print(json.dumps(row), flush=True)
    finest = rows[-1]
    for row in rows:
        for key in ("peak_lift", "peak_thrust"):
            row[f"{key}_change"] = abs(row[key] - finest[key]) / abs(finest[key])
    print("\n| level | Δx (mm) | grains | steps | wall time (s) | peak lift (N) | peak thrust (N) "
          "| Δ lift vs finest | Δ thrust vs finest | leaks |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['level']} | {1e3 * r['spacing']:.2f} | {r['granular_particles']} | {r['steps']} | "
              f"{r['wall_time']:.0f} | {r['peak_lift']:.3f} | {r['peak_thrust']:.3f} | "
              f"{100 * r['peak_lift_change']:.1f}% | {100 * r['peak_thrust_change']:.1f}% | {r['leaked_particles']} |")
    (args.out / "leg_convergence.json").write_text(json.dumps(rows, indent=2))
    plot_leg_loads(curves, path=args.out / "leg_convergence.png",
                   title=f"{args.leg}, ω = {args.omega:g} rad/s: resolution study")


if __name__ == "__main__":
    main()
