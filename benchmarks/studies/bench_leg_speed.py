"""Rate dependence of a rotating leg's loads: r_fs = F(fast)/F(slow) of chapter 3, Fig. 3.5.

Runs one leg at a slow and a fast angular velocity for each value of the grain–grain artificial
viscosity α_Π, in the CI variant of the leg scene (8 cm bed, 0.3 s pause, Δx = 2.13 mm), and
prints peak lift and thrust and their ratios fast/slow:

    python benchmarks/studies/bench_leg_speed.py [--leg c-leg] [--omegas 0.2 0.8] [--alphas 0.1 1.0] [--threads 2]

α_Π = 0.1 is terrasph's default; 1.0 is the dissertation's value (docs/design_decisions.md).
Rows are also written as JSON to benchmarks/results/leg_speed.json.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from terrasph import _core
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--leg", default="c-leg")
    parser.add_argument("--omegas", type=float, nargs=2, default=[0.2, 0.8], metavar=("SLOW", "FAST"))
    parser.add_argument("--alphas", type=float, nargs="+", default=[0.1, 1.0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "results")
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for alpha in args.alphas:
        for omega in args.omegas:
            config = LegRotation(leg=args.leg, omega=omega, bed_depth=0.08, settle_time=0.3,
                                 numerics={"artificial_viscosity": alpha})
            result = run_leg_rotation(config, output=None, progress=False, plot=False)
            row = {"artificial_viscosity": alpha, **result.summary()}
            rows.append(row)
            print(json.dumps(row), flush=True)
    print("\n| α_Π | ω slow → fast (rad/s) | peak lift slow / fast (N) | r_fs lift | peak thrust slow / fast (N) "
          "| r_fs thrust | leaks |")
    print("|---|---|---|---|---|---|---|")
    for slow, fast in zip(rows[0::2], rows[1::2]):
        print(f"| {slow['artificial_viscosity']:g} | {slow['omega']:g} → {fast['omega']:g} | "
              f"{slow['peak_lift']:.3f} / {fast['peak_lift']:.3f} | {fast['peak_lift'] / slow['peak_lift']:.3f} | "
              f"{slow['peak_thrust']:.3f} / {fast['peak_thrust']:.3f} | "
              f"{fast['peak_thrust'] / slow['peak_thrust']:.3f} | "
              f"{slow['leaked_particles'] + fast['leaked_particles']} |")
    (args.out / "leg_speed.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
