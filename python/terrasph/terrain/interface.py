"""One interface to the sand for a MuJoCo model of the user's own: :func:`attach` and :class:`Terrain`.

``sand = attach(model, data, terrain="rft3d")`` puts a compiled ``mujoco.MjModel`` and its
``mujoco.MjData`` on a terrain, unmodified but for its floor; ``sand.step(nstep)`` then takes the
place of ``mujoco.mj_step(model, data, nstep)``: it advances the same simulated time, nstep × the
model's ``opt.timestep``, with the terrain's loads on the coupled bodies. What the caller sets in
``data`` (``ctrl``, ``qfrc_applied``) acts as in ``mj_step``; sensors, viewers and controllers read
``data`` as usual. The terrains are the package's steppers, each behind the same methods
(:class:`Terrain`: what they share; :class:`RFTTerrain`, :class:`SPHTerrain`: what each says):

* ``"rft3d"``: 3D resistive force theory (:class:`terrasph.terrain.rft3d_coupling.RFT3DCoupling`), any
  model (free joints, hinges about any axis);
* ``"rft"``: planar resistive force theory (:class:`terrasph.terrain.rft_coupling.RFTCoupling`), a
  model moving in the x–z plane (slides along x and z, hinges about y);
* ``"sph"``: a planar model on an SPH bed of glass beads
  (:class:`terrasph.terrain.sph_coupling.CoupledSimulation`, built by
  :func:`terrasph.terrain.sph_coupling.planar_sph_bed`), the model shifted into the bed's frame;
* ``"sph3d"``: any model on a 3D SPH bed of glass beads
  (:class:`terrasph.terrain.sph3d_coupling.Coupled3D`), the bed laid in the model's frame.

The RFT terrains are implicit in the load (docs/rft.md): the stepper takes MuJoCo's step itself,
the load entering as ``xfrc_applied`` on the coupled bodies, and steps at most the terrain's
measured step (``time_step``, default :data:`~terrasph.terrain.rft_coupling.RFT_TIME_STEP` planar,
:data:`RFT3D_SUBSTEP` 3D): the model's step is cut into equal
substeps no longer than that, all taken in one call of the compiled stepper. The SPH coupling is
explicit at the SPH's step bound (both SPH terrains). ``opt.timestep`` is the model's own again when
:meth:`Terrain.step` returns. The steps use MuJoCo's semi-implicit Euler integrator (the scheme the
implicit RFT correction is derived for), whatever the model's ``opt.integrator`` (put back after
the call): on gymnasium's Ant (RK4 in its file), at the 3D terrain's step, Euler substeps walked a
gentle open-loop gait closer to the travel at half the step than RK4 substeps did
(benchmarks/results/sand_substeps.json, docs/terrain.md). The terrain owns the coupled bodies'
``xfrc_applied`` (the 3D stepper every body's): a perturbation there is not applied.

Every terrain is built by :func:`couple` from a robot whose coupled bodies are chosen: :func:`attach`
prepares the user's model and calls it, and terrasph's own robot scenes call it with their robots'
shapes; the 3D SPH bed, laid under the model's own geoms, is built by :func:`attach` alone (the
``mjcf`` scene on ``sph3d`` attaches its model as a user would). Their runs step the same
:class:`Terrain` (:meth:`Terrain.advance`, :func:`terrasph.robots.run.run_coupled`).

The floor: the model's horizontal planes (and the world's collision geoms whose top is at their
height) have their contacts switched off, one log line says so, and the sand's free surface lies
at the floor's height (terrasph.mjcf.terrain_robot). Coupled bodies: every body with a collision
geom, or those named (``bodies``), or those lower than ``couple_below`` above the floor now. A body
not coupled passes through the sand.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np

from terrasph.config import ConfigError, glass_beads
from terrasph.fidelity import DEFAULT_TIER, scene_numerics
from terrasph.mjcf.geoms import body_shape
from terrasph.mjcf.model import Coupling, PlanarRobot, body_name, check_body_masses, check_planar
from terrasph.mjcf.terrain_robot import check_couple_below, coupled_body_ids, floor_geoms, switch_off_floor
from terrasph.simulation import Simulation
from terrasph.sph3d import BED_MARGIN, BED_SPACING
from terrasph.terrain import rft
from terrasph.terrain.rft3d_coupling import RFT3DCoupling, Robot3D, bodies_3d
from terrasph.terrain.rft_coupling import RFT_TIME_STEP, NativeRFTStepper, RFTCoupling
from terrasph.terrain.sph3d_coupling import Coupled3D, CoupledBody3D, bed_under, body_shape_3d
from terrasph.terrain.sph_coupling import BED_NUMERICS, KICK_HEIGHT, CoupledSimulation, planar_sph_bed

__all__ = ["INTEGRATORS", "PLANAR_SPACING", "RFT3D_SUBSTEP", "SPH3D_BED", "SPH_BED", "TERRAINS", "RFTTerrain",
           "SPH3DTerrain", "SPHTerrain", "Terrain", "attach", "couple"]

#: the terrains :func:`attach` offers
TERRAINS = ("rft3d", "rft", "sph", "sph3d")

#: the particle spacing (m) of a planar body's shape (its drawing and lowest point; the RFT elements
#: follow the geoms' outline, :class:`terrasph.terrain.rft.SurfaceElements`), the scenes' Δx
PLANAR_SPACING = 0.005

#: the 3D RFT terrain's longest substep (s) here: gymnasium's Ant-v5 at 5 ms came within the seed scatter of
#: a 0.25 ms reference in travel and within 9 % in its feet's deepest sinkage, standing 0.1 mm off its sinkage,
#: at 0.55× the rigid environment's steps per second (1 ms: 0.18×); benchmarks/results/sand_substeps.json and
#: gym_sand_speed.json, docs/terrain.md. The run loop's scenes keep rft3d_coupling.RFT3D_TIME_STEP (the rover's travel, docs/rft.md)
RFT3D_SUBSTEP = 5e-3

#: the options of each terrain beyond `table` and `bodies` (:func:`attach`)
_OPTIONS = {"rft3d": ("couple_below", "time_step", "element_length", "integrator"),
            "rft": ("couple_below", "time_step", "element_length", "spacing", "integrator"),
            "sph": ("couple_below", "spacing", "bed_width", "bed_depth", "freeboard", "fidelity", "numerics",
                    "start_x", "widths", "integrator"),
            "sph3d": ("couple_below", "spacing", "bed_size", "bed_margin", "bed_depth", "freeboard", "fidelity",
                      "numerics", "integrator")}

#: the SPH bed of :func:`attach` unless its options say otherwise: 2 m of glass beads 10 cm deep at a
#: coarse 1 cm spacing (a lying Walker2d spans 1.5 m), 20 cm of container wall above them
SPH_BED = {"spacing": 0.01, "bed_width": 2.0, "bed_depth": 0.1, "freeboard": 0.2, "fidelity": DEFAULT_TIER}

#: the 3D SPH bed of :func:`attach` unless its options say otherwise: glass beads 15 cm deep at a coarse
#: 5 cm spacing (gymnasium's Ant's capsules are 16 cm thick, three wall layers at most), reaching
#: `bed_margin` beyond the coupled geoms on each side (or `bed_size` (x, y) across), its wall 10 cm
#: above the grains
SPH3D_BED = {"spacing": BED_SPACING, "bed_size": None, "bed_margin": BED_MARGIN, "bed_depth": 0.15, "freeboard": 0.1,
             "numerics": None, "fidelity": DEFAULT_TIER}

#: the integrators of the terrain's substeps (:func:`attach`'s option ``integrator``)
INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "model": None}

#: the part of MuJoCo's state that :meth:`Terrain.state` keeps: everything the next step reads
_MUJOCO_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


class Terrain:
    """A MuJoCo model and its data on a terrain (module docstring), built by :func:`attach`: what the
    terrains share. Each terrain says how it advances, what its loads and lowest points are and what
    its memory is (:class:`RFTTerrain`, :class:`SPHTerrain`)."""

    def __init__(self, kind: str, model: mujoco.MjModel, data: mujoco.MjData, coupled: Sequence[Any],
                 surface: float, model_step: float, integrator: int | None) -> None:
        self.kind, self.model, self.data = kind, model, data
        self._coupled = list(coupled)
        self._integrator = integrator
        self._surface = float(surface)
        self._model_step = model_step
        self._names = tuple(b.name for b in self._coupled)
        self._loads = self._no_loads()

    @property
    def bodies(self) -> tuple[str, ...]:
        """The names of the bodies the terrain carries, in the order of :meth:`loads`."""
        return self._names

    @property
    def surface(self) -> float:
        """The sand's free surface at the start, z (m): the model's floor height (RFT), the bed's (SPH)."""
        return self._surface

    @property
    def time_step(self) -> float:
        """The terrain's step (s) now."""
        raise NotImplementedError

    @property
    def leaked_grains(self) -> int:
        """Grains that have left the bed's domain (none on RFT, which has no grains)."""
        return 0

    def step(self, nstep: int = 1) -> None:
        """Advances the model and the sand by `nstep` × the model's ``opt.timestep`` (as
        ``mujoco.mj_step(model, data, nstep)`` would); :class:`terrasph.InstabilityError` if MuJoCo
        could not integrate a state (or the SPH bed went unstable). Afterwards each coupled body's
        ``xfrc_applied`` holds its load over the call (:meth:`loads`), as the sand's share of what
        ``mj_rnePostConstraint`` reports in ``cfrc_ext`` and a viewer draws; the next step replaces it."""
        if isinstance(nstep, bool) or not isinstance(nstep, (int, np.integer)) or nstep < 1:
            raise ConfigError(f"parameter 'nstep' = {nstep!r} is invalid: allowed an integer >= 1")
        self.coupling.reset_body_means()
        own_integrator = self.model.opt.integrator
        if self._integrator is not None:
            self.model.opt.integrator = self._integrator
        try:
            self._advance(int(nstep))
        finally:  # the model's own step and integrator, as the caller's env and viewer read them
            self.model.opt.timestep = self._model_step
            self.model.opt.integrator = own_integrator
        self._loads = self._mean_loads()
        for body, load in zip(self._coupled, self._loads.values()):
            self.data.xfrc_applied[body.body_id] = load

    def loads(self) -> dict[str, np.ndarray]:
        """Each coupled body's load from the sand over the last :meth:`step` call (each step's
        weighted by its dt), as MuJoCo's ``xfrc_applied`` holds one: force (3, N) and torque (3,
        N·m) about the body's centre of mass, world axes; NaN before the first step. On the planar
        terrains the torque is about y, moved from the body's frame origin to its centre of mass with
        the offset at the call's end."""
        return {name: load.copy() for name, load in self._loads.items()}

    def sinkage(self) -> dict[str, float]:
        """Each coupled body's depth below the free surface (m): the surface's z (the bed's undisturbed
        level now, on the SPH) less that of the body's lowest point now (negative while above it)."""
        surface = self._surface_now()
        return {name: surface - self._lowest(k) for k, name in enumerate(self._names)}

    def state(self) -> dict[str, Any]:
        """Everything the next step reads, as a copy: MuJoCo's integration state (``mj_getState``
        with ``mjSTATE_INTEGRATION``) and the terrain's memory; :meth:`restore` continues from it
        bit for bit."""
        mujoco_state = np.empty(mujoco.mj_stateSize(self.model, _MUJOCO_STATE))
        mujoco.mj_getState(self.model, self.data, mujoco_state, _MUJOCO_STATE)
        return {"mujoco": mujoco_state, "terrain": copy.deepcopy(self._memory()), "loads": self.loads()}

    def restore(self, state: dict[str, Any]) -> None:
        """Puts back a :meth:`state` of this terrain."""
        try:
            mujoco_state, memory, loads = state["mujoco"], state["terrain"], dict(state["loads"])
        except (KeyError, TypeError, ValueError):
            raise ConfigError("parameter 'state' is invalid: allowed a dict from Terrain.state()") from None
        if np.shape(mujoco_state) != (mujoco.mj_stateSize(self.model, _MUJOCO_STATE),):
            raise ConfigError("parameter 'state' is invalid: it belongs to another model (its MuJoCo state's size "
                              "differs)")
        mujoco.mj_setState(self.model, self.data, np.asarray(mujoco_state, dtype=float), _MUJOCO_STATE)
        self._put_memory(copy.deepcopy(memory))
        self._loads = {name: np.array(load, dtype=float) for name, load in loads.items()}

    def reset(self) -> None:
        """Starts the terrain afresh from the state now in ``data``, after the caller reset it
        (``mujoco.mj_resetData``, an environment's ``reset``): an undisturbed bed."""
        mujoco.mj_forward(self.model, self.data)
        self._restart()
        self._loads = self._no_loads()

    def _no_loads(self) -> dict[str, np.ndarray]:
        """The loads before a step: NaN."""
        return {name: np.full(6, math.nan) for name in self._names}

    def _planar_loads(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """Planar rows (F_x, F_z N, clockwise torque about the body origin N·m) as ``xfrc_applied`` rows."""
        loads = {}
        for body, (fx, fz, torque) in zip(self._coupled, rows):
            offset = self.data.xpos[body.body_id] - self.data.xipos[body.body_id]
            # τ_com = τ_ref + ((x_ref − x_com) × F)_y, (a × b)_y = a_z b_x − a_x b_z
            loads[body.name] = np.array([fx, 0.0, fz, 0.0, torque + offset[2] * fx - offset[0] * fz, 0.0])
        return loads

    # -- what a run of terrasph's own asks of it (terrasph.robots.run.run_coupled) -----------------
    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """Steps the coupling at its own step until `t_end` (s) is reached or passed, at most
        `max_steps` steps; returns the number taken. `control`, if given, is called with the coupling
        before each step or each control interval (the coupling's ``advance`` says which); the loads
        of :meth:`loads` and ``xfrc_applied`` are the coupling's, not replaced here (a run records
        them itself). The steps use the terrain's integrator, as :meth:`step`'s do."""
        own_integrator = self.model.opt.integrator
        if self._integrator is not None:
            self.model.opt.integrator = self._integrator
        try:
            return int(self.coupling.advance(t_end, max_steps, control))
        finally:
            self.model.opt.integrator = own_integrator

    # -- what each terrain says ------------------------------------------------------------------
    #: the coupling beneath: the stepper that advances the model and the sand (its type is the terrain's)
    coupling: Any

    def _advance(self, nstep: int) -> None:
        raise NotImplementedError

    def _mean_loads(self) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def _lowest(self, k: int) -> float:
        raise NotImplementedError

    def _surface_now(self) -> float:
        return self._surface

    def _memory(self) -> dict[str, Any]:
        raise NotImplementedError

    def _put_memory(self, memory: dict[str, Any]) -> None:
        raise NotImplementedError

    def _restart(self) -> None:
        raise NotImplementedError


class RFTTerrain(Terrain):
    """The planar or 3D RFT terrain (:class:`NativeRFTStepper`): `substeps` steps of the compiled
    stepper per model step, all of a call's in one call into it."""

    def __init__(self, kind: str, coupling: NativeRFTStepper, surface: float, substeps: int, model_step: float,
                 integrator: int | None) -> None:
        self.coupling = coupling
        self._substeps = substeps
        super().__init__(kind, coupling.robot.model, coupling.robot.data, coupling.robot.coupled, surface, model_step,
                         integrator)

    @property
    def time_step(self) -> float:
        """The terrain's step (s): the model's ``opt.timestep`` cut into equal substeps."""
        return self.coupling.time_step()

    def _advance(self, nstep: int) -> None:
        self.coupling.steps(nstep * self._substeps)

    def _mean_loads(self) -> dict[str, np.ndarray]:
        means = self.coupling.load_means()
        if self.kind == "rft3d":
            return {name: row.copy() for name, row in zip(self._names, means)}
        return self._planar_loads(means)

    def _lowest(self, k: int) -> float:
        return self.coupling.lowest_z(k)

    def _memory(self) -> dict[str, Any]:
        return {"stepper": self.coupling.state(), "step_count": self.coupling.step_count}

    def _put_memory(self, memory: dict[str, Any]) -> None:
        self.coupling.restore_state(memory["stepper"])
        self.coupling.step_count = int(memory["step_count"])

    def _restart(self) -> None:
        self.coupling.restart()


class _SPHBedTerrain(Terrain):
    """What the SPH terrains share: the coupled step at the SPH's step bound (``stepper``, on the
    compiled simulation ``core``), until the model's time is reached (the target kept, so steps
    that end past it do not add up); the undisturbed bed is the one built by :func:`attach`; the
    memory is the SPH's whole state with the coupling's own."""

    def __init__(self, kind: str, model: mujoco.MjModel, data: mujoco.MjData, coupling: Any, core: Any,
                 coupled: Sequence[Any], surface: float, model_step: float, integrator: int | None) -> None:
        self.coupling, self._core = coupling, core
        self._target = coupling.time
        self._bed = copy.deepcopy(core.state())
        super().__init__(kind, model, data, coupled, surface, model_step, integrator)

    @property
    def time_step(self) -> float:
        """The SPH's step (s) now: its stable bound."""
        return float(self.coupling.time_step())

    @property
    def leaked_grains(self) -> int:
        """Grains that have been inside a wall or body at any step (the leak counter)."""
        return int(self._core.penetrated_particles)

    def advance(self, t_end: float, max_steps: int = 2**62, control: Callable[[Any], None] | None = None) -> int:
        """As :meth:`Terrain.advance`; the model's time :meth:`step` counts from is then `t_end`
        (or as far as the steps got)."""
        taken = super().advance(t_end, max_steps, control)
        self._target = max(self._target, min(float(t_end), self.coupling.time))
        return taken

    def _advance(self, nstep: int) -> None:
        self._target += nstep * self._model_step
        self.coupling.advance(self._target)

    def _memory(self) -> dict[str, Any]:
        return {"sph": self._core.state(), "coupling": self.coupling.state(), "target": self._target}

    def _put_memory(self, memory: dict[str, Any]) -> None:
        self._core.restore(memory["sph"])
        self.coupling.restore_state(memory["coupling"])
        self._target = float(memory["target"])

    def _restart(self) -> None:
        self._core.restore(copy.deepcopy(self._bed))
        self.coupling.restart()
        self._target = self.coupling.time


class SPHTerrain(_SPHBedTerrain):
    """A planar model on the SPH bed (:class:`terrasph.terrain.sph_coupling.CoupledSimulation`)."""

    def __init__(self, coupled: CoupledSimulation, model_step: float, integrator: int | None) -> None:
        super().__init__("sph", coupled.robot.model, coupled.robot.data, coupled, coupled.sim.core, coupled.robot.coupled,
                         coupled.surface(), model_step, integrator)

    def _mean_loads(self) -> dict[str, np.ndarray]:
        samples = [self.coupling.body_sample(name) for name in self._names]
        return self._planar_loads(np.array([(s["force"][0], s["force"][1], s["torque"]) for s in samples]))

    def _lowest(self, k: int) -> float:
        return float(self.coupling.body_sample(self._names[k])["lowest_z"])

    def _surface_now(self) -> float:
        return self.coupling.surface()


class SPH3DTerrain(_SPHBedTerrain):
    """A 3D model on a 3D SPH bed (:class:`terrasph.terrain.sph3d_coupling.Coupled3D`)."""

    def __init__(self, coupled: Coupled3D, model_step: float, integrator: int | None) -> None:
        super().__init__("sph3d", coupled.model, coupled.data, coupled, coupled.core, coupled.coupled, coupled.surface,
                         model_step, integrator)

    def _mean_loads(self) -> dict[str, np.ndarray]:
        return {name: self.coupling.mean_load(k) for k, name in enumerate(self._names)}

    def _lowest(self, k: int) -> float:
        return self.coupling.lowest_z(k)

    def _put_memory(self, memory: dict[str, Any]) -> None:
        super()._put_memory(memory)
        mujoco.mj_forward(self.model, self.data)  # the derived poses sinkage() reads


def _sph3d_terrain(model: mujoco.MjModel, data: mujoco.MjData, bodies: Sequence[str], couple_below: float | None,
                   options: dict[str, Any], model_step: float, integrator: int | None) -> SPH3DTerrain:
    """The 3D SPH terrain of :func:`attach` (its options checked before the model's floor is switched off)."""
    settings = {**SPH3D_BED, **{k: v for k, v in options.items() if k not in ("integrator", "couple_below")}}
    for name in ("spacing", "bed_depth"):
        _check_number(name, settings[name], positive=True)
    for name in ("bed_margin", "freeboard"):
        _check_number(name, settings[name], positive=False)
    size = settings["bed_size"]
    if size is not None:
        if not (isinstance(size, (tuple, list)) and len(size) == 2):
            raise ConfigError(f"parameter 'bed_size' = {size!r} is invalid: allowed None or (x, y) in m, each > 0")
        for value in size:
            _check_number("bed_size", value, positive=True)
    numerics = scene_numerics("mjcf", settings["fidelity"], float(settings["spacing"]), BED_NUMERICS,
                              dict(settings["numerics"] or {}))
    floor, level = floor_geoms(model, data)
    chosen = coupled_body_ids(model, data, level, tuple(bodies), couple_below)
    check_body_masses(model, chosen)
    coupled = [CoupledBody3D(name, body, body_shape_3d(model, body, name, numerics.spacing, numerics.h_factor))
               for body, name in ((b, body_name(model, b)) for b in chosen)]
    points = np.concatenate([b.shape.position @ data.xmat[b.body_id].reshape(3, 3).T + data.xpos[b.body_id]
                             for b in coupled])
    material = glass_beads()
    bed = bed_under((points.min(axis=0), points.max(axis=0)), level, size, float(settings["bed_margin"]),
                    float(settings["bed_depth"]), material, numerics.spacing, numerics.h_factor,
                    float(settings["freeboard"]))
    stepper = Coupled3D(model, data, coupled, bed, level, material, numerics, KICK_HEIGHT)
    switch_off_floor(model, floor)
    model.opt.timestep = model_step
    mujoco.mj_forward(model, data)
    return SPH3DTerrain(stepper, model_step, integrator)


def _check_number(name: str, value: Any, positive: bool) -> None:
    """ConfigError naming `name` unless `value` is a finite number > 0 (`positive`) or >= 0 (m)."""
    if isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value)
                                       and (value > 0 if positive else value >= 0)):
        raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number "
                          f"{'>' if positive else '>='} 0 (m)")


def attach(model: mujoco.MjModel, data: mujoco.MjData, terrain: str = "rft3d", table: rft.RFTCoefficients | str = "generic",
           bodies: Sequence[str] | None = None, **options: Any) -> Terrain:
    """Puts the compiled `model` and its `data` on `terrain` (one of :data:`TERRAINS`) with the RFT
    coefficient map `table` (a name of :func:`terrasph.terrain.rft.coefficient_table` or a map) and returns
    the :class:`Terrain` that steps them (module docstring). `bodies`: the names of the bodies that
    meet the sand (default: every body with a collision geom). Options (each terrain's list:
    ``couple_below`` (m): couple only the bodies lower than this above the floor now; ``time_step``
    (s): the terrain's longest step; ``element_length`` (m): the RFT elements' size; ``spacing``
    (m, planar): the bodies' particle spacing, :data:`PLANAR_SPACING`; ``integrator``: MuJoCo's
    integrator in the terrain's substeps, ``"euler"`` (default: the implicit correction's own
    scheme; the measured choice, module docstring) or ``"model"`` (the model's ``opt.integrator``);
    the SPH beds' options: :data:`SPH_BED` (planar), :data:`SPH3D_BED` (3D: ``spacing`` (m) of the
    grains and the bodies' particles, ``bed_size`` (x, y; m) or ``bed_margin`` (m) beyond the
    coupled geoms, ``bed_depth``, ``freeboard`` (m), ``fidelity``, ``numerics``).

    Refused before anything is changed, as :class:`terrasph.config.ConfigError` naming the item: a
    terrain, table or option not offered; gravity not along −z; a model the planar terrain cannot
    carry (naming its joint or body); no body to couple, a named body the model lacks, a coupled
    body without mass; on the 3D SPH a geom it does not fill (mesh, plane, …) or too thin for the
    spacing. On success the model's floor is switched off (logged)."""
    if not isinstance(model, mujoco.MjModel) or not isinstance(data, mujoco.MjData):
        raise ConfigError("parameters 'model' and 'data' must be a compiled mujoco.MjModel and its mujoco.MjData")
    if terrain not in TERRAINS:
        raise ConfigError(f"parameter 'terrain' = {terrain!r} is invalid: allowed one of {', '.join(TERRAINS)}")
    unknown = sorted(set(options) - set(_OPTIONS[terrain]))
    if unknown:
        raise ConfigError(f"parameter '{unknown[0]}' is not an option of terrain {terrain!r}: allowed "
                          f"{', '.join(_OPTIONS[terrain])}")
    if terrain in ("sph", "sph3d") and table != "generic":
        raise ConfigError(f"parameter 'table' = {table!r} is invalid on the SPH terrains: allowed only its default "
                          "'generic' there (it sets the RFT terrains' sand; the SPH's is its bed)")
    table = rft.coefficient_table(table)
    gravity = _downward_gravity(model)
    model_step = float(model.opt.timestep)
    integrator = options.get("integrator", "euler")
    if integrator not in INTEGRATORS:
        raise ConfigError(f"parameter 'integrator' = {integrator!r} is invalid: allowed one of {', '.join(INTEGRATORS)}")
    longest = options.get("time_step", RFT3D_SUBSTEP if terrain == "rft3d" else RFT_TIME_STEP)
    if isinstance(longest, bool) or not (isinstance(longest, (int, float)) and math.isfinite(longest) and longest > 0):
        raise ConfigError(f"parameter 'time_step' = {longest!r} is invalid: allowed a finite number > 0 (s)")
    substeps = max(1, math.ceil(model_step / longest * (1 - 1e-12)))
    couple_below = options.get("couple_below")
    if couple_below is not None:
        check_couple_below(couple_below)
    mujoco.mj_forward(model, data)
    if terrain == "sph":
        _check_planar(model, data, "sph")
        planar, simulation = planar_sph_bed(model, data=data, bodies=tuple(bodies or ()), couple_below=couple_below,
                                            **{**SPH_BED, **{k: v for k, v in options.items() if k != "integrator"}})
        sand = couple(planar, "sph", simulation=simulation, model_step=model_step, integrator=INTEGRATORS[integrator])
        model.opt.timestep = model_step
        mujoco.mj_forward(model, data)
        return sand
    if terrain == "sph3d":
        return _sph3d_terrain(model, data, tuple(bodies or ()), couple_below, options, model_step,
                              INTEGRATORS[integrator])
    floor, level = floor_geoms(model, data)
    chosen = coupled_body_ids(model, data, level, tuple(bodies or ()), couple_below)
    check_body_masses(model, chosen)
    steps: dict[str, Any] = {"time_step": model_step / substeps, "control_interval": model_step}
    if terrain == "rft3d":
        coupled = bodies_3d(model, chosen, options.get("element_length"))
        switch_off_floor(model, floor)
        sand = couple(Robot3D(model, data, coupled, level), "rft3d", table, substeps=substeps, model_step=model_step,
                      integrator=INTEGRATORS[integrator], **steps)
    else:
        _check_planar(model, data, "rft")
        spacing = options.get("spacing", PLANAR_SPACING)
        couplings = {body_name(model, b): Coupling(body_shape(model, b, spacing)) for b in chosen}
        sand = couple(PlanarRobot(model, couplings, gravity=gravity, data=data), "rft", table, surface=level,
                      substeps=substeps, model_step=model_step, integrator=INTEGRATORS[integrator],
                      element_length=options.get("element_length"), **steps)
        switch_off_floor(model, floor)
    model.opt.timestep = model_step
    mujoco.mj_forward(model, data)
    return sand


def couple(robot: PlanarRobot | Robot3D, terrain: str, table: rft.RFTCoefficients | str = "generic", *,
           surface: float | None = None, simulation: Simulation | None = None, substeps: int = 1,
           model_step: float | None = None, integrator: int | None = None, **coupling_options: Any) -> Terrain:
    """The one construction of a terrain for a robot whose coupled bodies are chosen: :func:`attach`'s,
    once it has prepared the user's model, and terrasph's own scenes', whose bodies carry shapes of
    their own. Builds the coupling of `terrain` on `robot` and returns the :class:`Terrain` over it:

    * ``"rft"``: a :class:`~terrasph.mjcf.model.PlanarRobot` on planar RFT (:class:`RFTCoupling`)
      with the map `table` and its free surface at z = `surface` (m);
    * ``"rft3d"``: a :class:`~terrasph.terrain.rft3d_coupling.Robot3D` on 3D RFT
      (:class:`RFT3DCoupling`), its surface the robot's;
    * ``"sph"``: a PlanarRobot already added to the scene of `simulation` (a
      :class:`terrasph.Simulation`), coupled with it (:class:`CoupledSimulation`).

    `coupling_options` go to the RFT coupling (``time_step``, ``control_interval``, planar
    ``element_length``; their defaults are the coupling's). :meth:`Terrain.step` then advances
    `model_step` (s; default `substeps` of the RFT coupling's steps, the model's ``opt.timestep`` on
    the SPH) per model step, in `substeps` RFT steps, with MuJoCo's `integrator` (None: the model's);
    :meth:`Terrain.advance` steps the coupling at its own step, as a run does."""
    if terrain == "rft":
        planar = RFTCoupling(robot, surface, table, **coupling_options)  # type: ignore[arg-type]
        step = planar.time_step() * substeps if model_step is None else model_step
        return RFTTerrain("rft", planar, planar.surface_level, substeps, step, integrator)
    if terrain == "rft3d":
        spatial = RFT3DCoupling(robot, table, **coupling_options)  # type: ignore[arg-type]
        step = spatial.time_step() * substeps if model_step is None else model_step
        return RFTTerrain("rft3d", spatial, spatial.robot.surface, substeps, step, integrator)
    if terrain == "sph" and isinstance(simulation, Simulation):
        step = float(robot.model.opt.timestep) if model_step is None else model_step
        return SPHTerrain(CoupledSimulation(robot, simulation), step, integrator)  # type: ignore[arg-type]
    raise ConfigError(f"parameter 'terrain' = {terrain!r} is invalid for couple(): allowed 'rft', 'rft3d' or 'sph' "
                      "with its simulation")


def _downward_gravity(model: mujoco.MjModel) -> float:
    """g (m/s²) of the model's gravity (0, 0, −g); ConfigError otherwise: the sand's surface is level
    and its resistance scales with depth along gravity."""
    gx, gy, gz = (float(v) for v in model.opt.gravity)
    if not (gx == 0.0 and gy == 0.0 and gz < 0.0):
        raise ConfigError(f"the model's option 'gravity' = {[gx, gy, gz]} is invalid on the sand: allowed (0, 0, -g) "
                          "with g > 0 (the sand's surface is level)")
    return -gz


def _check_planar(model: mujoco.MjModel, data: mujoco.MjData, terrain: str) -> None:
    """ConfigError naming the first joint or body that is not planar, with the terrain that takes any model."""
    try:
        check_planar(model, data)
    except ConfigError as error:
        raise ConfigError(f"{error}; the planar terrain {terrain!r} takes planar models only: attach this one with "
                          "terrain 'rft3d'") from None
