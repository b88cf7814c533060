"""Where a coupled step's wall time goes: the SPH step, MuJoCo, and the coupling (loads out,
kinematics in, Python glue), for the README's coarse leg-wheel (Δx = 5 mm, 30 × 5 cm bed).

    python benchmarks/bench_robot_step_shares.py [threads ...]

Prints, per OpenMP thread count, the wall time per simulated second and the shares.
"""

from __future__ import annotations

import sys
import time

import mujoco

from terrasph import _core
from terrasph.robots.leg_wheel import LegWheel, build_leg_wheel

CONFIG = LegWheel(wheel="reversed-c-leg", spacing=0.005, thickness=0.015, leg_length=0.05, bed_width=0.3,
                  bed_depth=0.05, start_x=0.1, settle_time=0.0, duration=0.3)


def shares(threads: int, t_end: float = 0.3) -> dict[str, float]:
    _core.set_num_threads(threads)
    coupled = build_leg_wheel(CONFIG)
    coupled.robot.data.ctrl[0] = CONFIG.omega
    clock = {"sph": 0.0, "mujoco": 0.0}
    advance, step = coupled.sim.advance, mujoco.mj_step

    def timed_advance(*args, **kwargs):
        start = time.perf_counter()
        try:
            return advance(*args, **kwargs)
        finally:
            clock["sph"] += time.perf_counter() - start

    def timed_step(*args):
        start = time.perf_counter()
        try:
            return step(*args)
        finally:
            clock["mujoco"] += time.perf_counter() - start

    coupled.sim.advance = timed_advance
    mujoco.mj_step = timed_step
    try:
        start = time.perf_counter()
        coupled.advance(t_end)
        total = time.perf_counter() - start
    finally:
        mujoco.mj_step = step
    return {"threads": threads, "steps": coupled.sim.step_count, "wall_per_simulated_s": total / coupled.time,
            "sph": clock["sph"] / total, "mujoco": clock["mujoco"] / total,
            "coupling": 1 - (clock["sph"] + clock["mujoco"]) / total}


if __name__ == "__main__":
    for threads in [int(t) for t in sys.argv[1:]] or [1, 2]:
        r = shares(threads)
        print(f"threads {r['threads']}: {r['steps']} steps, {r['wall_per_simulated_s']:.1f} s wall per simulated s; "
              f"SPH {100 * r['sph']:.1f} %, MuJoCo {100 * r['mujoco']:.1f} %, coupling {100 * r['coupling']:.1f} %",
              flush=True)
