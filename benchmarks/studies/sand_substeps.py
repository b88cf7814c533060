"""The terrain's substeps (terrasph.terrain.attach): MuJoCo's integrator in them and their length, against
the same run at half the step. gymnasium's ``ant.xml`` (RK4 in its file, 0.01 s) on the 3D RFT sand
walks a gentle open-loop trot (every hip and ankle 0.3 sin(2π t + phase), diagonal legs in phase)
for 5 s after 2 s of settling; the result is its travel (m, centre of mass, in the plane) and each
ankle's sinkage at rest before the gait. Deterministic: one run per setting.

    OMP_NUM_THREADS=1 python benchmarks/studies/sand_substeps.py

writes benchmarks/results/sand_substeps.json (machine, date, commit inside) and prints a table.
"""

from __future__ import annotations

import datetime
import json
import logging
import os
import pathlib
import platform
import subprocess

import mujoco
import numpy as np
from gymnasium.envs.mujoco import ant_v5
from terrasph.terrain import attach

ANT = pathlib.Path(ant_v5.__file__).parent / "assets" / "ant.xml"
RESULT = pathlib.Path(__file__).resolve().parents[1] / "results" / "sand_substeps.json"
#: (integrator option, terrain step s)
SETTINGS = (("model", 5e-4), ("model", 1e-3), ("model", 2e-3), ("euler", 5e-4), ("euler", 1e-3), ("euler", 2e-3),
            ("euler", 5e-3))
#: the trot's phases: hip and ankle of each leg, diagonal legs together, each ankle a quarter turn behind its hip
PHASES = np.array([0.0, 0.5, 1.0, 1.5, 0.0, 0.5, 1.0, 1.5]) * np.pi


def gait(time: float) -> np.ndarray:
    """The actuators' commands at `time` (s)."""
    return 0.3 * np.sin(2.0 * np.pi * time + PHASES)


def run(integrator: str, time_step: float) -> dict[str, object]:
    model = mujoco.MjModel.from_xml_path(str(ANT))
    data = mujoco.MjData(model)
    sand = attach(model, data, "rft3d", time_step=time_step, integrator=integrator)
    sand.step(round(2.0 / model.opt.timestep))
    sinkage = sand.sinkage()
    start = data.subtree_com[0].copy()
    for _ in range(round(5.0 / model.opt.timestep)):
        data.ctrl[:] = gait(data.time)
        sand.step()
    travel = data.subtree_com[0][:2] - start[:2]
    ankles = [name for name in sand.bodies if name.startswith("#")]
    return {"integrator": integrator, "time_step": time_step, "travel": travel.tolist(),
            "travel_distance": float(np.hypot(*travel)), "ankle_sinkage_at_rest": [sinkage[a] for a in ankles]}


def main() -> None:
    logging.disable(logging.WARNING)
    rows = [run(*setting) for setting in SETTINGS]
    for row in rows:
        print(f"{row['integrator']:>6} {row['time_step']:.0e} s: travel {row['travel_distance']:.3f} m "
              f"{np.round(row['travel'], 3).tolist()}, ankle sinkage at rest "
              f"{1000 * np.mean(row['ankle_sinkage_at_rest']):.2f} mm")
    root = pathlib.Path(__file__).resolve().parents[2]
    commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    result = {"study": "benchmarks/studies/sand_substeps.py", "command": "OMP_NUM_THREADS=1 python "
              "benchmarks/studies/sand_substeps.py", "date": datetime.datetime.now(datetime.timezone.utc).isoformat(
                  timespec="seconds"), "commit": commit,
              "machine": {"platform": platform.platform(), "logical_cpus": os.cpu_count(),
                          "mujoco": mujoco.__version__}, "rows": rows}
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
