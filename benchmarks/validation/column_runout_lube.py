"""Column runout against the quasi-2D fits of Lube, Huppert, Sparks & Freundt (2005, Phys. Rev. E
72, 041301): L* = (L∞ − L0)/L0 ≈ 1.2 a for a ≲ 1.8 and ≈ 1.9 a^(2/3) for a ≳ 2.8, a = H0/L0.
Every column has the area of the dissertation's 7 × 8 cm column (L0·H0 = 56 cm², so the
same particle count at a named resolution), Table 2.1's beads with μ1 = tan 21°, μ2 = tan 33°, on a
0.6 m rough floor; the front is the column scene's (first thinner than
DEPOSIT_THICKNESS_GRAIN_DIAMETERS grain diameters); each run until at rest (or --t-end).

    python benchmarks/validation/column_runout_lube.py [--aspects 0.5 1 2 4 6] [--resolution coarse]
        [--wall-friction 0 0.384] [--model mu_i_hypoelastic] [--numerics NAME=VALUE ...] [--t-end 3]

Prints a Markdown table; the CPU time is the process's, per run.
"""

from __future__ import annotations

import argparse
import math
import time

from terrasph.cli_common import add_numerics_option, numerics_overrides
from terrasph.scenes.column_collapse import ColumnCollapse, lube_runout, run_column_collapse

#: L0·H0 of the dissertation's column (m²)
COLUMN_AREA = 0.07 * 0.08


#: Lube et al. (2005)'s quasi-2D runout L* for aspect ratio a (the scene's, which sizes its floor by it)
lube_fit = lube_runout


def column(aspect: float, resolution: str, numerics: dict, t_end: float,
           model: str = "mu_i_hypoelastic") -> ColumnCollapse:
    """The column of aspect ratio a with the area COLUMN_AREA."""
    width = math.sqrt(COLUMN_AREA / aspect)
    return ColumnCollapse(column_width=width, column_height=aspect * width, resolution=resolution,
                          floor_length=0.6, t_end=t_end, numerics=numerics, model=model)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--aspects", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0, 6.0])
    parser.add_argument("--resolution", default="coarse")
    parser.add_argument("--wall-friction", type=float, nargs="+", default=[0.0, 0.384])
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--model", default="mu_i_hypoelastic", help="material.model of the column")
    add_numerics_option(parser)
    args = parser.parse_args()
    base = numerics_overrides(args.numerics)
    print("| a | μ_w | L0 (mm) | H0 (mm) | Δx (mm) | grains | L* | L* (Lube fit) | ratio | toe L* | at rest (s) "
          "| steps | CPU s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for mu_w in args.wall_friction:
        for aspect in args.aspects:
            config = column(aspect, args.resolution, {**base, "wall_friction_coefficient": mu_w}, args.t_end,
                            args.model)
            start = time.process_time()
            result = run_column_collapse(config, output=None, progress=False, plot=False)
            cpu = time.process_time() - start
            fit = lube_fit(aspect)
            length0 = result.initial_length
            toe = (result.toe_front - length0) / length0
            rest = f"{result.run.time:.2f}" if result.run.status == "at_rest" else f"no ({result.run.time:.1f})"
            print(f"| {aspect:g} | {mu_w:g} | {1e3 * length0:.1f} | {1e3 * result.initial_height:.1f} "
                  f"| {1e3 * result.spacing:.2f} | {result.granular_particles} | {result.runout_normalised:.2f} "
                  f"| {fit:.2f} | {result.runout_normalised / fit:.2f} | {toe:.2f} | {rest} | {result.run.steps} "
                  f"| {cpu:.1f} |", flush=True)


if __name__ == "__main__":
    main()
