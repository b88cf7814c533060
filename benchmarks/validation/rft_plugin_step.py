"""The MuJoCo plugin ``terrasph.rft`` against terrasph's implicit 3D RFT stepper (docs/mujoco_plugin.md):
gymnasium's ant on the generic sand under a fixed random action sequence, at several MuJoCo steps.

    OMP_NUM_THREADS=1 python benchmarks/validation/rft_plugin_step.py [--steps 1e-2 5e-3 2e-3 1e-3 5e-4]
        [--reference-step 2.5e-4] [--seeds 0 1 2] [--out benchmarks/results/rft_plugin_step.json]

The ant is gymnasium's ``ant.xml`` with only the plugin named in it and the floor's contacts switched
off (``contype="0" conaffinity="0"`` on the floor geom). It drops from the file's pose onto the sand
with zero actions and settles for 2 s (its ankles come to rest on their joint limits after 1.4 s);
then it stands for 0.5 s (phase ``stand``, still zero actions)
and is driven for 1 s (phase ``walk``) by uniform random actions in [−1, 1], each held 0.05 s
(Ant-v5's control interval, 5 × the file's 0.01 s; a random walk of this light ant, 0.91 kg under
150 N m motors, is chaotic: over 3 s the paths of any two steps part by decimetres, so the horizon is
1 s). Variants, each at every step dt:

* ``rk4-explicit``: the file as it is (integrator RK4); the plugin's load is explicit there;
* ``euler-explicit``: integrator Euler, the plugin's correction switched off (``implicit=false``);
* ``euler-implicit``: integrator Euler, the plugin's default: the backward-Euler correction;
* ``reference``: terrasph's implicit stepper (terrasph.terrain.rft3d_coupling.RFT3DCoupling) on the same
  bodies and elements, integrator Euler, at the same dt;

and the converged reference: the implicit stepper at ``--reference-step`` (default 2.5e-4 s) with the
file's integrator (RK4), whose own uncertainty the row ``reference-euler`` gives (the same with Euler).
Each run reports, per phase: stable (no NaN, no MuJoCo reset, torso speed below 100 m/s), the torso's
path error against the converged reference (RMS over the phase and at its end, m), the total vertical RFT
load's relative RMS error over 0.05 s windows and its mean over the ant's weight, and its chatter
(the load of each step from the change of the ant's momentum, F_z = W + ΔP_z/dt, so that every
variant is measured alike, RK4's four evaluations included):
the mean change of the total vertical load from one step to the next, over the weight (an explicit
load that flips between full and none each step reads about 1; a smooth one, a few per cent). The
random walk is repeated for each seed (default three) and summarised by the median and range of each
error: an explicit variant's walk parts from the reference's by a different amount for each seed. Writes the table as JSON with the machine,
the date and the commit.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import pathlib
import platform
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium
import mujoco
import numpy as np
import terrasph
from terrasph import mujoco_plugin
from terrasph.terrain.rft3d import BodyElements
from terrasph.terrain.rft3d_coupling import Body3D, RFT3DCoupling, Robot3D

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


def _momentum_z(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """The ant's vertical momentum (N s) at the data's state (its frames and velocities brought to it
    first; the state itself is not touched)."""
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_comVel(model, data)
    mujoco.mj_subtreeVel(model, data)
    return float(model.body_subtreemass[1] * data.subtree_linvel[1, 2])


def drive(model: mujoco.MjModel, data: mujoco.MjData, step: Callable[[], None], dt: float, t_end: float,
          actions: np.ndarray) -> Trace:
    """Steps with `step` under `actions` (one row per control interval). The vertical RFT load of each
    step is read from the momentum, F_z = W + ΔP_z / dt (the sand and gravity are the only external
    loads once the floor is off): the load MuJoCo integrated, whatever the integrator's stages."""
    per, windows = _windows(dt, t_end)
    weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
    path, load, chatter, stable = [], [], [], True
    momentum, previous = _momentum_z(model, data), math.nan
    start = time.process_time()
    for w in range(windows):
        data.ctrl[:] = actions[w]
        fz = np.empty(per)
        for k in range(per):
            step()
            now = _momentum_z(model, data)
            fz[k], momentum = weight + (now - momentum) / dt, now
        stable = stable and _stable(data)
        if not stable:
            break
        path.append(data.qpos[:3].copy())
        load.append(fz.mean())
        chatter.append(np.nanmean(np.abs(np.diff(np.concatenate([[previous], fz])))))
        previous = fz[-1]
    return Trace(np.array(path), np.array(load), np.array(chatter), stable, time.process_time() - start)


def run_plugin(dt: float, t_end: float, actions: np.ndarray, integrator: str | None, implicit: bool) -> Trace:
    """The ant with the plugin in a plain mj_step loop."""
    model = mujoco.MjModel.from_xml_string(ant_on_sand(integrator, implicit))
    model.opt.timestep = dt
    data = mujoco.MjData(model)
    return drive(model, data, lambda: mujoco.mj_step(model, data), dt, t_end, actions)


def run_reference(dt: float, t_end: float, actions: np.ndarray, bodies: list[int],
                  integrator: str | None = "Euler") -> Trace:
    """The ant on terrasph's implicit stepper (`integrator`, None: the file's), the plugin's bodies and
    elements."""
    model = mujoco.MjModel.from_xml_string(ant_on_sand(integrator, plugin=False))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    coupled = [Body3D(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"#{b}", b,
                      BodyElements.from_body(model, b)) for b in bodies]
    stepper = RFT3DCoupling(Robot3D(model, data, coupled, 0.0), time_step=dt)
    return drive(model, data, stepper.step, dt, t_end, actions)


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


#: the phases: their start and end (s) and whether the actions are random (else zero); before the
#: first, the drop and the settling
PHASES = {"stand": (2.0, 2.5, False), "walk": (2.5, 3.5, True)}


def fmt(value: float | None, scale: float = 1.0, digits: str = ".3g") -> str:
    """A table cell: `value` × `scale`, or a dash for a run that blew up."""
    return "—" if value is None else format(scale * value, digits)


def measure(seed: int, steps: list[float], reference_step: float, bodies: list[int], weight: float,
            nu: int) -> list[dict]:
    """Every variant at every step against the converged reference, for the random actions of `seed`:
    one row per phase, variant and step (printed as it comes)."""
    t_end = max(end for _, end, _ in PHASES.values())
    windows = round(t_end / CONTROL_INTERVAL)
    actions = np.zeros((windows, nu))
    rng = np.random.default_rng(seed)
    for begin, end, random in PHASES.values():
        if random:
            span = slice(round(begin / CONTROL_INTERVAL), round(end / CONTROL_INTERVAL))
            actions[span] = rng.uniform(-1.0, 1.0, (span.stop - span.start, nu))
    rows: list[dict] = []

    def record(variant: str, dt: float, trace: Trace) -> list[dict]:
        out = []
        for phase, (begin, end, _) in PHASES.items():
            span = slice(round(begin / CONTROL_INTERVAL), round(end / CONTROL_INTERVAL))
            part = Trace(trace.path[span], trace.load[span], trace.chatter[span],
                         trace.stable and len(trace.path) >= span.stop, trace.cpu)
            whole = Trace(converged.path[span], converged.load[span], converged.chatter[span], True, 0.0)
            row = {"seed": seed, "phase": phase, "variant": variant, "dt": dt, **compare(part, whole, weight)}
            print(f"| {seed} | {phase} | {variant} | {1e3 * dt:g} | {'yes' if row['stable'] else 'no'} | "
                  f"{fmt(row['path_rms_m'], 1e3)} | {fmt(row['path_end_m'], 1e3)} | {fmt(row['load_rms_rel'])} | "
                  f"{fmt(row['load_mean_over_weight'])} | {fmt(row['load_chatter_over_weight'])} | "
                  f"{row['cpu_s']:.2f} |", flush=True)
            out.append(row)
        rows.extend(out)
        return out

    converged = run_reference(reference_step, t_end, actions, bodies, None)
    assert converged.stable, "the converged reference blew up"
    record("reference-rk4", reference_step, converged)
    record("reference-euler", reference_step, run_reference(reference_step, t_end, actions, bodies))
    for dt in steps:
        runs = {"rk4-explicit": lambda dt=dt: run_plugin(dt, t_end, actions, None, False),
                "euler-explicit": lambda dt=dt: run_plugin(dt, t_end, actions, "Euler", False),
                "euler-implicit": lambda dt=dt: run_plugin(dt, t_end, actions, "Euler", True),
                "reference": lambda dt=dt: run_reference(dt, t_end, actions, bodies)}
        traces, recorded = {}, {}
        for variant, run in runs.items():
            traces[variant] = run()
            recorded[variant] = record(variant, dt, traces[variant])
        plugin, same_step = traces["euler-implicit"], traces["reference"]
        if plugin.stable and same_step.stable:  # the plugin's correction against the stepper at the same dt
            path = float(np.abs(plugin.path - same_step.path).max())
            load = float(np.abs(plugin.load - same_step.load).max() / weight)
            for row in recorded["euler-implicit"]:
                row.update({"path_against_stepper_same_dt_m": path, "load_against_stepper_same_dt_rel": load})
            print(f"| {seed} | all | euler-implicit − reference | {1e3 * dt:g} | | {path:.1e} m (max) | | "
                  f"{load:.1e} × weight (max) | | | |")
    return rows


def summarise(rows: list[dict]) -> list[dict]:
    """Per phase, variant and step: the median and range over the seeds of each error (a random walk
    of the explicit variants parts from the reference differently for each seed: its path moves by
    decimetres under a change of the last bits of its load)."""
    keys = ("path_end_m", "load_rms_rel", "path_against_stepper_same_dt_m", "load_against_stepper_same_dt_rel")
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        groups.setdefault((row["phase"], row["variant"], row["dt"]), []).append(row)
    out = []
    for (phase, variant, dt), group in groups.items():
        entry: dict = {"phase": phase, "variant": variant, "dt": dt, "seeds": len(group),
                       "stable": all(r["stable"] for r in group)}
        for key in keys:
            values = [r[key] for r in group if r.get(key) is not None]
            if values:
                entry[key] = {"median": float(np.median(values)), "min": float(min(values)), "max": float(max(values))}
        out.append(entry)
    return out


#: the variants docs/mujoco_plugin.md shows, in its order, and their names there
SHOWN = {"euler-implicit": "plugin, Euler, implicit (default)", "reference": "terrasph's implicit stepper, Euler",
         "rk4-explicit": "plugin, RK4 (the file as shipped), explicit", "euler-explicit": "plugin, Euler, `implicit=false`"}
#: the table docs/mujoco_plugin.md shows (docs/hooks/generated_tables.py): key, heading, format
COLUMNS = [["variant", "variant", "{}"], ["dt_ms", "dt (ms)", "{:g}"],
           ["stand_mm", "standing: torso position error (mm)", "{:.3g}"],
           ["walk_path_mm", "walk: torso path error after 1 s (mm), median", "{:.3g}"],
           ["walk_path_range_mm", "(range over the seeds)", "{}"],
           ["walk_load", "walk: vertical load RMS error (0.05 s means), median", "{:.1%}"],
           ["walk_load_range", "(range)", "{}"]]


def _millimetres(metres: float) -> str:
    """A length in mm to three digits, whole above a metre."""
    return f"{1e3 * metres:.3g}" if metres < 1.0 else f"{1e3 * metres:.0f}"


def table_rows(summary: list[dict]) -> list[dict]:
    """The summary as :data:`COLUMNS`' rows: per shown variant and step, the standing error (the same for
    every seed: the median) and the walk's path and load errors (median and range over the seeds)."""
    entries = {(e["phase"], e["variant"], e["dt"]): e for e in summary}
    rows = []
    for variant, name in SHOWN.items():
        for dt in sorted({e["dt"] for e in summary if e["variant"] == variant}):
            stand, walk = entries.get(("stand", variant, dt), {}), entries.get(("walk", variant, dt), {})
            if "path_end_m" not in stand or "path_end_m" not in walk:
                rows.append({"variant": name, "dt_ms": 1e3 * dt, "stand_mm": math.nan, "walk_path_mm": math.nan,
                             "walk_path_range_mm": "unstable", "walk_load": math.nan, "walk_load_range": "unstable"})
                continue
            path, load = walk["path_end_m"], walk["load_rms_rel"]
            rows.append({"variant": name, "dt_ms": 1e3 * dt, "stand_mm": 1e3 * stand["path_end_m"]["median"],
                         "walk_path_mm": 1e3 * path["median"],
                         "walk_path_range_mm": f"{_millimetres(path['min'])}–{_millimetres(path['max'])}",
                         "walk_load": load["median"], "walk_load_range": f"{load['min']:.1%}–{load['max']:.1%}"})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", nargs="+", type=float, default=[1e-2, 5e-3, 2e-3, 1e-3, 5e-4])
    parser.add_argument("--reference-step", type=float, default=2.5e-4)
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("benchmarks/results/rft_plugin_step.json"))
    args = parser.parse_args()
    mujoco_plugin.load()
    model = mujoco.MjModel.from_xml_string(ant_on_sand())
    bodies = mujoco_plugin.coupled_bodies(model)
    weight = float(model.body_subtreemass[1] * -model.opt.gravity[2])
    print("| seed | phase | variant | dt (ms) | stable | path RMS (mm) | path end (mm) | load RMS error | "
          "mean load / weight | load chatter / weight | CPU (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    rows = [row for seed in args.seeds for row in measure(seed, args.steps, args.reference_step, bodies, weight, model.nu)]
    summary = summarise(rows)
    print("\n| phase | variant | dt (ms) | stable | path end error (mm): median [min, max] | load RMS error: median "
          "[min, max] |")
    print("|---|---|---|---|---|---|")
    for entry in summary:
        cells = []
        for key, scale in (("path_end_m", 1e3), ("load_rms_rel", 1.0)):
            v = entry.get(key)
            cells.append("—" if v is None else f"{fmt(v['median'], scale)} [{fmt(v['min'], scale)}, {fmt(v['max'], scale)}]")
        print(f"| {entry['phase']} | {entry['variant']} | {1e3 * entry['dt']:g} | {'yes' if entry['stable'] else 'no'} | "
              f"{cells[0]} | {cells[1]} |")
    meta = provenance()
    command = "OMP_NUM_THREADS=1 python benchmarks/validation/rft_plugin_step.py " + " ".join(
        [f"--steps {' '.join(f'{s:g}' for s in args.steps)}", f"--reference-step {args.reference_step:g}",
         f"--seeds {' '.join(str(s) for s in args.seeds)}"])
    result = {**meta, "provenance": {"date": meta["date"], "terrasph": terrasph.__version__, "commit": meta["commit"],
                                     "cpu": meta["machine"], "threads": os.environ.get("OMP_NUM_THREADS"),
                                     "cores": os.cpu_count(), "command": command},
              "columns": COLUMNS, "rows": table_rows(summary),
              "command": "python benchmarks/validation/rft_plugin_step.py " + " ".join(
        [f"--steps {' '.join(f'{s:g}' for s in args.steps)}", f"--reference-step {args.reference_step:g}",
         f"--seeds {' '.join(str(s) for s in args.seeds)}"]),
        "model": "gymnasium ant.xml, floor contacts off, plugin terrasph.rft (generic map, surface 0)",
        "weight_n": weight, "control_interval_s": CONTROL_INTERVAL,
        "phases": {name: {"start_s": b, "end_s": e, "random_actions": r} for name, (b, e, r) in PHASES.items()},
        "summary": summary, "seed_rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
