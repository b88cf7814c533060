"""Extraction resistance against the dead weight of the grains above ("strength at low
confinement"): a plate pushed into the settled bed of glass beads and pulled out again, for each
constitutive model given. At each depth d of the up stroke it prints the downward load on the plate,
the weight of the prism of grains above it, W_p = ρ0 g d L W, their ratio, and the ratio of the
extraction load to the penetration load at the same depth. A tension-free, stress-less packing
resists extraction with the prism's weight only (ratio 1); frictional strength makes it larger.

    python benchmarks/validation/plate_extraction.py [--models mu_i_hypoelastic drucker_prager] [--spacing 0.0025]
        [--max-depth 0.04] [--numerics NAME=VALUE ...]

With ``--buried H`` the plate starts buried instead, its top face H below the surface of the bed
that settles on it (an intact overburden), and is pulled straight up by ``--pull`` at ``--speed``: the
plane-strain strip-anchor uplift test. It prints the load at rest before the pull (the weight the
plate carries), the peak extraction load, and both against the dead weight γHBW and the
vertical-slip-surface estimate γHBW(1 + K0 tan φ·H/B) (``anchor_uplift_references``).
``--geostatic`` starts the hypoelastic μ(I) geostatic (Drucker–Prager always is).

    python benchmarks/validation/plate_extraction.py --buried 0.03 [--pull 0.015] [--settle 0.3] [--geostatic]
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
    parser.add_argument("--speed", type=float, default=0.02, help="plate speed (m/s)")
    parser.add_argument("--buried", type=float, default=None, help="start buried, top face this deep (m)")
    parser.add_argument("--pull", type=float, default=0.015, help="buried start: upward travel (m)")
    parser.add_argument("--settle", type=float, default=0.3, help="buried start: settling time (s)")
    parser.add_argument("--geostatic", action="store_true", help="start the hypoelastic mu(I) geostatic")
    add_numerics_option(parser)
    args = parser.parse_args()
    if args.buried is not None:
        buried(args)
        return
    print("| model | depth (mm) | penetration load (N) | extraction load (N, down) | prism weight (N) "
          "| extraction / prism | extraction / penetration | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for model in args.models:
        config = PlateIntrusion(spacing=args.spacing, max_depth=args.max_depth, model=model, speed=args.speed,
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


def buried(args: argparse.Namespace) -> None:
    """The buried-start table: load at rest and peak extraction load against the references."""
    print("| model | start | H (mm) | B (mm) | net load at rest (N, down) | peak extraction (N, down) | at uplift (mm) "
          "| dead weight γHBW (N) | vertical slip (N) | rest / dead | peak / dead | peak / vertical slip "
          "| leaks | CPU s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for model in args.models:
        geostatic = args.geostatic and model == "mu_i_hypoelastic"
        config = PlateIntrusion(spacing=args.spacing, model=model, buried_depth=args.buried, pull_distance=args.pull,
                                settle_time=args.settle, geostatic=geostatic, speed=args.speed,
                                numerics=numerics_overrides(args.numerics))
        start = time.process_time()
        result = run_plate_intrusion(config, output=None, progress=False, plot=False)
        cpu = time.process_time() - start
        series = result.run.bodies["plate"]
        at_rest = (series["time"] > config.settle_time - 0.05) & (series["time"] <= config.settle_time + 1e-9)
        rest = -float(np.mean(series["force"][at_rest, 1]))
        depth, force = result.stroke("up")
        uplift = (config.buried_depth + config.plate_thickness) - depth
        peak_uplift, peak = result.extraction_peak()
        refs = result.uplift_references()
        dead, slip = refs["dead_weight"], refs["vertical_slip"]
        start_name = "geostatic" if (geostatic or model == "drucker_prager") else "isotropic"
        print(f"| {model} | {start_name} | {1000 * config.buried_depth:.0f} | {1000 * config.plate_length:.0f} "
              f"| {rest:.3f} | {peak:.3f} | {1000 * peak_uplift:.1f} | {dead:.3f} | {slip:.3f} | {rest / dead:.2f} "
              f"| {peak / dead:.2f} | {peak / slip:.2f} | {result.leaked_particles} | {cpu:.0f} |", flush=True)
        for target in (0.5e-3, 1e-3, 2e-3, 5e-3, 10e-3):
            if target <= uplift.max():
                print(f"|   uplift {1000 * target:g} mm | | | | | {-float(np.interp(target, uplift[::-1], force[::-1])):.3f} "
                      "| | | | | | | | |", flush=True)


if __name__ == "__main__":
    main()
