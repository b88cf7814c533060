"""Thread count on a shared machine: 2 threads against 1, idle and with a
competing CPU-bound process, under terrasph's default wait (a bounded spin), sleeping threads
(passive) and a spinning one (active, what the OpenMP runtime did before terrasph set the policy).

    python benchmarks/performance/bench_threads.py [--size 8000] [--steps 300] [--repeats 3] [--policies default passive active]
    python benchmarks/performance/bench_threads.py --late 3 [--simulated 0.3] [--size 8000] [--repeats 3]

Each case runs in a fresh process (the OpenMP runtime reads its wait policy once): a bed of dry
glass beads at rest (benchmarks/performance/bench_sph.py) stepped `--steps` steps after a warm-up; the figure
is the median wall time of `--repeats`. The competitor is a Python busy loop pinned to nothing.
Also printed: the thread count terrasph picks by default in each situation. With ``--late``: a
run (the run loop, ``Simulation.run``) that starts on an idle machine and meets a CPU-bound
process `--late` seconds in, with terrasph's defaults, with a thread count the user set (no load
watch), the same with the long spin, and on 1 thread; its wall time and the competitor's share of
a core while they overlap.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from terrasph.threads import LONG_SPIN

CHILD = """
import sys, time
sys.path.insert(0, {bench_dir!r})
import terrasph
from terrasph import _core
from terrasph.threads import default_threads
from terrasph.config import Material, Numerics
import bench_sph
picked = _core.get_max_threads()
_core.set_num_threads({threads})
sim = bench_sph.bed({size}, Material(), Numerics(spacing=bench_sph.SPACING))
sim.advance(1e9, max_steps=20)
start = time.perf_counter()
sim.advance(1e9, max_steps={steps})
print(time.perf_counter() - start, picked)
"""

BUSY_LOOP = "while True:\n    pass\n"

LATE_CHILD = """
import subprocess, sys, threading, time
sys.path.insert(0, {bench_dir!r})
import terrasph
from terrasph import _core
from terrasph.config import Material, Numerics
import bench_sph
picked = _core.get_max_threads()
sim = bench_sph.bed({size}, Material(), Numerics(spacing=bench_sph.SPACING))
sim.advance(1e9, max_steps=20)
competitor = []
timer = threading.Timer({late}, lambda: competitor.append((subprocess.Popen([sys.executable, "-c", {busy!r}]),
                                                             time.perf_counter())))
start = time.perf_counter()
timer.start()
sim.run(sim.time + {simulated}, progress=False)
wall = time.perf_counter() - start
timer.cancel()
share = float("nan")
if competitor:
    process, since = competitor[0]
    with open(f"/proc/{{process.pid}}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    share = (int(fields[11]) + int(fields[12])) / 100 / (time.perf_counter() - since)
    process.kill()
print(wall, picked, _core.get_max_threads(), share)
"""


def run_case(threads: int, policy: str, size: int, steps: int) -> tuple[float, int]:
    """(seconds for `steps` steps, default thread count picked at import) in a fresh process."""
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    if policy.startswith("spin"):  # spinN: libgomp's spin-then-sleep, N polls
        env["GOMP_SPINCOUNT"] = policy[len("spin"):]
    elif policy != "default":  # default: terrasph's own (terrasph/__init__.py)
        env["OMP_WAIT_POLICY"] = policy
    code = CHILD.format(bench_dir=str(Path(__file__).parent), threads=threads, size=size, steps=steps)
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
    seconds, picked = out.stdout.split()
    return float(seconds), int(picked)


def late_competitor(size: int, simulated: float, late: float, repeats: int) -> None:
    """A run that starts alone and meets a CPU-bound process `late` s in: terrasph's default (the
    threads and spin chosen at import, the load watch of the run loop), a count set by the user
    (no watch, the short spin), the same with the long spin, and 1 thread."""
    print(f"{os.cpu_count()} cores; {size} particles, {simulated} simulated s, a competitor from {late} s, "
          f"median of {repeats}")
    print("| case | wall (s) | threads at start → end | competitor's share of a core |")
    print("|---|---|---|---|")
    picked_now = str(os.cpu_count() or 1)
    cases = {"default (count and long spin chosen at import, load watch)": {},
             "OMP_NUM_THREADS = all cores (the user's count: short spin, no watch)": {"OMP_NUM_THREADS": picked_now},
             "the same with the long spin (GOMP_SPINCOUNT = LONG_SPIN)": {"OMP_NUM_THREADS": picked_now,
                                                                         "GOMP_SPINCOUNT": str(LONG_SPIN)},
             "1 thread": {"OMP_NUM_THREADS": "1"}}
    for name, extra in cases.items():
        env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
        env.update(extra)
        code = LATE_CHILD.format(bench_dir=str(Path(__file__).parent), size=size, simulated=simulated, late=late,
                                 busy=BUSY_LOOP)
        rows = []
        for _ in range(repeats):
            out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
            wall, start_threads, end_threads, share = out.stdout.split()
            rows.append((float(wall), start_threads, end_threads, float(share)))
        wall = statistics.median(r[0] for r in rows)
        share = statistics.median(r[3] for r in rows)
        print(f"| {name} | {wall:.1f} | {rows[0][1]} → {rows[0][2]} | {share:.2f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=8000, help="granular particles")
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--policies", nargs="+", default=["default", "passive", "active"],
                        help="OMP_WAIT_POLICY values, spinN (GOMP_SPINCOUNT=N) or default (terrasph's own)")
    parser.add_argument("--late", type=float, default=None, metavar="SECONDS",
                        help="instead: a run that meets a competing process SECONDS after it starts")
    parser.add_argument("--simulated", type=float, default=0.3, help="simulated seconds of the --late run")
    args = parser.parse_args()
    if args.late is not None:
        late_competitor(args.size, args.simulated, args.late, args.repeats)
        return
    print(f"{os.cpu_count()} cores; {args.size} particles, {args.steps} steps, median of {args.repeats}")
    print("| machine | wait policy | 1 thread (s) | 2 threads (s) | speed-up 2 vs 1 | default threads picked |")
    print("|---|---|---|---|---|---|")
    for machine in ("idle", "one competing CPU-bound process"):
        competitor = None
        if machine != "idle":
            competitor = subprocess.Popen([sys.executable, "-c", BUSY_LOOP])
            time.sleep(0.5)
        try:
            for policy in args.policies:
                timings: dict[int, list[float]] = {1: [], 2: []}
                picked = []
                for _ in range(args.repeats):
                    for threads in (1, 2):  # interleaved, so drifts in machine load hit both
                        seconds, default = run_case(threads, policy, args.size, args.steps)
                        timings[threads].append(seconds)
                        picked.append(default)
                one, two = (statistics.median(timings[n]) for n in (1, 2))
                print(f"| {machine} | {policy} | {one:.2f} | {two:.2f} | {one / two:.2f}× | "
                      f"{statistics.median(picked):g} |", flush=True)
        finally:
            if competitor is not None:
                competitor.kill()
                competitor.wait()


if __name__ == "__main__":
    main()
