"""gymnasium's ``ant.xml``, unmodified, at rest on the 3D SPH bed of ``attach(terrain="sph3d")``
(docs/sph3d.md, docs/terrain.md): lift / weight over windows of 0.25 s, the torso's height and
vertical speed, leaked grains; and the four-wheeled rover (terrasph's ``rover4.xml``) driving on it.

    OMP_NUM_THREADS=1 python benchmarks/validation/ant_sph3d.py [--spacings 0.05 0.04] [--t-end 3]
        [--rover-spacing 0.015] [--out benchmarks/results/ant_sph3d.json]

The ant first settles 2 s on MuJoCo's own floor with its actuators idle (its legs come to rest on
their joint limits), then is attached to the bed (the floor's contacts off) and runs `--t-end` s,
actuators still idle. The load is each step's mean of the coupled bodies' vertical loads, averaged
over the window.
"""

from __future__ import annotations

import argparse
import datetime
import json
import pathlib
import platform
import subprocess
import time

import gymnasium
import mujoco
import numpy as np
from terrasph.terrain import attach

ANT = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml"
WINDOW = 0.25  # s


def provenance() -> dict[str, str]:
    """Machine, date and commit of the run."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True,
                                cwd=pathlib.Path(__file__).parent).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    return {"machine": f"{platform.node()} {platform.machine()} {platform.processor() or ''}".strip(),
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": commit, "mujoco": mujoco.__version__}


def measure(spacing: float, t_end: float) -> dict:
    """One ant at rest on a bed at `spacing` (m) for `t_end` (s)."""
    model = mujoco.MjModel.from_xml_path(str(ANT))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, round(2.0 / model.opt.timestep))
    sand = attach(model, data, "sph3d", spacing=spacing)
    weight = float(model.body_subtreemass[0]) * 9.81
    per_window = round(WINDOW / model.opt.timestep)
    windows = []
    start = time.perf_counter()
    for k in range(round(t_end / WINDOW)):
        lift = []
        for _ in range(per_window):
            sand.step()
            lift.append(sum(load[2] for load in sand.loads().values()))
        windows.append({"end": (k + 1) * WINDOW, "lift_over_weight": float(np.mean(lift)) / weight,
                        "torso_z": float(data.qpos[2]), "torso_vz": float(data.qvel[2])})
    core = sand.coupling.core
    return {"spacing": spacing, "grains": len(core.mass), "wall_particles": len(core.wall_position),
            "sph_steps": int(core.step), "leaked_grains": sand.leaked_grains,
            "wall_seconds": time.perf_counter() - start, "windows": windows}


ROVER = pathlib.Path(__file__).parents[2] / "python" / "terrasph" / "robots" / "models" / "rover4.xml"


def rover(spacing: float, settle: float = 0.5, drive: float = 1.0, spin: float = 3.0) -> dict:
    """The rover dropped 5 mm onto a bed 10 cm deep at `spacing` (m), left `settle` s, then its four
    wheels commanded `spin` rad/s for `drive` s: travel, slip 1 − v/(ω R), the chassis' sinking,
    lift / weight over the drive, leaked grains."""
    model = mujoco.MjModel.from_xml_path(str(ROVER))
    data = mujoco.MjData(model)
    sand = attach(model, data, "sph3d", spacing=spacing, bed_depth=0.1, bed_margin=0.25)
    weight = float(model.body_subtreemass[0]) * 9.81
    start = time.perf_counter()
    sand.step(round(settle / model.opt.timestep))
    x0, z0 = float(data.qpos[0]), float(data.qpos[2])
    data.ctrl[:] = spin
    lift = []
    for _ in range(round(drive / 0.05)):
        sand.step(round(0.05 / model.opt.timestep))
        lift.append(sum(load[2] for load in sand.loads().values()) / weight)
    travel = float(data.qpos[0]) - x0
    core = sand.coupling.core
    return {"spacing": spacing, "grains": len(core.mass), "wall_particles": len(core.wall_position),
            "settle": settle, "drive": drive, "spin": spin, "travel": travel,
            "slip": 1.0 - travel / drive / (spin * 0.06), "chassis_sinking_while_driving": z0 - float(data.qpos[2]),
            "lift_over_weight_mean": float(np.mean(lift)), "lift_over_weight_range": [min(lift), max(lift)],
            "leaked_grains": sand.leaked_grains, "wall_seconds": time.perf_counter() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacings", type=float, nargs="+", default=[0.05, 0.04])
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--rover-spacing", type=float, default=0.015)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("benchmarks/results/ant_sph3d.json"))
    args = parser.parse_args()
    runs = []
    for spacing in args.spacings:
        runs.append(measure(spacing, args.t_end))
        print(json.dumps({k: v for k, v in runs[-1].items() if k != "windows"}), flush=True)
        for window in runs[-1]["windows"]:
            print(f"  t {window['end']:.2f} s  lift/weight {window['lift_over_weight']:.4f}  torso z "
                  f"{window['torso_z']:.4f} m  vz {window['torso_vz']:+.4f} m/s", flush=True)
    driven = rover(args.rover_spacing)
    print(json.dumps(driven), flush=True)
    result = {**provenance(), "threads": "OMP_NUM_THREADS as run", "t_end": args.t_end, "window": WINDOW,
              "runs": runs, "rover": driven}
    args.out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
