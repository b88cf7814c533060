"""The MuJoCo plugin ``terrasph.rft`` against terrasph's implicit 3D RFT stepper (docs/mujoco_plugin.md):
gymnasium's ant on the generic sand under a fixed random action sequence, at several MuJoCo steps.

    OMP_NUM_THREADS=1 python benchmarks/validation/rft_plugin_step.py [--steps 1e-2 5e-3 2e-3 1e-3 5e-4]
        [--t-end 3] [--seed 0] [--out benchmarks/results/rft_plugin_step.json]

The ant is gymnasium's ``ant.xml`` with only the plugin named in it and the floor's contacts switched
off (``contype="0" conaffinity="0"`` on the floor geom). It drops from the file's pose onto the sand
and is driven by uniform random actions in [−1, 1], each held 0.05 s (Ant-v5's control interval,
5 × the file's 0.01 s). Variants, each at every step dt:

* ``rk4-explicit``: the file as it is (integrator RK4); the plugin's load is explicit there;
* ``euler-explicit``: integrator Euler, the plugin's correction switched off (``implicit=false``);
* ``euler-implicit``: integrator Euler, the plugin's default: the backward-Euler correction;
* ``reference``: terrasph's implicit stepper (terrasph.robots.rft3d_terrain.RFT3DCoupling) on the same
  bodies and elements, integrator Euler, at the same dt;

and the converged reference: the implicit stepper at ``--reference-step`` (default 2.5e-4 s).
Each run reports: stable (no NaN, no MuJoCo reset, torso speed below 100 m/s), the torso's path
error against the converged reference (RMS over the run and at the end, m), the total vertical RFT
load's relative RMS error over 0.05 s windows and its mean over the ant's weight, and its chatter:
the mean change of the total vertical load from one step to the next, over the weight (an explicit
load that flips between full and none each step reads about 1; a smooth one, a few per cent). Writes the table as JSON with the machine,
the date and the commit.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import pathlib
import platform
import subprocess
import time
from dataclasses import dataclass

import gymnasium
import mujoco
import numpy as np

from terrasph import mujoco_plugin
from terrasph.rft3d import BodyElements
from terrasph.robots.rft3d_terrain import Body3D, RFT3DCoupling, Robot3D

#: gymnasium's ant model file
ANT = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "ant.xml"
#: Ant-v5's control interval (s): frame_skip 5 × the file's 0.01 s
CONTROL_INTERVAL = 0.05
#: a torso faster than this (m/s) has blown up
BLOW_UP_SPEED = 100.0


def ant_on_sand(integrator: str | None = None, implicit: bool = True, plugin: bool = True) -> str:
    """gymnasium's ant.xml with the plugin named in it (``implicit`` its correction), the floor's contacts
    off and, if given, another integrator; without `plugin`, only the floor switched off."""
    text = ANT.read_text()
    floor = '<geom conaffinity="1" condim="3" material="MatPlane" name="floor"'
    assert floor in text, "gymnasium's ant.xml changed: its floor geom is not found"
    text = text.replace(floor, floor.replace('conaffinity="1"', 'contype="0" conaffinity="0"'))
    if plugin:
        text = text.replace('<mujoco model="ant">', '<mujoco model="ant">\n  <extension>\n    <plugin plugin="terrasph.rft">'
                            f'\n      <instance name="sand"><config key="implicit" value="{str(implicit).lower()}"/>'
                            '</instance>\n    </plugin>\n  </extension>', 1)
    if integrator is not None:
        text = text.replace('integrator="RK4"', f'integrator="{integrator}"')
    return text


@dataclass
class Trace:
    """A run's torso path (per control window), the total vertical RFT load (window means), its
    chatter (each window's mean |ΔF_z| from step to step), and whether it stayed stable."""

    path: np.ndarray
    load: np.ndarray
    chatter: np.ndarray
    stable: bool
    cpu: float


def _windows(dt: float, t_end: float) -> tuple[int, int]:
    per = max(1, round(CONTROL_INTERVAL / dt))
    return per, round(t_end / CONTROL_INTERVAL)


def run_plugin(dt: float, t_end: float, actions: np.ndarray, integrator: str | None, implicit: bool) -> Trace:
    """The ant with the plugin in a plain mj_step loop."""
    model = mujoco.MjModel.from_xml_string(ant_on_sand(integrator, implicit))
    model.opt.timestep = dt
    data = mujoco.MjData(model)
    state = slice(int(model.plugin_stateadr[0]), int(model.plugin_stateadr[0] + model.plugin_statenum[0]))
    per, windows = _windows(dt, t_end)
    path, load, chatter, stable = [], [], [], True
    previous = math.nan
    start = time.process_time()
    for w in range(windows):
        data.ctrl[:] = actions[w]
        fz = np.empty(per)
        for k in range(per):
            mujoco.mj_step(model, data)
            fz[k] = data.plugin_state[state].reshape(-1, 6)[:, 2].sum()
        stable = stable and _stable(data)
        if not stable:
            break
        path.append(data.qpos[:3].copy())
        load.append(fz.mean())
        chatter.append(np.nanmean(np.abs(np.diff(np.concatenate([[previous], fz])))))
        previous = fz[-1]
    return Trace(np.array(path), np.array(load), np.array(chatter), stable, time.process_time() - start)


def run_reference(dt: float, t_end: float, actions: np.ndarray, bodies: list[int]) -> Trace:
    """The ant on terrasph's implicit stepper (integrator Euler), the plugin's bodies and elements."""
    model = mujoco.MjModel.from_xml_string(ant_on_sand("Euler", plugin=False))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    coupled = [Body3D(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"#{b}", b,
                      BodyElements.from_body(model, b)) for b in bodies]
    stepper = RFT3DCoupling(Robot3D(model, data, coupled, 0.0), time_step=dt)
    per, windows = _windows(dt, t_end)
    path, load, chatter, stable = [], [], [], True
    previous = math.nan
    start = time.process_time()
    for w in range(windows):
        data.ctrl[:] = actions[w]
        fz = np.empty(per)
        for k in range(per):
            stepper.reset_body_means()
            stepper.step()
            fz[k] = sum(stepper.body_sample(i)["force"][2] for i in range(len(coupled)))
        stable = stable and _stable(data)
        if not stable:
            break
        path.append(data.qpos[:3].copy())
        load.append(fz.mean())
        chatter.append(np.nanmean(np.abs(np.diff(np.concatenate([[previous], fz])))))
        previous = fz[-1]
    return Trace(np.array(path), np.array(load), np.array(chatter), stable, time.process_time() - start)


def _stable(data: mujoco.MjData) -> bool:
    resets = sum(data.warning[k].number for k in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
                                                  mujoco.mjtWarning.mjWARN_BADQVEL))
    return bool(np.all(np.isfinite(data.qvel)) and resets == 0 and np.linalg.norm(data.qvel[:3]) < BLOW_UP_SPEED)


def compare(trace: Trace, reference: Trace, weight: float) -> dict[str, float | bool | None]:
    """The run's errors against the converged reference (None where it blew up)."""
    out: dict[str, float | bool | None] = {"stable": trace.stable, "cpu_s": round(trace.cpu, 3)}
    if not trace.stable:
        return {**out, "path_rms_m": None, "path_end_m": None, "load_rms_rel": None, "load_mean_over_weight": None,
                "load_chatter_over_weight": None}
    distance = np.linalg.norm(trace.path - reference.path, axis=1)
    out.update({"path_rms_m": float(np.sqrt(np.mean(distance**2))), "path_end_m": float(distance[-1]),
                "load_rms_rel": float(np.sqrt(np.mean((trace.load - reference.load) ** 2))
                                      / np.sqrt(np.mean(reference.load**2))),
                "load_mean_over_weight": float(trace.load.mean() / weight),
                "load_chatter_over_weight": float(trace.chatter.mean() / weight)})
    return out


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", nargs="+", type=float, default=[1e-2, 5e-3, 2e-3, 1e-3, 5e-4])
    parser.add_argument("--reference-step", type=float, default=2.5e-4)
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("benchmarks/results/rft_plugin_step.json"))
    args = parser.parse_args()
    mujoco_plugin.load()
    model = mujoco.MjModel.from_xml_string(ant_on_sand())
    bodies = mujoco_plugin.coupled_bodies(model)
    weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
    actions = np.random.default_rng(args.seed).uniform(-1.0, 1.0, (round(args.t_end / CONTROL_INTERVAL), model.nu))
    converged = run_reference(args.reference_step, args.t_end, actions, bodies)
    assert converged.stable, "the converged reference blew up"
    rows = [{"variant": "reference", "dt": args.reference_step, **compare(converged, converged, weight)}]
    print("| variant | dt (ms) | stable | path RMS (mm) | path end (mm) | load RMS error | mean load / weight | "
          "load chatter / weight | CPU (s) |")
    print("|---|---|---|---|---|---|---|---|---|")

    def show(row: dict) -> None:
        def fmt(value: float | None, scale: float = 1.0, digits: str = ".3g") -> str:
            return "—" if value is None else format(scale * value, digits)
        print(f"| {row['variant']} | {1e3 * row['dt']:g} | {'yes' if row['stable'] else 'no'} | "
              f"{fmt(row['path_rms_m'], 1e3)} | {fmt(row['path_end_m'], 1e3)} | {fmt(row['load_rms_rel'])} | "
              f"{fmt(row['load_mean_over_weight'])} | {fmt(row['load_chatter_over_weight'])} | {row['cpu_s']:.2f} |",
              flush=True)

    show(rows[0])
    for dt in args.steps:
        runs = {"rk4-explicit": lambda: run_plugin(dt, args.t_end, actions, None, False),
                "euler-explicit": lambda: run_plugin(dt, args.t_end, actions, "Euler", False),
                "euler-implicit": lambda: run_plugin(dt, args.t_end, actions, "Euler", True),
                "reference": lambda: run_reference(dt, args.t_end, actions, bodies)}
        traces = {}
        for variant, run in runs.items():
            traces[variant] = run()
            rows.append({"variant": variant, "dt": dt, **compare(traces[variant], converged, weight)})
            show(rows[-1])
        plugin, same_step = traces["euler-implicit"], traces["reference"]
        if plugin.stable and same_step.stable:  # the plugin's correction against the stepper at the same dt
            rows[-2]["path_against_stepper_same_dt_m"] = float(np.abs(plugin.path - same_step.path).max())
            rows[-2]["load_against_stepper_same_dt_rel"] = float(np.abs(plugin.load - same_step.load).max() / weight)
            print(f"|  euler-implicit vs reference at {1e3 * dt:g} ms: path {rows[-2]['path_against_stepper_same_dt_m']:.2e} m, "
                  f"load {rows[-2]['load_against_stepper_same_dt_rel']:.2e} × weight |")
    result = {**provenance(), "command": "python benchmarks/validation/rft_plugin_step.py " + " ".join(
        [f"--steps {' '.join(f'{s:g}' for s in args.steps)}", f"--reference-step {args.reference_step:g}",
         f"--t-end {args.t_end:g}", f"--seed {args.seed}"]),
        "model": "gymnasium ant.xml, floor contacts off, plugin terrasph.rft (generic map, surface 0)",
        "weight_n": weight, "control_interval_s": CONTROL_INTERVAL, "t_end_s": args.t_end, "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
