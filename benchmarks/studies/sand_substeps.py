"""The 3D RFT terrain's substeps (terrasph.terrain.attach, terrasph.gym.OnSand): their length against a
converged reference (``--reference-step``, 0.25 ms), on the outcomes a user of gymnasium's ``Ant-v5``
reads.

gymnasium's ``ant.xml`` unmodified (RK4, 0.01 s in its file; the terrain's substeps are Euler, and at
``--model-integrator`` substeps also the file's RK4: attach's option ``integrator``),
from the file's pose with Ant-v5's reset noise drawn from each seed (qpos + U(−0.1, 0.1), qvel +
0.1 N(0, 1)), dropped on the generic sand and settled 1 s with zero actions, then driven 2 s with
the commands held 0.05 s (Ant-v5's control interval):

* ``rest``: the settling of the file's pose without noise, 2 s: the four ankles' mean sinkage and the
  sand's vertical load over the last 0.5 s over the weight (deterministic: one run);
* ``random``: uniform random actions in [−1, 1] (seeded): the torso's horizontal travel (m) and the
  deepest ankle sinkage (m, over the drive);
* ``gait``: an open-loop trot (every hip and ankle 0.3 sin(2π t + phase), diagonal legs in phase): the
  same two outcomes.

A single trajectory is chaotic (a random walk of this 0.91 kg ant under 150 N m motors parts by
decimetres under a change of the last bits), so ``random`` and ``gait`` are read as distributions over
the seeds: each setting's mean and standard deviation, and its mean's difference from the
reference's with the standard error of that difference.

    OMP_NUM_THREADS=1 python benchmarks/studies/sand_substeps.py [--seeds 12] [--steps 1e-3 2e-3 2.5e-3 5e-3 1e-2] [--model-integrator 5e-3]

writes benchmarks/results/sand_substeps.json (machine, date, commit inside) and prints a table.
"""

from __future__ import annotations

import argparse
import datetime
import json
import logging
import math
import os
import pathlib
import platform
import subprocess
import time

import mujoco
import numpy as np
import terrasph
from gymnasium.envs.mujoco import ant_v5
from terrasph.terrain import attach

ANT = pathlib.Path(ant_v5.__file__).parent / "assets" / "ant.xml"
RESULT = pathlib.Path(__file__).resolve().parents[1] / "results" / "sand_substeps.json"
#: the trot's phases: hip and ankle of each leg, diagonal legs together, each ankle a quarter turn behind its hip
PHASES = np.array([0.0, 0.5, 1.0, 1.5, 0.0, 0.5, 1.0, 1.5]) * np.pi
#: Ant-v5's control interval (s), the settling before the drive and the drive (s)
CONTROL_INTERVAL, SETTLE, DRIVE, REST = 0.05, 1.0, 2.0, 2.0


def gait(time_now: float) -> np.ndarray:
    """The trot's commands at `time_now` (s)."""
    return 0.3 * np.sin(2.0 * np.pi * time_now + PHASES)


def _ant(time_step: float, seed: int | None, integrator: str = "euler") -> tuple[mujoco.MjModel, mujoco.MjData, object]:
    model = mujoco.MjModel.from_xml_path(str(ANT))
    data = mujoco.MjData(model)
    if seed is not None:  # Ant-v5's reset noise
        rng = np.random.default_rng(seed)
        data.qpos[:] = model.qpos0 + rng.uniform(-0.1, 0.1, model.nq)
        data.qvel[:] = 0.1 * rng.standard_normal(model.nv)
    sand = attach(model, data, "rft3d", time_step=time_step, integrator=integrator)
    return model, data, sand


def _ankles(sand: object) -> list[str]:
    return [name for name in sand.bodies if name.endswith("ankle")]


def rest(time_step: float, integrator: str) -> dict[str, float]:
    """The file's pose settled on the sand: ankle sinkage (m, mean of four) and lift / weight over the last 0.5 s."""
    model, _data, sand = _ant(time_step, None, integrator)
    per = round(CONTROL_INTERVAL / model.opt.timestep)
    weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
    lift = []
    for k in range(round(REST / CONTROL_INTERVAL)):
        sand.step(per)
        if (k + 1) * CONTROL_INTERVAL > REST - 0.5:
            lift.append(sum(load[2] for load in sand.loads().values()))
    sinkage = sand.sinkage()
    return {"ankle_sinkage": float(np.mean([sinkage[a] for a in _ankles(sand)])),
            "lift_over_weight": float(np.mean(lift) / weight)}


def rollout(time_step: float, seed: int, policy: str, integrator: str) -> dict[str, float]:
    """Settled 1 s, then driven 2 s by `policy` (random or gait): travel (m) and deepest ankle sinkage (m)."""
    model, data, sand = _ant(time_step, seed, integrator)
    per = round(CONTROL_INTERVAL / model.opt.timestep)
    sand.step(round(SETTLE / model.opt.timestep))
    start = data.xpos[1, :2].copy()
    actions = np.random.default_rng(1000 + seed).uniform(-1.0, 1.0, (round(DRIVE / CONTROL_INTERVAL), model.nu))
    deepest = -math.inf
    ankles = _ankles(sand)
    for action in actions:
        data.ctrl[:] = action if policy == "random" else gait(data.time)
        sand.step(per)
        sinkage = sand.sinkage()
        deepest = max(deepest, max(sinkage[a] for a in ankles))
    return {"travel": float(np.linalg.norm(data.xpos[1, :2] - start)), "deepest_sinkage": deepest}


def _stats(values: list[float]) -> dict[str, float]:
    return {"mean": float(np.mean(values)), "std": float(np.std(values, ddof=1)), "values": values}


def setting(time_step: float, seeds: int, integrator: str = "euler") -> dict[str, object]:
    """One substep's outcomes (attach's option `integrator` in the substeps) and the CPU time (s) they took."""
    start = time.process_time()
    row: dict[str, object] = {"time_step": time_step, "integrator": integrator, "rest": rest(time_step, integrator)}
    for policy in ("random", "gait"):
        runs = [rollout(time_step, seed, policy, integrator) for seed in range(seeds)]
        row[policy] = {key: _stats([r[key] for r in runs]) for key in ("travel", "deepest_sinkage")}
    row["cpu_s"] = time.process_time() - start
    return row


def against(row: dict, reference: dict, seeds: int) -> dict[str, object]:
    """The setting's errors against the reference: at rest (m, and lift/weight), and per policy and
    outcome the mean's difference, relative to the reference mean, with the standard error of the difference."""
    errors: dict[str, object] = {
        "rest_sinkage_m": row["rest"]["ankle_sinkage"] - reference["rest"]["ankle_sinkage"],
        "rest_lift_over_weight": row["rest"]["lift_over_weight"]}
    for policy in ("random", "gait"):
        for key in ("travel", "deepest_sinkage"):
            a, b = row[policy][key], reference[policy][key]
            difference = a["mean"] - b["mean"]
            errors[f"{policy}_{key}_rel"] = difference / b["mean"]
            errors[f"{policy}_{key}_se_rel"] = math.sqrt((a["std"] ** 2 + b["std"] ** 2) / seeds) / b["mean"]
    return errors


#: the table docs/terrain.md shows (docs/hooks/generated_tables.py): key, heading, format
COLUMNS = [["substep_ms", "substep (ms)", "{:g}"], ["integrator", "substeps' integrator", "{}"], ["rest_sinkage_mm", "at rest: ankle sinkage (mm)", "{:.2f}"],
           ["rest_lift_over_weight", "at rest: lift / weight", "{:.4f}"],
           ["random_travel_error", "random: travel", "{:+.1%}"], ["random_travel_se", "±", "{:.1%}"],
           ["random_sinkage_error", "random: deepest sinkage", "{:+.1%}"], ["random_sinkage_se", "±", "{:.1%}"],
           ["gait_travel_error", "trot: travel", "{:+.1%}"], ["gait_travel_se", "±", "{:.1%}"],
           ["gait_sinkage_error", "trot: deepest sinkage", "{:+.1%}"], ["gait_sinkage_se", "±", "{:.1%}"]]


def table_row(row: dict) -> dict[str, float]:
    """A setting's row of :data:`COLUMNS`: at rest its values, driven its means' differences from the
    reference's over the reference's (0 on the reference's own row) with their standard errors."""
    errors = row.get("errors", {})
    flat = {"substep_ms": 1e3 * row["time_step"], "integrator": "the model's (RK4)" if row["integrator"] == "model"
            else "Euler", "rest_sinkage_mm": 1e3 * row["rest"]["ankle_sinkage"],
            "rest_lift_over_weight": row["rest"]["lift_over_weight"]}
    for policy in ("random", "gait"):
        for key, name in (("travel", "travel"), ("deepest_sinkage", "sinkage")):
            flat[f"{policy}_{name}_error"] = errors.get(f"{policy}_{key}_rel", 0.0)
            flat[f"{policy}_{name}_se"] = errors.get(f"{policy}_{key}_se_rel", 0.0)
    return flat


def provenance(command: str) -> dict[str, object]:
    root = pathlib.Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit, dirty = "unknown", ""
    cpu = next((line.split(":", 1)[1].strip() for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if pathlib.Path("/proc/cpuinfo").exists() \
        else platform.processor()
    return {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "terrasph": terrasph.__version__,
            "commit": commit + ("+dirty" if dirty else ""), "cpu": cpu, "cores": os.cpu_count(),
            "threads": os.environ.get("OMP_NUM_THREADS"), "command": command, "mujoco": mujoco.__version__,
            "platform": platform.platform()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--steps", nargs="+", type=float, default=[1e-3, 2e-3, 2.5e-3, 5e-3, 1e-2])
    parser.add_argument("--reference-step", type=float, default=2.5e-4)
    parser.add_argument("--model-integrator", nargs="*", type=float, default=[5e-3],
                        help="substeps (s) also run with the model's own integrator (attach's integrator='model')")
    parser.add_argument("--out", type=pathlib.Path, default=RESULT)
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    command = (f"OMP_NUM_THREADS=1 python benchmarks/studies/sand_substeps.py --seeds {args.seeds} --steps "
               + " ".join(f"{s:g}" for s in args.steps) + f" --reference-step {args.reference_step:g} --model-integrator "
               + " ".join(f"{s:g}" for s in args.model_integrator))
    meta = provenance(command)  # before the first write of the (tracked) result file
    reference = setting(args.reference_step, args.seeds)
    rows = [{**reference, "reference": True}]
    unstable: list[dict[str, object]] = []
    for step, integrator in [(step, "euler") for step in args.steps] + [(s, "model") for s in args.model_integrator]:
        try:
            row = setting(step, args.seeds, integrator)
        except terrasph.InstabilityError as error:  # MuJoCo could not integrate a state: the setting is unusable
            unstable.append({"time_step": step, "integrator": integrator, "error": str(error)})
            print(f"{integrator} {1e3 * step:5.2f} ms: unstable: {error}", flush=True)
            continue
        row["errors"] = against(row, reference, args.seeds)
        rows.append(row)
        e = row["errors"]
        print(f"{integrator} {1e3 * step:5.2f} ms: rest sinkage {1e3 * e['rest_sinkage_m']:+.2f} mm, lift/W "
              f"{e['rest_lift_over_weight']:.3f}; random travel {100 * e['random_travel_rel']:+.1f} ± "
              f"{100 * e['random_travel_se_rel']:.1f} %, sinkage {100 * e['random_deepest_sinkage_rel']:+.1f} ± "
              f"{100 * e['random_deepest_sinkage_se_rel']:.1f} %; gait travel {100 * e['gait_travel_rel']:+.1f} ± "
              f"{100 * e['gait_travel_se_rel']:.1f} %, sinkage {100 * e['gait_deepest_sinkage_rel']:+.1f} ± "
              f"{100 * e['gait_deepest_sinkage_se_rel']:.1f} %  (cpu {row['cpu_s']:.0f} s)", flush=True)
        result = {"study": "benchmarks/studies/sand_substeps.py", "provenance": meta,
                  "seeds": args.seeds, "reference_step": args.reference_step, "columns": COLUMNS,
                  "rows": [table_row(r) for r in rows], "details": rows, "unstable": unstable}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1) + "\n")  # after each setting: a checkpoint of sorts


if __name__ == "__main__":
    main()
