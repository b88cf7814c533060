"""Extraction resistance against the dead weight of the grains above (issue 13, "strength at low
confinement"): a plate pushed into the settled bed of glass beads and pulled out again, for each
constitutive model given. At each depth d of the up stroke it prints the downward load on the plate,
the weight of the prism of grains above it, W_p = ρ0 g d L W, their ratio, and the ratio of the
extraction load to the penetration load at the same depth. A tension-free, stress-less packing
resists extraction with the prism's weight only (ratio 1); frictional strength makes it larger.

    python benchmarks/plate_extraction.py [--models mu_i_hypoelastic drucker_prager] [--spacing 0.0025]
        [--max-depth 0.04] [--numerics NAME=VALUE ...]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from terrasph.cli_common import add_numerics_option, numerics_overrides
from terrasph.scene import GRAVITY
from terrasph.scenes.plate_intrusion import PlateIntrusion, run_plate_intrusion

DEPTHS = (0.01, 0.02, 0.03)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--models", nargs="+", default=["mu_i_hypoelastic", "drucker_prager"])
    parser.add_argument("--spacing", type=float, default=0.0025)
    parser.add_argument("--max-depth", type=float, default=0.04)
    add_numerics_option(parser)
    args = parser.parse_args()
    print("| model | depth (mm) | penetration load (N) | extraction load (N, down) | prism weight (N) "
          "| extraction / prism | extraction / penetration | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for model in args.models:
        config = PlateIntrusion(spacing=args.spacing, max_depth=args.max_depth, model=model,
                                numerics=numerics_overrides(args.numerics))
        start = time.process_time()
        result = run_plate_intrusion(config, output=None, progress=False, plot=False)
        cpu = time.process_time() - start
        down_depth, down_force = result.stroke("down")
        up_depth, up_force = result.stroke("up")
        rho0 = config.material().reference_density
        for depth in DEPTHS:
            penetration = float(np.interp(depth, down_depth, down_force))
            extraction = -float(np.interp(depth, up_depth, up_force))
            prism = rho0 * GRAVITY * depth * config.plate_length * config.width
            print(f"| {model} | {1000 * depth:.0f} | {penetration:.3f} | {extraction:.3f} | {prism:.3f} | "
                  f"{extraction / prism:.2f} | {extraction / penetration:.2f} | {cpu:.0f} |", flush=True)


if __name__ == "__main__":
    main()
