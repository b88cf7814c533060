"""Where a coupled step's wall time goes: the SPH step, MuJoCo, and the coupling (loads out,
kinematics in, Python glue), for the default leg-wheel scene (``LegWheel()``: Δx = 1.67 mm, 50 × 10 cm
bed, reversed C-leg here) or, with ``--coarse``, the README's coarse one (Δx = 5 mm, 30 × 5 cm bed).
The wheel is driven from the start (no pause) for ``--t-end`` simulated seconds.

    python benchmarks/performance/bench_robot_step_shares.py [--coarse] [--t-end T] [threads ...]

Prints, per OpenMP thread count, the wall time per simulated second and the shares.
"""

from __future__ import annotations

import argparse
import time

import mujoco
from terrasph import _core
from terrasph.scenes.leg_wheel import LegWheel, build_leg_wheel

COARSE = LegWheel(wheel="reversed-c-leg", spacing=0.005, thickness=0.015, leg_length=0.05, bed_width=0.3,
                  bed_depth=0.05, start_x=0.1, settle_time=0.0, t_end=0.3)


DEFAULT = LegWheel(wheel="reversed-c-leg", settle_time=0.0)


def shares(config: LegWheel, threads: int, t_end: float) -> dict[str, float]:
    _core.set_num_threads(threads)
    coupled = build_leg_wheel(config).coupling
    coupled.robot.data.ctrl[0] = config.omega
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coarse", action="store_true", help="the README's coarse scene instead of the default")
    parser.add_argument("--t-end", type=float, default=None, help="simulated s (default 0.3 coarse, 0.02 default)")
    parser.add_argument("threads", type=int, nargs="*", default=[1, 2])
    args = parser.parse_args()
    config = COARSE if args.coarse else DEFAULT
    t_end = args.t_end or (0.3 if args.coarse else 0.02)
    print(f"{'coarse' if args.coarse else 'default'} leg-wheel, {t_end} s simulated", flush=True)
    for threads in args.threads:
        r = shares(config, threads, t_end)
        print(f"threads {r['threads']}: {r['steps']} steps, {r['wall_per_simulated_s']:.1f} s wall per simulated s; "
              f"SPH {100 * r['sph']:.1f} %, MuJoCo {100 * r['mujoco']:.1f} %, coupling {100 * r['coupling']:.1f} %",
              flush=True)
