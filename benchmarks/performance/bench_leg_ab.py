"""Interleaved A/B of the default rotating-leg scene (or the coarse leg-wheel) between two
installs of terrasph, in one run on one machine: wall time per simulated second, the measure of
the speed work.

    python benchmarks/performance/bench_leg_ab.py --a-python VENV_A/bin/python --b-python VENV_B/bin/python \\
        [--a-numerics KEY=VALUE ...] [--b-numerics KEY=VALUE ...] [--a-env NAME=VALUE ...] [--b-env ...] \\
        [--threads 2] [--rounds 2] [--until 3.0] [--scene leg|leg-wheel|leg-wheel-default]

Each side is a Python interpreter whose environment has a terrasph installed (for the reference,
a venv with an earlier commit built into it: ``python -m venv A && A/bin/pip install
<dependencies> && A/bin/pip install --no-build-isolation <a checkout of that commit>``); the
numerics options are passed to each side's scene (``mass_scaling=16``), the environment
variables to its process (``GOMP_SPINCOUNT=30000``). Each round runs the
scene once with A and once with B, in alternating order, each in its own process, on `--threads`
threads under each side's own default wait policy, up to `--until` simulated seconds (the whole
run, 9.85 s, with ``--until 0``; then the peak lift and thrust are printed too). The cost per
simulated second of a stretch of the run stands for the whole run's only as far as its steps
do: the step count per simulated second is printed, and it holds within 1 % over the run (the
step is bound by the sound speed, the grains' speeds are small against it). ``--scene leg-wheel``:
the second round's coarse leg-wheel (docs/archive/speed_history.md; Δx = 5 mm, 3 s with ``--until 0``), its
mean slip, mean sinkage and final sinkage when the install's summary has them; ``--scene
leg-wheel-default``: the same scene at its default resolution (Δx = 1.67 mm, 6 s with ``--until 0``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess

from bench_sph import parse_numerics

CHILD = {"leg": """
import json, time
from terrasph import _core
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation
_core.set_num_threads({threads})
config = LegRotation(numerics={numerics!r})
until = {until!r} or None
start, cpu = time.perf_counter(), time.process_time()
result = run_leg_rotation(config, output=None, progress=False, plot=False, until=until)
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
simulated = until or config.duration
summary = result.summary() if until is None else {{}}
print(json.dumps({{"wall": wall, "cpu": cpu, "simulated": simulated, "steps": result.run.steps,
                  "outcome": [summary.get("peak_lift"), summary.get("peak_thrust")]}}))
""",
         # the second round's coarse leg-wheel (Δx = 5 mm, legs 1.5 cm thick, a 1 s pause); older
         # installs return a plain summary dict and take no `plot`
         "leg-wheel": """
import json, time
from terrasph import _core
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel
_core.set_num_threads({threads})
wheel = LegWheel(spacing=0.005, thickness=0.015, settle_time=1.0, t_end={until!r} or 3.0, numerics={numerics!r})
start, cpu = time.perf_counter(), time.process_time()
try:
    result = run_leg_wheel(wheel, plot=False)
except TypeError:
    result = run_leg_wheel(wheel)
wall, cpu = time.perf_counter() - start, time.process_time() - cpu
summary = result.summary() if hasattr(result, "summary") else {{}}
print(json.dumps({{"wall": wall, "cpu": cpu, "simulated": wheel.t_end, "steps": summary.get("steps", 0),
                  "outcome": [summary.get("mean_slip"), summary.get("mean_sinkage"), summary.get("final_sinkage")]}}))
"""}
# chapter 4's leg-wheel at its default resolution (LegWheel(): Δx = 1.67 mm, 18 000 grains, C-leg wheel,
# 2 s pause, 6 s with ``--until 0``)
_COARSE_WHEEL = "spacing=0.005, thickness=0.015, settle_time=1.0, t_end={until!r} or 3.0"
assert _COARSE_WHEEL in CHILD["leg-wheel"]  # else the default scene would silently run coarse
CHILD["leg-wheel-default"] = CHILD["leg-wheel"].replace(_COARSE_WHEEL, "t_end={until!r} or 6.0")


def run_side(scene: str, python: str, threads: int, numerics: dict, until: float, env: dict[str, str]) -> dict:
    """One run of `scene` in a fresh process of `python`, with `env` added to this environment."""
    code = CHILD[scene].format(threads=threads, numerics=numerics, until=until)
    out = subprocess.run([python, "-c", code], check=True, capture_output=True, text=True,
                         env={**os.environ, **env}).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", choices=sorted(CHILD), default="leg")
    parser.add_argument("--a-python", required=True, help="interpreter of the reference install (A)")
    parser.add_argument("--b-python", required=True, help="interpreter of the install measured (B)")
    parser.add_argument("--a-numerics", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--b-numerics", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--a-env", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--b-env", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--until", type=float, default=3.0, help="simulated seconds; 0 = the whole run")
    args = parser.parse_args()
    if args.threads < 1 or args.rounds < 1 or args.until < 0:
        parser.error("--threads and --rounds must be >= 1 and --until >= 0")
    sides = {"A": (args.a_python, parse_numerics(args.a_numerics), dict(p.split("=", 1) for p in args.a_env)),
             "B": (args.b_python, parse_numerics(args.b_numerics), dict(p.split("=", 1) for p in args.b_env))}
    per_second: dict[str, list[float]] = {"A": [], "B": []}
    outcome = "peak lift (N) | peak thrust (N)" if args.scene == "leg" else "mean slip | mean sinkage (m) | final sinkage (m)"
    print(f"| round | side | steps per sim. s | wall s per sim. s | CPU s per sim. s | {outcome} |")
    print("|---" * (5 + outcome.count("|") + 1) + "|")
    for round_ in range(args.rounds):
        order = ("A", "B") if round_ % 2 == 0 else ("B", "A")
        for side in order:
            python, numerics, env = sides[side]
            r = run_side(args.scene, python, args.threads, numerics, args.until, env)
            per_second[side].append(r["wall"] / r["simulated"])
            peaks = [f"{v:.4g}" if v is not None else "—" for v in r["outcome"]]
            print(f"| {round_ + 1} | {side} | {r['steps'] / r['simulated']:.0f} | {r['wall'] / r['simulated']:.1f} "
                  f"| {r['cpu'] / r['simulated']:.1f} | {' | '.join(peaks)} |", flush=True)
    a, b = (statistics.median(per_second[s]) for s in ("A", "B"))
    print(f"\nmedian wall s per simulated s: A {a:.1f}, B {b:.1f}; A/B = {a / b:.2f}x less wall time with B")


if __name__ == "__main__":
    main()
