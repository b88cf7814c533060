"""Sweep throughput on a LocalCluster: runs per hour with 1 and with 2 process workers (one OpenMP
thread each), interleaved (1, 2, 1, 2, ...), on the same small leg-wheel sweep in fresh directories.
The wall time includes starting the cluster and its workers' imports (what a user waits for).

    python benchmarks/performance/bench_sweep_throughput.py [runs] [rounds]

Sweep: `runs` Latin-hypercube cases of the leg-wheel as in the study (benchmarks/studies/
sweep_leg_wheel_study.yaml: Δx = 1 cm, 6 cm legs 3 cm thick, 35 × 5 cm bed), 0.2 s pause + 0.8 s
driven by a drawn ω(t) schedule.
"""

from __future__ import annotations

import sys
import tempfile
import time

from terrasph.sweeps.runner import run_sweep
from terrasph.sweeps.spec import parse_spec

FIXED = {"spacing": 0.01, "thickness": 0.03, "leg_length": 0.06, "bed_width": 0.35, "bed_depth": 0.05,
         "start_x": 0.1, "settle_time": 0.2, "t_end": 1.0, "frame_interval": 0.5}

if __name__ == "__main__":
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 6
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    spec = parse_spec({"scene": "leg-wheel", "seed": 5, "fixed": FIXED,
                       "design": {"method": "latin-hypercube", "runs": runs,
                                  "vary": {"load": {"range": [2.0, 6.0]}, "wheel": {"values": ["c-leg", "wheel"]}},
                                  "input": {"parameter": "omega_schedule", "range": [0.5, 3.0]}}})
    print("round  workers  wall (s)  runs/hour  mean run wall (s)")
    for round_ in range(rounds):
        for workers in (1, 2):
            with tempfile.TemporaryDirectory() as out:
                start = time.perf_counter()
                manifest = run_sweep(spec, out, workers=workers, progress=False)
                wall = time.perf_counter() - start
            done = [c for c in manifest["cases"] if c["status"] == "completed"]
            mean_run = sum(c["wall_time"] for c in done) / len(done)
            print(f"{round_:5d}  {workers:7d}  {wall:8.1f}  {3600 * len(done) / wall:9.1f}  {mean_run:17.1f}", flush=True)
