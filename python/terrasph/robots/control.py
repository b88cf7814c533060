"""Driving a MuJoCo model's actuators from outside: a controller ``(time, model, data) -> ctrl``,
called before each coupled step, and the per-actuator specs the command line gives.

A spec is ``ACTUATOR=FORM``, the actuator named by its own name, the joint it drives or ``#index``
(gymnasium's hopper leaves its motors unnamed), with FORM one of

* ``VALUE`` — a constant ctrl;
* ``sin:AMPLITUDE,PERIOD[,PHASE_DEG[,OFFSET]]`` — OFFSET + AMPLITUDE·sin(2π t/PERIOD + PHASE);
* ``knots:T0/U0,T1/U1,...`` — the piecewise-linear schedule of :mod:`terrasph.schedules`;
* ``hold:KP,KD`` — a PD servo holding the actuator's joint at its angle at start,
  torque −KP (q − q0) − KD q̇ (N·m/rad, N·m·s/rad, or N/m, N·s/m on a slide), ctrl = torque/gear.

The time t of ``sin`` and ``knots`` counts from `start`, and these and a constant give 0 before it
(a scene's settling pause); ``hold`` acts from the first step. Actuators without a spec get 0. MuJoCo clamps the
result to each actuator's ctrlrange.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from terrasph.config import ConfigError
from terrasph.schedules import check_knots, evaluate

__all__ = ["FORMS", "ActuatorSpec", "Controller", "parse_spec", "spec_controller"]

#: a controller: (time s, model, data) -> the ctrl vector (model.nu values)
Controller = Callable[[float, mujoco.MjModel, mujoco.MjData], np.ndarray]
#: the forms of an actuator spec
FORMS = ("VALUE", "sin:AMPLITUDE,PERIOD[,PHASE_DEG[,OFFSET]]", "knots:T0/U0,T1/U1,...", "hold:KP,KD")


@dataclass(frozen=True)
class ActuatorSpec:
    """One actuator's command: its `name`, the `form` ("constant", "sin", "knots", "hold") and its numbers."""

    name: str
    form: str
    values: tuple[float, ...] = ()
    knots: tuple[tuple[float, float], ...] = ()


def _numbers(spec: str, text: str, least: int, most: int) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if not least <= len(values) <= most or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"parameter 'ctrl' = {spec!r} is invalid: allowed ACTUATOR=" + " | ".join(FORMS))
    return values


def parse_spec(spec: str) -> ActuatorSpec:
    """One ``ACTUATOR=FORM`` (module docstring); ConfigError naming 'ctrl' and the forms otherwise."""
    name, sep, form = str(spec).partition("=")
    kind, colon, rest = form.partition(":")
    if not sep or not name:
        raise ConfigError(f"parameter 'ctrl' = {spec!r} is invalid: allowed ACTUATOR=" + " | ".join(FORMS))
    if not colon:
        return ActuatorSpec(name, "constant", _numbers(spec, form, 1, 1))
    if kind == "sin":
        values = _numbers(spec, rest, 2, 4)
        if values[1] <= 0:
            raise ConfigError(f"parameter 'ctrl' = {spec!r}: the period must be > 0 s")
        return ActuatorSpec(name, "sin", values)
    if kind == "hold":
        values = _numbers(spec, rest, 2, 2)
        if min(values) < 0:
            raise ConfigError(f"parameter 'ctrl' = {spec!r}: KP and KD must be >= 0")
        return ActuatorSpec(name, "hold", values)
    if kind == "knots":
        try:
            pairs = [tuple(float(v) for v in knot.split("/")) for knot in rest.split(",")]
        except ValueError:
            pairs = [()]
        if not all(len(p) == 2 for p in pairs):
            raise ConfigError(f"parameter 'ctrl' = {spec!r} is invalid: knots are T/U pairs, e.g. knots:0/0,1/0.5")
        return ActuatorSpec(name, "knots", knots=check_knots(f"ctrl of {name}", pairs))
    raise ConfigError(f"parameter 'ctrl' = {spec!r} is invalid: allowed ACTUATOR=" + " | ".join(FORMS))


def _actuator_names(model: mujoco.MjModel, a: int) -> list[str]:
    """What a spec may call actuator `a`: its name, the joint it drives, ``#a`` (its index)."""
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or ""]
    if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
        names.append(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.actuator_trnid[a, 0])) or "")
    return [n for n in names if n] + [f"#{a}"]


def _actuator(model: mujoco.MjModel, name: str) -> int:
    """The actuator a spec names: by its own name, else the joint it drives (if only it drives that
    joint), else ``#index``."""
    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
    if index >= 0:
        return index
    matches = [a for a in range(model.nu) if name in _actuator_names(model, a)]
    if len(matches) != 1:
        known = ["/".join(_actuator_names(model, a)) for a in range(model.nu)]
        raise ConfigError(f"parameter 'ctrl' names actuator '{name}', which is {'ambiguous' if matches else 'not'} "
                          f"an actuator of the MJCF model (by name, joint or #index); its actuators: {known}")
    return matches[0]


def spec_controller(specs: Sequence[str], model: mujoco.MjModel, data: mujoco.MjData, start: float = 0.0) -> Controller:
    """A controller from ``ACTUATOR=FORM`` specs (module docstring); `data` gives the joints' angles
    at start for ``hold``; the other forms begin at `start` (s). Checked here, before any step:
    unknown actuators, bad forms, an actuator named twice, ``hold`` on an actuator that does not
    drive a joint."""
    parsed = [parse_spec(s) for s in specs]
    indices = [_actuator(model, p.name) for p in parsed]
    twice = sorted({p.name for p, i in zip(parsed, indices) if indices.count(i) > 1})
    if twice:
        raise ConfigError(f"parameter 'ctrl' names actuator(s) {twice} twice")
    holds = {}
    for p, a in zip(parsed, indices):
        if p.form == "hold":
            if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
                raise ConfigError(f"parameter 'ctrl': actuator '{p.name}' does not drive a joint; 'hold' needs one")
            joint = int(model.actuator_trnid[a, 0])
            qpos, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
            holds[a] = (qpos, dof, float(data.qpos[qpos]), float(model.actuator_gear[a, 0]))

    def controller(time: float, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        ctrl = np.zeros(model.nu)
        after = time - start
        for p, a in zip(parsed, indices):
            if p.form == "hold":
                qpos, dof, target, gear = holds[a]
                kp, kd = p.values
                ctrl[a] = (-kp * (data.qpos[qpos] - target) - kd * data.qvel[dof]) / gear
            elif after < 0:
                continue
            elif p.form == "constant":
                ctrl[a] = p.values[0]
            elif p.form == "sin":
                amplitude, period, phase, offset = (*p.values, 0.0, 0.0)[:4]
                ctrl[a] = offset + amplitude * math.sin(2 * math.pi * after / period + math.radians(phase))
            else:
                ctrl[a] = float(evaluate(p.knots, after))
        return ctrl

    return controller
