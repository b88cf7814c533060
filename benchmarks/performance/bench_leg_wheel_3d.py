"""A narrow leg-wheel on the 3D SPH bed: issue 49's cost figure (docs/sph3d.md#cost).

    OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive python benchmarks/performance/bench_leg_wheel_3d.py
        [--spacing 0.005] [--bed-size 0.5 0.12] [--bed-depth 0.05] [--freeboard 0.05] [--settle 0.5]
        [--omega 1.0] [--t-end 2.0] [--fidelity standard] [--numerics NAME=VALUE ...]
        [--output benchmarks/results/leg_wheel_3d_narrow.json]

terrasph's ``leg_wheel3d.xml`` (python/terrasph/robots/models: chapter 4's rig, a chassis sliding in
x and z carrying 2.45 N, and three C-legs of box geoms, 8 cm hip to toe, 5 cm wide, on a hinge with
a velocity servo) put on a bed of glass beads by ``terrasph.terrain.attach(model, data, "sph3d")``,
the path of any MuJoCo model from Python: the bed ``--bed-size`` (x, y) across, centred under the
wheel (so the wheel, 5 cm wide, is narrower than the bed), ``--bed-depth`` deep, its walls
``--freeboard`` above the grains, at the terrain's default tier unless ``--fidelity``. The wheel is
held (ctrl 0) for ``--settle`` s and then commanded ``--omega`` rad/s to ``--t-end``; the bed is long
enough that the wheel, at no slip, stays a kernel support from its end.

Times the stepping alone (wall seconds, ``time.perf_counter``; CPU seconds of all threads,
``time.process_time``, and of the main thread, ``time.thread_time``: the main thread runs the
serial part, MuJoCo and the coupling, and its share of each parallel phase, so on otherwise idle
cores the wall time is about its CPU time) and writes the particle counts (grains, fixed wall particles, the wheel's
particles), SPH steps, µs per grain-step (wall and CPU), the core's phases' wall seconds
(phase_seconds) and each one's share, the wheel's lift over the rig's weight at the end of the pause, its travel and slip
over the drive, its sinkage (``Terrain.sinkage``: below the undisturbed surface) at the end of the
pause, over the drive and at the end, leaked grains, and the provenance (date, commit, CPU, the load
average before and after: the machine is shared, so the wall time is an upper bound of an idle
machine's).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import terrasph
from terrasph.robots import LEG_WHEEL3D
from terrasph.terrain import attach

ROOT = Path(__file__).resolve().parents[2]
LEG_LENGTH = 0.08  #: m, hip to toe: the wheel's radius in the slip (Eq. 4.8 of chapter 4)
SAMPLE = 0.01  #: s between the samples of the wheel's pose and load


def provenance(load_before: tuple[float, float, float]) -> dict[str, Any]:
    """When, on what and by which command it was measured (no host name), and the machine's load."""
    git = ["git", "-C", str(ROOT)]
    commit = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run([*git, "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                           text=True).stdout.strip()
    cpuinfo = Path("/proc/cpuinfo")
    cpu = next((line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if cpuinfo.exists() else platform.processor()
    return {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": commit + ("+changes" if dirty else ""), "terrasph": terrasph.__version__, "cpu": cpu,
            "cores": os.cpu_count() or 0, "threads": os.environ.get("OMP_NUM_THREADS", "all"),
            "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY", "unset"),
            "load_average_before": list(load_before), "load_average_after": list(os.getloadavg()),
            "command": " ".join(["python", "benchmarks/performance/bench_leg_wheel_3d.py", *sys.argv[1:]])}


def numerics_override(text: str) -> tuple[str, float]:
    """argparse type of ``--numerics``: NAME=VALUE (a number)."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name, float(value)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The run of the module docstring; its figures."""
    model = mujoco.MjModel.from_xml_path(str(LEG_WHEEL3D))
    data = mujoco.MjData(model)
    built = time.perf_counter()
    sand = attach(model, data, "sph3d", spacing=args.spacing, bed_size=tuple(args.bed_size),
                  bed_depth=args.bed_depth, freeboard=args.freeboard, fidelity=args.fidelity,
                  numerics=dict(args.numerics) or None)
    build_seconds = time.perf_counter() - built
    core = sand.coupling.core
    body = np.asarray(core.wall_body) >= 0
    weight = float(model.body_subtreemass[1]) * -float(model.opt.gravity[2])
    per_sample = round(SAMPLE / model.opt.timestep)
    samples: list[dict[str, float]] = []
    wall, cpu, main = time.perf_counter(), time.process_time(), time.thread_time()
    t = 0.0
    while t < args.t_end - 1e-9:
        data.ctrl[0] = 0.0 if t < args.settle - 1e-9 else args.omega
        sand.step(per_sample)
        t = float(data.time)
        samples.append({"time": t, "x": float(data.qpos[0]), "z": float(data.qpos[1]),
                        "omega": float(data.qvel[2]), "sinkage": sand.sinkage()["wheel"],
                        "lift_over_weight": float(sand.loads()["wheel"][2]) / weight})
    wall, cpu, main = time.perf_counter() - wall, time.process_time() - cpu, time.thread_time() - main
    times = np.array([s["time"] for s in samples])
    pause_end = samples[int(np.searchsorted(times, args.settle - 1e-9))]
    before = [s for s in samples if args.settle - 0.1 - 1e-9 <= s["time"] <= args.settle + 1e-9]
    drive = [s for s in samples if s["time"] > args.settle + 1e-9]
    travel = samples[-1]["x"] - pause_end["x"]
    spin = float(np.mean([s["omega"] for s in drive]))
    grains, steps = len(core.mass), int(core.step)
    seconds = dict(core.phase_seconds)
    total = sum(seconds.values()) or 1.0
    return {"spacing": args.spacing, "fidelity": args.fidelity, "numerics_overrides": dict(args.numerics),
            "bed_size": list(sand.coupling.bed.size), "settle": args.settle, "omega": args.omega,
            "t_end": args.t_end, "simulated": samples[-1]["time"],
            "grains": grains, "fixed_wall_particles": int((~body).sum()), "wheel_particles": int(body.sum()),
            "particles": grains + len(body), "sph_steps": steps, "build_seconds": build_seconds,
            "wall_seconds": wall, "cpu_seconds": cpu, "main_thread_cpu_seconds": main,
            "wall_us_per_grain_step": 1e6 * wall / (grains * steps), "cpu_us_per_grain_step": 1e6 * cpu / (grains * steps),
            "core_phase_seconds": seconds, "phase_shares": {name: value / total for name, value in seconds.items()},
            "lift_over_weight_last_0.1s_of_pause": float(np.mean([s["lift_over_weight"] for s in before])),
            "lift_over_weight_drive": float(np.mean([s["lift_over_weight"] for s in drive])),
            "travel": travel, "mean_omega_drive": spin,
            "slip": 1.0 - travel / (drive[-1]["time"] - pause_end["time"]) / (spin * LEG_LENGTH),
            "sinkage_end_of_pause": pause_end["sinkage"],
            "sinkage_drive_mean": float(np.mean([s["sinkage"] for s in drive])),
            "sinkage_drive_max": float(np.max([s["sinkage"] for s in drive])), "sinkage_end": samples[-1]["sinkage"],
            "leaked_grains": sand.leaked_grains, "series": samples}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--spacing", type=float, default=0.005)
    parser.add_argument("--bed-size", type=float, nargs=2, default=[0.5, 0.12])
    parser.add_argument("--bed-depth", type=float, default=0.05)
    parser.add_argument("--freeboard", type=float, default=0.05)
    parser.add_argument("--settle", type=float, default=0.5)
    parser.add_argument("--omega", type=float, default=1.0)
    parser.add_argument("--t-end", type=float, default=2.0)
    parser.add_argument("--fidelity", default="standard")
    parser.add_argument("--numerics", type=numerics_override, nargs="*", default=[])
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks" / "results" / "leg_wheel_3d_narrow.json")
    args = parser.parse_args()
    load = os.getloadavg()
    result = run(args)
    print(json.dumps({k: v for k, v in result.items() if k != "series"}, indent=1), flush=True)
    args.output.write_text(json.dumps({"provenance": provenance(load), **result}, indent=1) + "\n")
    print(args.output)


if __name__ == "__main__":
    main()
