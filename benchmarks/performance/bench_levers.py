"""Error against run time of the speed levers, on the leg scene or the column collapse.

    python benchmarks/performance/bench_levers.py leg [--variant NAME:KEY=VALUE,KEY=VALUE ...] [--threads 2]
        [--bed-depth 0.08] [--settle 0.3] [--omega 0.8]
    python benchmarks/performance/bench_levers.py column [--variant ...] [--resolution coarse]
    python benchmarks/performance/bench_levers.py leg-wheel [--variant ...] [--spacing 0.005] [--settle 1.0] [--t-end 3.0]

Each variant is a set of overrides of the scene's numerics (e.g. ``cfl=0.4``, ``sound_speed=14.4``,
``cell_order=true``); for the column, ``material_preset=NAME`` selects the material preset instead.
The first variant is the reference ("baseline", no overrides, unless given). Prints steps, steps
per simulated second (load-independent), wall time per simulated second (moves with the machine's
load: compare within one run), CPU seconds of this process per simulated second (much less
sensitive to other processes' load than wall time; run with OMP_WAIT_POLICY=passive so that idle
threads do not spin), and the outcome with its relative change against the reference:
peak lift and thrust for the leg (the CI variant of the scene by default: 8 cm bed, 0.3 s pause,
ω = 0.8 rad/s, Δx = 2.13 mm), L* and H* for the column, mean slip, mean forward speed, mean, final
and maximum sinkage for the leg-wheel (chapter 4's 50 × 10 cm bed and 8 cm C-leg wheel under
4.9 N at ω = 1.5 rad/s, coarsened: Δx = 5 mm with legs 1.5 cm thick, the three rows a part needs).
"""

from __future__ import annotations

import argparse
import json
import time

from terrasph import _core
from terrasph.cli_common import setting_value
from terrasph.scenes import ColumnCollapse, run_column_collapse
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel

OUTCOMES = {"leg": ("peak_lift", "peak_thrust"), "column": ("runout_normalised", "final_height_normalised"),
            "leg-wheel": ("mean_slip", "mean_forward_speed", "mean_sinkage", "final_sinkage", "max_sinkage")}


def parse_variant(text: str) -> tuple[str, dict[str, bool | int | float | str]]:
    """"fast:cfl=0.4,sound_speed=14.4" -> ("fast", {"cfl": 0.4, "sound_speed": 14.4})."""
    name, _, rest = text.partition(":")
    overrides: dict[str, bool | int | float | str] = {}
    for pair in filter(None, rest.split(",")):
        key, _, value = pair.partition("=")
        overrides[key] = value if key == "material_preset" else setting_value(value)
    return name, overrides


def run_variant(scene: str, overrides: dict, args: argparse.Namespace) -> dict:
    numerics = {k: v for k, v in overrides.items() if k != "material_preset"}
    if scene == "leg":
        config = LegRotation(leg=args.leg, omega=args.omega, bed_depth=args.bed_depth, settle_time=args.settle,
                             numerics=numerics)
        return run_leg_rotation(config, output=None, progress=False, plot=False).summary()
    if scene == "leg-wheel":
        start = time.perf_counter()
        wheel = LegWheel(wheel=args.wheel, spacing=args.spacing, thickness=3 * args.spacing, settle_time=args.settle,
                         t_end=args.t_end, numerics=numerics)
        summary = run_leg_wheel(wheel, plot=False).summary()
        return {**summary, "time": wheel.t_end, "wall_time": time.perf_counter() - start, "status": "completed"}
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
    parser.add_argument("--settle", type=float, default=None, help="pause (s); 0.3 (leg), 1.0 (leg-wheel)")
    parser.add_argument("--resolution", default="coarse")
    parser.add_argument("--wheel", default="c-leg")
    parser.add_argument("--spacing", type=float, default=0.005)
    parser.add_argument("--t-end", type=float, default=3.0)
    args = parser.parse_args()
    if args.settle is None:
        args.settle = 1.0 if args.scene == "leg-wheel" else 0.3
    _core.set_num_threads(args.threads)
    variants = [parse_variant(v) for v in args.variant] or [("baseline", {})]
    rows = []
    for name, overrides in variants:
        cpu = time.process_time()
        row = {"variant": name, "overrides": overrides, **run_variant(args.scene, overrides, args)}
        row["cpu_time"] = time.process_time() - cpu
        rows.append(row)
        print(json.dumps(row), flush=True)
    outcomes = OUTCOMES[args.scene]
    print("\n| variant | steps | steps per sim. s | wall s per sim. s | speed-up (wall) | CPU s per sim. s "
          "| speed-up (CPU) | " + " | ".join(f"{name} | change" for name in outcomes) + " | leaks | status |")
    print("|---" * (9 + 2 * len(outcomes)) + "|")
    reference = rows[0]
    for r in rows:
        per_second = r["wall_time"] / r["time"]
        changes = " | ".join(f"{r[name]:.4g} | {100 * (r[name] / reference[name] - 1):+.1f}%" for name in outcomes)
        print(f"| {r['variant']} | {r['steps']} | {r['steps'] / r['time']:.0f} | {per_second:.1f} | "
              f"{reference['wall_time'] / reference['time'] / per_second:.2f} | {r['cpu_time'] / r['time']:.1f} | "
              f"{reference['cpu_time'] / reference['time'] / (r['cpu_time'] / r['time']):.2f} | {changes} | "
              f"{r.get('leaked_particles', '—')} | {r['status']} |")

if __name__ == "__main__":
    main()
