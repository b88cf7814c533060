"""Table and figures from leg-rotation run files (Fig. 3.2–3.5 of the dissertation).

    python benchmarks/studies/leg_report.py RUN.h5 [RUN.h5 ...] [--out DIR]

Reads each file's `/results` attributes and `/series/bodies/leg` (written by
`terrasph run leg-rotation` or `run_leg_rotation`), prints a markdown table (leg, ω, peak lift,
peak thrust, noise, leaks, wall time) and writes one figure per ω with every leg's lift and thrust
against θ (`leg_loads_omega_<ω>.png`).
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np
from terrasph.io import read_run
from terrasph.plotting import plot_leg_loads


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "results")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    by_omega: dict[float, list] = defaultdict(list)
    rows = []
    for path in sorted(args.runs):
        run = read_run(path)
        results = run.group_attrs.get("/results", {})
        config = run.config["leg_rotation"]
        series = run.series["bodies/leg"]
        turning = series["time"] > config["settle_time"] + 1e-9
        theta, force = series["angle"][turning], series["force"][turning]
        by_omega[config["omega"]].append((theta, force[:, 1], force[:, 0], config["leg"]))
        rows.append({"file": path.name, "leg": config["leg"], "omega": config["omega"],
                     "bed_depth": config["bed_depth"], "settle_time": config["settle_time"],
                     **{k: results[k] for k in ("peak_lift", "peak_thrust", "lift_noise", "thrust_noise",
                                                "leaked_particles", "granular_particles", "wall_time", "spacing")},
                     "lift_at_0": float(np.interp(0.0, theta, force[:, 1]))})
    print("| leg | ω (rad/s) | peak lift F_z (N) | F_z at θ = 0 (N) | peak thrust F_x (N) | noise lift / thrust | leaks | grains | wall time (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["omega"], r["leg"])):
        print(f"| {r['leg']} | {r['omega']:g} | {r['peak_lift']:.3f} | {r['lift_at_0']:.3f} | {r['peak_thrust']:.3f} | "
              f"{100 * r['lift_noise']:.1f} % / {100 * r['thrust_noise']:.1f} % | {r['leaked_particles']} | "
              f"{r['granular_particles']} | {r['wall_time']:.0f} |")
    for omega, curves in by_omega.items():
        plot_leg_loads(curves, path=args.out / f"leg_loads_omega_{omega:g}.png", title=f"ω = {omega:g} rad/s")
    (args.out / "leg_report.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
