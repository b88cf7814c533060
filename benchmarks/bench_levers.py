"""Error against run time of the speed levers (issue 12), on the leg scene or the column collapse.

    python benchmarks/bench_levers.py leg [--variant NAME:KEY=VALUE,KEY=VALUE ...] [--threads 2]
        [--bed-depth 0.08] [--settle 0.3] [--omega 0.8]
    python benchmarks/bench_levers.py column [--variant ...] [--resolution coarse]

Each variant is a set of overrides of the scene's numerics (e.g. ``cfl=0.4``, ``sound_speed=14.4``,
``cell_order=true``); for the column, ``material_preset=NAME`` selects the material preset instead.
The first variant is the reference ("baseline", no overrides, unless given). Prints steps, steps
per simulated second (load-independent), wall time per simulated second (moves with the machine's
load: compare within one run), CPU seconds of this process per simulated second (much less
sensitive to other processes' load than wall time; run with OMP_WAIT_POLICY=passive so that idle
threads do not spin), and the outcome with its relative change against the reference:
peak lift and thrust for the leg (the CI variant of the scene by default: 8 cm bed, 0.3 s pause,
ω = 0.8 rad/s, Δx = 2.13 mm), L* and H* for the column.
"""

from __future__ import annotations

import argparse
import json
import time

from bench_sph import parse_value
from terrasph import _core
from terrasph.scenes import ColumnCollapse, run_column_collapse
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation

OUTCOMES = {"leg": ("peak_lift", "peak_thrust"), "column": ("runout_normalised", "final_height_normalised")}


def parse_variant(text: str) -> tuple[str, dict[str, bool | int | float | str]]:
    """"fast:cfl=0.4,sound_speed=14.4" -> ("fast", {"cfl": 0.4, "sound_speed": 14.4})."""
    name, _, rest = text.partition(":")
    overrides: dict[str, bool | int | float | str] = {}
    for pair in filter(None, rest.split(",")):
        key, _, value = pair.partition("=")
        overrides[key] = value if key == "material_preset" else parse_value(value)
    return name, overrides


def run_variant(scene: str, overrides: dict, args: argparse.Namespace) -> dict:
    numerics = {k: v for k, v in overrides.items() if k != "material_preset"}
    if scene == "leg":
        config = LegRotation(leg=args.leg, omega=args.omega, bed_depth=args.bed_depth, settle_time=args.settle,
                             numerics=numerics)
        return run_leg_rotation(config, output=None, progress=False, plot=False).summary()
    extra = {"material_preset": overrides["material_preset"]} if "material_preset" in overrides else {}
    config = ColumnCollapse(resolution=args.resolution, numerics=numerics, **extra)
    return run_column_collapse(config, output=None, progress=False, plot=False).summary()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene", choices=sorted(OUTCOMES))
    parser.add_argument("--variant", action="append", default=[], metavar="NAME:KEY=VALUE,...")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--leg", default="c-leg")
    parser.add_argument("--omega", type=float, default=0.8)
    parser.add_argument("--bed-depth", type=float, default=0.08)
    parser.add_argument("--settle", type=float, default=0.3)
    parser.add_argument("--resolution", default="coarse")
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    variants = [parse_variant(v) for v in args.variant] or [("baseline", {})]
    rows = []
    for name, overrides in variants:
        cpu = time.process_time()
        row = {"variant": name, "overrides": overrides, **run_variant(args.scene, overrides, args)}
        row["cpu_time"] = time.process_time() - cpu
        rows.append(row)
        print(json.dumps(row), flush=True)
    first, second = OUTCOMES[args.scene]
    reference = rows[0]
    print(f"\n| variant | steps | steps per sim. s | wall s per sim. s | speed-up (wall) | CPU s per sim. s "
          f"| speed-up (CPU) | {first} | change "
          f"| {second} | change | status |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        per_second = r["wall_time"] / r["time"]
        print(f"| {r['variant']} | {r['steps']} | {r['steps'] / r['time']:.0f} | {per_second:.1f} | "
              f"{reference['wall_time'] / reference['time'] / per_second:.2f} | {r['cpu_time'] / r['time']:.1f} | "
              f"{reference['cpu_time'] / reference['time'] / (r['cpu_time'] / r['time']):.2f} | {r[first]:.4g} | "
              f"{100 * (r[first] / reference[first] - 1):+.1f}% | {r[second]:.4g} | "
              f"{100 * (r[second] / reference[second] - 1):+.1f}% | {r['status']} |")


if __name__ == "__main__":
    main()
