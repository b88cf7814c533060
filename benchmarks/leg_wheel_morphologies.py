"""The five leg-wheels of Fig. 4.2 and the plain wheel in the coarse trial of the README
(Δx = 5 mm, legs 1.5 cm thick and 5 cm long, 30 × 5 cm bed, load 4.9 N, 0.2 s pause, ω = 1.5 rad/s).
A trial of the pipeline at a resolution three times too coarse for the legs' real thickness, not
the dissertation's comparison.

    python benchmarks/leg_wheel_morphologies.py [t_end]
"""

from __future__ import annotations

import sys
import time

from terrasph.robots.leg_wheel import WHEELS, LegWheel, run_leg_wheel

if __name__ == "__main__":
    t_end = float(sys.argv[1]) if len(sys.argv) > 1 else 1.5
    print("wheel            mean v_x (m/s)  mean slip  final sinkage (cm)  max sinkage (cm)  CoT    leaks  wall (s)")
    for wheel in WHEELS:
        start = time.perf_counter()
        config = LegWheel(wheel=wheel, spacing=0.005, thickness=0.015, leg_length=0.05, bed_width=0.3, bed_depth=0.05,
                          start_x=0.1, settle_time=0.2, duration=t_end)
        s = run_leg_wheel(config)["summary"]
        print(f"{wheel:<16} {s['mean_forward_speed']:14.4f}  {s['mean_slip']:9.3f}  {100 * s['final_sinkage']:18.2f}"
              f"  {100 * s['max_sinkage']:16.2f}  {s['cost_of_transport']:5.2f}  {s['leaked_particles']:5d}"
              f"  {time.perf_counter() - start:8.1f}", flush=True)
