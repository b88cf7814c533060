"""gymnasium's hopper on the bed of glass beads and on MuJoCo's floor, driven from Python: standing
(its motors hold the start posture) and one hop (crouch, then straighten at once), docs/mjcf.md.

    python benchmarks/studies/mjcf_hopper.py [--spacing 0.01] [--out-prefix hopper]

Standing: the grains' lift over the hopper's weight in the last fifth of 2 s, the foot's sinkage.
Hop: the rise of the centre of mass above its standing height after the push, on sand and on the
rigid floor, and the hopper's pitch at the end. The model file is gymnasium's, as shipped
(envs/mujoco/assets/hopper.xml).
"""

from __future__ import annotations

import argparse
import json
import os
import time

import gymnasium
import mujoco
import numpy as np
from terrasph.scenes.mjcf_scene import MjcfScene, rigid_floor_run, run_mjcf

MODEL = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets", "hopper.xml")
#: PD gains of the posture controller (N·m/rad, N·m·s/rad); the motors give at most 200 N·m
KP, KD = 3000.0, 150.0
#: the crouch: thigh, knee and ankle angles (rad, MuJoCo's joint coordinates)
CROUCH = np.array([-0.8, -1.4, 0.6])
CROUCH_AT, PUSH_AT = 0.6, 1.3
#: the hop's end: on sand the hopper topples backward after its landing, and its torso, which is not
#: coupled, would then pass through the bed
HOP_END = 1.8


def hop(time: float, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Standing straight, crouched from CROUCH_AT, straight again from PUSH_AT: the motors' ctrl."""
    target = CROUCH if CROUCH_AT <= time < PUSH_AT else np.zeros(3)
    return (-KP * (data.qpos[3:6] - target) - KD * data.qvel[3:6]) / model.actuator_gear[:, 0]


def rise(times: np.ndarray, height: np.ndarray) -> float:
    """The centre of mass's highest point after the push above its mean just before the crouch (m)."""
    standing = height[(times > CROUCH_AT - 0.1) & (times < CROUCH_AT)].mean()
    return float(height[times >= PUSH_AT].max() - standing)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spacing", type=float, default=0.01)
    parser.add_argument("--out-prefix", default=None, help="write PREFIX_stand.h5 and PREFIX_hop.h5 (and PNGs)")
    args = parser.parse_args()
    hold = tuple(f"{j}=hold:{KP},{KD}" for j in ("thigh_joint", "leg_joint", "foot_joint"))
    stand = MjcfScene(model=MODEL, bed_width=1.0, bed_depth=0.1, spacing=args.spacing, settle_time=0.0, t_end=2.0,
                      ctrl=hold)
    jump = MjcfScene(model=MODEL, bed_width=2.0, bed_depth=0.15, spacing=args.spacing, start_x=1.2, settle_time=0.0,
                     t_end=HOP_END)
    out = {name: f"{args.out_prefix}_{name}.h5" if args.out_prefix else None for name in ("stand", "hop")}
    start = time.perf_counter()
    standing = run_mjcf(stand, out["stand"]).summary()
    hopping = run_mjcf(jump, out["hop"], controller=hop)
    wall = time.perf_counter() - start
    _, path = rigid_floor_run(MODEL, hop, HOP_END, timestep=HOP_END / hopping.summary()["steps"])
    com = hopping.series["robot/actuators"]
    print(json.dumps({"stand": standing, "hop": hopping.summary(),
                      "hop_rise_sand_m": rise(com["time"], com["com"][:, 1]),
                      "hop_rise_rigid_m": rise(path[:, 0], path[:, 2]),
                      "hop_final_pitch_sand_rad": float(com["qpos"][-1, 2]), "wall_s": round(wall, 1)}, indent=2))


if __name__ == "__main__":
    main()
