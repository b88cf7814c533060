"""Numerics levers on the cost of a 3D scene in motion: the plate slab's down stroke, interleaved.

    python benchmarks/performance/bench_sph3d_motion.py [--spacing 0.005] [--span 0.25] [--threads 1]
        [--variant NAME=VALUE,NAME=VALUE ...] [--output benchmarks/results/sph3d_motion.json]

bench_sph3d_levers.py measures beds at rest, which never rebuild their neighbour lists; this is the
same comparison with grains moving. The scene is the plate-intrusion slab of
benchmarks/validation/slab_3d.py (terrasph.scenes.plane_strain_3d.PlateSlab: the 40 mm plate
pushed 4 cm down at 2 cm/s into a 25 mm slab of glass beads between smooth walls, the standard
tier), built once with the default numerics and once per variant (each a comma-separated list of
numerics settings), all in this process. Each is advanced through the settling pause untimed, then
the down stroke is cut into intervals of `span` simulated seconds, and each interval is advanced
by every scene in turn (the order reversed every other interval), timing the process's CPU seconds.
Per interval and variant: the speed-up against the defaults per grain-step and per simulated
second (the time step scales with h), and the neighbour-list builds per step. Writes a JSON file
with its provenance, one row per variant (medians over the intervals, and the last interval's, the
plate deepest) and the columns docs/sph3d.md shows of them (``<!-- results: sph3d_motion -->``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import time
from pathlib import Path

from bench_sph import parse_numerics
from bench_sph3d import provenance
from terrasph import _core
from terrasph.scenes.plane_strain_3d import PlateSlab, build_plate_slab
from terrasph.scenes.plate_intrusion import PlateIntrusion

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_VARIANTS = ["h_factor=1.2", "h_factor=1.2,neighbour_skin=0.02"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--spacing", type=float, default=0.005)
    parser.add_argument("--span", type=float, default=0.25, help="simulated seconds per timed interval")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--variant", nargs="+", default=DEFAULT_VARIANTS, metavar="NAME=VALUE,...")
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks" / "results" / "sph3d_motion.json")
    args = parser.parse_args()
    if not (args.spacing > 0 and args.span > 0 and args.threads >= 1):
        parser.error("--spacing > 0, --span > 0 and --threads >= 1 are required")
    _core.set_num_threads(args.threads)
    config = PlateIntrusion(spacing=args.spacing, fidelity="standard", max_depth=0.04)
    settings = {"defaults": {}} | {text: parse_numerics(text.split(",")) for text in args.variant}
    cores = {name: build_plate_slab(PlateSlab(dataclasses.replace(config, numerics=values))).core
             for name, values in settings.items()}
    for core in cores.values():
        core.advance(config.settle_time, 10**8)
    intervals = max(1, int(config.stroke_time / args.span))
    measured: dict[str, list[dict[str, float]]] = {name: [] for name in cores}
    for index in range(intervals):
        end = config.settle_time + (index + 1) * args.span
        for name in cores if index % 2 == 0 else list(cores)[::-1]:
            core = cores[name]
            step, builds = core.step, core.neighbour_builds
            start = time.process_time()
            core.advance(end, 10**8)
            cpu = time.process_time() - start
            steps = core.step - step
            measured[name].append({"cpu_per_grain_step": cpu / (steps * len(core.mass)), "cpu_per_second": cpu / args.span,
                                   "builds_per_step": (core.neighbour_builds - builds) / steps})
    rows = []
    for name, runs in measured.items():
        per_step = [a["cpu_per_grain_step"] / b["cpu_per_grain_step"] for a, b in zip(measured["defaults"], runs)]
        per_second = [a["cpu_per_second"] / b["cpu_per_second"] for a, b in zip(measured["defaults"], runs)]
        rows.append({"variant": name, "speedup_per_grain_step": statistics.median(per_step),
                     "speedup_per_second": statistics.median(per_second), "speedup_per_second_deepest": per_second[-1],
                     "builds_per_step": statistics.median(r["builds_per_step"] for r in runs),
                     "builds_per_step_deepest": runs[-1]["builds_per_step"],
                     "speedup_per_second_by_interval": per_second, "intervals": runs})
        print(f"{name}: speed-up per grain-step {rows[-1]['speedup_per_grain_step']:.2f}, per simulated second "
              f"{rows[-1]['speedup_per_second']:.2f} (deepest {per_second[-1]:.2f}), builds per step "
              f"{rows[-1]['builds_per_step']:.3f} (deepest {runs[-1]['builds_per_step']:.3f})", flush=True)
    args.output.write_text(json.dumps({
        "provenance": provenance("bench_sph3d_motion.py", str(args.threads)),
        "columns": [["variant", "numerics", "{}"],
                    ["speedup_per_grain_step", "speed-up per grain-step (median over intervals)", "{:.2f}"],
                    ["speedup_per_second", "speed-up per simulated second (median)", "{:.2f}"],
                    ["speedup_per_second_deepest", "per simulated second, last interval (deepest)", "{:.2f}"],
                    ["builds_per_step", "list builds per step (median)", "{:.3f}"],
                    ["builds_per_step_deepest", "list builds per step, last interval", "{:.3f}"]],
        "spacing": args.spacing, "span": args.span, "intervals": intervals, "grains": len(cores["defaults"].mass),
        "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
