"""Does the column's thin toe come to rest? The 7 × 8 cm column collapse with and
without Coulomb wall friction: at each time, the reach of the connected tail (`toe_front`,
analysis.front_position) and the largest |v_x| of the five front-most grains (the toe and any grain
ahead of it). Wave-speed step; CPU time per run.

    python benchmarks/validation/column_toe.py [--resolution fit] [--model mu_i_hypoelastic] [--wall-friction 0 0.384]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from terrasph import analysis
from terrasph.scenes.column_collapse import ColumnCollapse, build_column_collapse
from terrasph.simulation import Simulation

TIMES = (0.3, 0.4, 0.5, 0.6, 0.8, 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", default="fit")
    parser.add_argument("--model", default="mu_i_hypoelastic")
    parser.add_argument("--wall-friction", type=float, nargs="+", default=[0.0, 0.384])
    args = parser.parse_args()
    print("| level | model | μ_w | " + " | ".join(f"lead speed at {t} s (m/s)" for t in TIMES)
          + " | toe reach at 1 s (mm) | CPU s |")
    print("|---" * (len(TIMES) + 5) + "|")
    for mu_w in args.wall_friction:
        config = ColumnCollapse(resolution=args.resolution, model=args.model,
                                numerics={"wall_friction_coefficient": mu_w})
        scene, material, numerics = build_column_collapse(config)
        sim = Simulation(scene, material, numerics)
        start = time.process_time()
        speeds = []
        for t in TIMES:
            sim.advance(t)
            lead = np.argsort(sim.position[:, 0])[-5:]
            speeds.append(f"{np.abs(sim.velocity[lead, 0]).max():.4f}")
        toe = analysis.front_position(sim.position, scene.spacing)
        print(f"| {args.resolution} | {args.model} | {mu_w:g} | " + " | ".join(speeds)
              + f" | {1e3 * toe:.1f} | {time.process_time() - start:.1f} |", flush=True)


if __name__ == "__main__":
    main()
