"""One interface to the sand for a MuJoCo model of the user's own: :func:`attach` and :class:`Terrain`.

``sand = attach(model, data, terrain="rft3d")`` puts a compiled ``mujoco.MjModel`` and its
``mujoco.MjData`` on a terrain, unmodified but for its floor; ``sand.step(nstep)`` then takes the
place of ``mujoco.mj_step(model, data, nstep)``: it advances the same simulated time, nstep × the
model's ``opt.timestep``, with the terrain's loads on the coupled bodies. What the caller sets in
``data`` (``ctrl``, ``qfrc_applied``) acts as in ``mj_step``; sensors, viewers and controllers read
``data`` as usual. The terrains are the package's steppers, each behind the same methods:

* ``"rft3d"``: 3D resistive force theory (:class:`terrasph.robots.rft3d_terrain.RFT3DCoupling`), any
  model (free joints, hinges about any axis);
* ``"rft"``: planar resistive force theory (:class:`terrasph.robots.rft_terrain.RFTCoupling`), a
  model moving in the x–z plane (slides along x and z, hinges about y).

Both are implicit in the RFT load (docs/rft.md): the stepper takes MuJoCo's step itself, the load
entering as ``xfrc_applied`` on the coupled bodies, and steps at most the terrain's measured step
(``time_step``, default :data:`~terrasph.robots.rft_terrain.RFT_TIME_STEP` planar,
:data:`~terrasph.robots.rft3d_terrain.RFT3D_TIME_STEP` 3D): the model's step is cut into equal
substeps no longer than that, all taken in one call of the compiled stepper, and ``opt.timestep``
is the model's own again when :meth:`Terrain.step` returns. The substeps use MuJoCo's
semi-implicit Euler integrator (the scheme the implicit RFT correction is derived for), whatever
the model's ``opt.integrator`` (put back after the call): on gymnasium's Ant (RK4 in its file),
with the 3D terrain's step, Euler substeps walked a gentle open-loop gait closer to the travel at
half the step than RK4 substeps did, and faster (benchmarks/results/sand_substeps.json,
docs/terrain.md). The terrain owns the coupled bodies'
``xfrc_applied`` (the 3D stepper every body's): a perturbation there is not applied.

The floor: the model's horizontal planes (and the world's collision geoms whose top is at their
height) have their contacts switched off, one log line says so, and the sand's free surface lies
at the floor's height (terrasph.robots.terrain_robot). Coupled bodies: every body with a collision
geom, or those named (``bodies``), or those lower than ``couple_below`` above the floor now. A body
not coupled passes through the sand.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from terrasph import rft
from terrasph.config import ConfigError
from terrasph.robots.geoms import body_shape
from terrasph.robots.mjcf import Coupling, PlanarRobot, check_planar
from terrasph.robots.rft3d_terrain import (
    RFT3D_TIME_STEP,
    RFT3DCoupling,
    Robot3D,
    bodies_3d,
)
from terrasph.robots.rft_terrain import RFT_TIME_STEP, NativeRFTStepper, RFTCoupling
from terrasph.robots.terrain_robot import (
    check_couple_below,
    coupled_body_ids,
    floor_geoms,
    switch_off_floor,
)

__all__ = ["INTEGRATORS", "PLANAR_SPACING", "TERRAINS", "Terrain", "attach"]

#: the terrains :func:`attach` offers
TERRAINS = ("rft3d", "rft")

#: the particle spacing (m) of a planar body's shape (its drawing and lowest point; the RFT elements
#: follow the geoms' outline, :class:`terrasph.rft.SurfaceElements`), the scenes' Δx
PLANAR_SPACING = 0.005

#: the options of each terrain beyond `table` and `bodies` (:func:`attach`)
_OPTIONS = {"rft3d": ("couple_below", "time_step", "element_length", "integrator"),
            "rft": ("couple_below", "time_step", "element_length", "spacing", "integrator")}

#: the integrators of the terrain's substeps (:func:`attach`'s option ``integrator``)
INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "model": None}

#: the part of MuJoCo's state that :meth:`Terrain.state` keeps: everything the next step reads
_MUJOCO_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


class Terrain:
    """A MuJoCo model and its data on a terrain (module docstring). Built by :func:`attach`."""

    def __init__(self, kind: str, model: mujoco.MjModel, data: mujoco.MjData, stepper: NativeRFTStepper,
                 surface: float, substeps: int, model_step: float, integrator: int | None) -> None:
        self.kind, self.model, self.data = kind, model, data
        self._integrator = integrator
        self._stepper = stepper
        self._surface = float(surface)
        self._substeps = substeps
        self._model_step = model_step
        self._names = tuple(b.name for b in stepper.robot.coupled)
        self._loads = self._mean_loads()  # NaN: no step yet

    @property
    def bodies(self) -> tuple[str, ...]:
        """The names of the bodies the terrain carries, in the order of :meth:`loads`."""
        return self._names

    @property
    def surface(self) -> float:
        """The sand's free surface, z (m): the model's floor height."""
        return self._surface

    @property
    def time_step(self) -> float:
        """The terrain's step (s): the model's ``opt.timestep`` cut into equal substeps."""
        return self._stepper.time_step()

    def step(self, nstep: int = 1) -> None:
        """Advances the model and the sand by `nstep` × the model's ``opt.timestep`` (as
        ``mujoco.mj_step(model, data, nstep)`` would), in one call of the compiled stepper;
        :class:`terrasph.InstabilityError` if MuJoCo could not integrate a state. Afterwards each
        coupled body's ``xfrc_applied`` holds its load over the call (:meth:`loads`), as the sand's
        share of what ``mj_rnePostConstraint`` reports in ``cfrc_ext`` and a viewer draws; the next
        step replaces it."""
        if isinstance(nstep, bool) or not isinstance(nstep, (int, np.integer)) or nstep < 1:
            raise ConfigError(f"parameter 'nstep' = {nstep!r} is invalid: allowed an integer >= 1")
        self._stepper.reset_body_means()
        own_integrator = self.model.opt.integrator
        if self._integrator is not None:
            self.model.opt.integrator = self._integrator
        try:
            self._stepper.steps(int(nstep) * self._substeps)
        finally:  # the model's own step and integrator, as the caller's env and viewer read them
            self.model.opt.timestep = self._model_step
            self.model.opt.integrator = own_integrator
        self._loads = self._mean_loads()
        for body, load in zip(self._stepper.robot.coupled, self._loads.values()):
            self.data.xfrc_applied[body.body_id] = load

    def loads(self) -> dict[str, np.ndarray]:
        """Each coupled body's load from the sand over the last :meth:`step` call (each substep's
        weighted by its dt), as MuJoCo's ``xfrc_applied`` holds one: force (3, N) and torque (3,
        N·m) about the body's centre of mass, world axes; NaN before the first step. On the planar
        terrain the torque is about y, moved from the body's frame origin to its centre of mass with
        the offset at the call's end."""
        return {name: load.copy() for name, load in self._loads.items()}

    def _mean_loads(self) -> dict[str, np.ndarray]:
        """The loads of :meth:`loads` from the stepper's sums."""
        means = self._stepper.load_means()
        if self.kind == "rft3d":
            return {name: row.copy() for name, row in zip(self._names, means)}
        loads = {}
        for body, (fx, fz, torque) in zip(self._stepper.robot.coupled, means):
            offset = self.data.xpos[body.body_id] - self.data.xipos[body.body_id]
            # τ_com = τ_ref + ((x_ref − x_com) × F)_y, (a × b)_y = a_z b_x − a_x b_z
            loads[body.name] = np.array([fx, 0.0, fz, 0.0, torque + offset[2] * fx - offset[0] * fz, 0.0])
        return loads

    def sinkage(self) -> dict[str, float]:
        """Each coupled body's depth below the free surface (m): the surface's z less that of the
        body's lowest point now (negative while the body is above the sand)."""
        return {name: self._surface - self._stepper.lowest_z(k) for k, name in enumerate(self._names)}

    def state(self) -> dict[str, Any]:
        """Everything the next step reads, as a copy: MuJoCo's integration state (``mj_getState``
        with ``mjSTATE_INTEGRATION``) and the stepper's memory; :meth:`restore` continues from it
        bit for bit."""
        mujoco_state = np.empty(mujoco.mj_stateSize(self.model, _MUJOCO_STATE))
        mujoco.mj_getState(self.model, self.data, mujoco_state, _MUJOCO_STATE)
        return {"mujoco": mujoco_state, "stepper": copy.deepcopy(self._stepper.state()),
                "step_count": self._stepper.step_count, "loads": self.loads()}

    def restore(self, state: dict[str, Any]) -> None:
        """Puts back a :meth:`state` of this terrain."""
        try:
            mujoco_state, memory, count = state["mujoco"], state["stepper"], int(state["step_count"])
            dict(state["loads"])
        except (KeyError, TypeError, ValueError):
            raise ConfigError("parameter 'state' is invalid: allowed a dict from Terrain.state()") from None
        if np.shape(mujoco_state) != (mujoco.mj_stateSize(self.model, _MUJOCO_STATE),):
            raise ConfigError("parameter 'state' is invalid: it belongs to another model (its MuJoCo state's size "
                              "differs)")
        mujoco.mj_setState(self.model, self.data, np.asarray(mujoco_state, dtype=float), _MUJOCO_STATE)
        self._stepper.restore_state(copy.deepcopy(memory))
        self._stepper.step_count = count
        self._loads = {name: np.array(load, dtype=float) for name, load in state["loads"].items()}

    def reset(self) -> None:
        """Starts the terrain's memory afresh from the state now in ``data``, after the caller reset
        it (``mujoco.mj_resetData``, an environment's ``reset``): a fresh, flat bed."""
        mujoco.mj_forward(self.model, self.data)
        self._stepper.restart()
        self._loads = self._mean_loads()


def attach(model: mujoco.MjModel, data: mujoco.MjData, terrain: str = "rft3d", table: rft.RFTCoefficients | str = "generic",
           bodies: Sequence[str] | None = None, **options: Any) -> Terrain:
    """Puts the compiled `model` and its `data` on `terrain` (one of :data:`TERRAINS`) with the RFT
    coefficient map `table` (a name of :func:`terrasph.rft.coefficient_table` or a map) and returns
    the :class:`Terrain` that steps them (module docstring). `bodies`: the names of the bodies that
    meet the sand (default: every body with a collision geom). Options (each terrain's list:
    ``couple_below`` (m): couple only the bodies lower than this above the floor now; ``time_step``
    (s): the terrain's longest step; ``element_length`` (m): the RFT elements' size; ``spacing``
    (m, planar): the bodies' particle spacing, :data:`PLANAR_SPACING`; ``integrator``: MuJoCo's
    integrator in the terrain's substeps, ``"euler"`` (default: the implicit correction's own
    scheme; the measured choice, module docstring) or ``"model"`` (the model's ``opt.integrator``).

    Refused before anything is changed, as :class:`terrasph.config.ConfigError` naming the item: a
    terrain, table or option not offered; gravity not along −z; a model the planar terrain cannot
    carry (naming its joint or body); no body to couple, a named body the model lacks, a coupled
    body without mass. On success the model's floor is switched off (logged)."""
    if not isinstance(model, mujoco.MjModel) or not isinstance(data, mujoco.MjData):
        raise ConfigError("parameters 'model' and 'data' must be a compiled mujoco.MjModel and its mujoco.MjData")
    if terrain not in TERRAINS:
        raise ConfigError(f"parameter 'terrain' = {terrain!r} is invalid: allowed one of {', '.join(TERRAINS)}")
    unknown = sorted(set(options) - set(_OPTIONS[terrain]))
    if unknown:
        raise ConfigError(f"parameter '{unknown[0]}' is not an option of terrain {terrain!r}: allowed "
                          f"{', '.join(_OPTIONS[terrain])}")
    table = rft.coefficient_table(table)
    gravity = _downward_gravity(model)
    model_step = float(model.opt.timestep)
    integrator = options.get("integrator", "euler")
    if integrator not in INTEGRATORS:
        raise ConfigError(f"parameter 'integrator' = {integrator!r} is invalid: allowed one of {', '.join(INTEGRATORS)}")
    longest = options.get("time_step", RFT3D_TIME_STEP if terrain == "rft3d" else RFT_TIME_STEP)
    if isinstance(longest, bool) or not (isinstance(longest, (int, float)) and math.isfinite(longest) and longest > 0):
        raise ConfigError(f"parameter 'time_step' = {longest!r} is invalid: allowed a finite number > 0 (s)")
    substeps = max(1, math.ceil(model_step / longest * (1 - 1e-12)))
    couple_below = options.get("couple_below")
    if couple_below is not None:
        check_couple_below(couple_below)
    mujoco.mj_forward(model, data)
    floor, level = floor_geoms(model, data)
    chosen = coupled_body_ids(model, data, level, tuple(bodies or ()), couple_below)
    if 0 in chosen:
        raise ConfigError("coupled body 'world' cannot move; couple a body of the robot")
    element_length = options.get("element_length")
    if terrain == "rft3d":
        coupled = bodies_3d(model, chosen, element_length)
        switch_off_floor(model, floor)
        stepper: NativeRFTStepper = RFT3DCoupling(Robot3D(model, data, coupled, level), table,
                                                 time_step=model_step / substeps, control_interval=model_step)
    else:
        _check_planar(model, data)
        spacing = options.get("spacing", PLANAR_SPACING)
        couplings = {_body_name(model, b): Coupling(body_shape(model, b, spacing)) for b in chosen}
        robot = PlanarRobot(model, couplings, gravity=gravity, data=data)
        stepper = RFTCoupling(robot, level, table, time_step=model_step / substeps, element_length=element_length,
                              control_interval=model_step)
        switch_off_floor(model, floor)
    model.opt.timestep = model_step
    mujoco.mj_forward(model, data)
    return Terrain(terrain, model, data, stepper, level, substeps, model_step, INTEGRATORS[integrator])


def _body_name(model: mujoco.MjModel, body: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"#{body}"


def _downward_gravity(model: mujoco.MjModel) -> float:
    """g (m/s²) of the model's gravity (0, 0, −g); ConfigError otherwise: the sand's surface is level
    and its resistance scales with depth along gravity."""
    gx, gy, gz = (float(v) for v in model.opt.gravity)
    if not (gx == 0.0 and gy == 0.0 and gz < 0.0):
        raise ConfigError(f"the model's option 'gravity' = {[gx, gy, gz]} is invalid on the sand: allowed (0, 0, -g) "
                          "with g > 0 (the sand's surface is level)")
    return -gz


def _check_planar(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """ConfigError naming the first joint or body that is not planar, with the terrain that takes any model."""
    try:
        check_planar(model, data)
    except ConfigError as error:
        raise ConfigError(f"{error}; the planar terrain 'rft' takes planar models only: attach this one with "
                          "terrain 'rft3d'") from None
