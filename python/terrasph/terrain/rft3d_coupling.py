"""Any MuJoCo robot — hinges about any axis, free joints — on a flat 3D RFT terrain (terrasph.terrain.rft3d).

:func:`rft_robot` reads the MJCF model as the SPH terrain does (:func:`terrasph.mjcf.terrain_robot.
terrain_model`: the floor switched off, the bodies near it coupled) and gives each coupled body its
collision geoms' surface as 3D RFT elements; the free surface is the floor's height, the model's
frame is kept. :class:`RFT3DCoupling` is the run loop's stepper (terrasph.run_loop.Stepper, driven by
:func:`terrasph.robots.run.run_coupled`). Each step of dt, from the state at t_n:

1. each coupled body's RFT wrench W_n (force and torque about its centre of mass, world frame) at
   the state of t_n goes into MuJoCo's ``xfrc_applied`` and MuJoCo steps: velocities q̇*, poses q*;
2. the step is made backward Euler in the RFT load: M (q̇ − q̇*) = dt (G(q̇) − G_n), G = Σ_b J_bᵀ W_b(J_b q̇)
   the generalised load (J_b the body's 6 × nv Jacobian at its centre of mass, at t_n's pose), solved
   by Newton's method (at most :data:`NEWTON_ITERATIONS`, each step halved while it does not reduce
   the residual) with the wrenches' velocity Jacobians, those of the element law's analytic one
   (cpp/src/rft3d.cpp); the positions move by dt (q̇ − q̇*). The torque-limited velocity servos take
   the step as plain forces, their force at t_n, corrected in the Newton solve as the wrenches are.
   Where no halving lowers the residual (a kink of the regularised load) the iterations stop with the
   best velocities so far: in a drop onto the sand a good share of the impact's steps end so, and the
   settled sinkage depends on those stops at the level of a few per cent (docs/rft.md, "3D RFT").

Why implicit, as in the planar stepper (terrasph.terrain.rft_coupling): the regularised load's
derivative in the normal speed is F / v_ε with v_ε = 0.1 mm/s, a damping that an explicit step
of dt cannot carry unless dt < 2 m v_ε / F, i.e. microseconds for a robot resting on the sand
(docs/rft.md, "3D RFT"). The loads are taken at the step's start pose.
MuJoCo's other actuators act inside its step as usual.

The step runs in the compiled core (``terrasph._core.Robot3DStepper``, cpp/src/rft3d_robot.cpp),
which calls the MuJoCo library of the ``mujoco`` package on the robot's own ``model`` and ``data``,
as the planar stepper (terrasph.terrain.rft_coupling) does: :meth:`RFT3DCoupling.advance` takes the
steps of a whole control interval per Python call. A state MuJoCo cannot integrate (it then resets
the robot) raises :class:`terrasph.InstabilityError`, checked after each such call.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from terrasph import _core
from terrasph.mjcf.model import body_name, check_body_masses
from terrasph.mjcf.terrain_robot import COUPLE_BELOW, terrain_model
from terrasph.terrain import rft
from terrasph.terrain.rft3d import BodyElements, body_wrench
from terrasph.terrain.rft_coupling import RFT_CONTROL_INTERVAL, NativeRFTStepper, mujoco_library
from terrasph.terrain.sph_coupling import (
    _velocity_servos,
    divergences,
    mujoco_state,
    restore_mujoco_state,
)

__all__ = [
    "RFT3D_TIME_STEP",
    "RFT3DCoupling",
    "Robot3D",
    "bodies_3d",
    "rft_robot",
]

#: MuJoCo's step on the 3D RFT terrain (s): chosen when the numpy stepper read the rover's travel at 1e-3 s
#: within 0.3 % of that at 5e-4 s (2e-3 s 12 % short); the native one reads 5 % apart, within the spread
#: the drop's implicit solve leaves in it (docs/rft.md, "3D RFT"; benchmarks/studies/rft3d_rover.py)
RFT3D_TIME_STEP = 1e-3

#: Newton iterations per step at most, halvings of a step that fails to reduce the residual, and the
#: residual (its largest component relative to the larger of the step's momentum M q̇* and impulse
#: dt G_n) at which the iterations stop; the solver, shared by both steppers: cpp/src/backward_euler.hpp.
#: 20 halvings: with 6, Ant-v5 standing on the sand at 5 ms substeps never came to rest (its lift
#: swung 0.78–1.07 × its weight from one 0.05 s window to the next: Newton stopped on the kinks of
#: the regularised load), with 12 or more it rests, its lift its weight (benchmarks/results/sand_substeps.json)
NEWTON_ITERATIONS = 12
NEWTON_HALVINGS = 20
NEWTON_TOLERANCE = 1e-8


@dataclass(frozen=True)
class Body3D:
    """A coupled MuJoCo body: its `name`, `body_id` and RFT `elements` (in its frame)."""

    name: str
    body_id: int
    elements: BodyElements


class Robot3D:
    """A MuJoCo model (any joints) and the bodies that meet the terrain: ``model``, ``data`` and
    ``coupled`` (:class:`Body3D`), the names MuJoCo gives them; `surface` is the floor's height (m)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, coupled: Sequence[Body3D], surface: float) -> None:
        self.model, self.data, self.coupled, self.surface = model, data, list(coupled), float(surface)


def rft_robot(mjcf: str | os.PathLike[str] | mujoco.MjModel, *, bodies: Sequence[str] = (),
              couple_below: float = COUPLE_BELOW, element_length: float | None = None) -> Robot3D:
    """The MJCF model on the 3D RFT terrain: the floor switched off and the coupled bodies chosen as
    on the SPH terrain (:func:`terrasph.mjcf.terrain_robot.terrain_model`), each with its collision
    geoms' surface as elements about `element_length` m across
    (:meth:`terrasph.terrain.rft3d.BodyElements.from_body`); the free surface at the floor's height."""
    model, data, level, chosen = terrain_model(mjcf, bodies=bodies, couple_below=couple_below)
    return Robot3D(model, data, bodies_3d(model, chosen, element_length), level)


def bodies_3d(model: mujoco.MjModel, chosen: Sequence[int], element_length: float | None = None) -> list[Body3D]:
    """The bodies `chosen` (ids) of the model, each with its collision geoms' surface as elements
    about `element_length` m across (:meth:`terrasph.terrain.rft3d.BodyElements.from_body`); ConfigError
    naming the world body or a body without mass (:func:`terrasph.mjcf.model.check_body_masses`)."""
    check_body_masses(model, chosen)
    return [Body3D(body_name(model, body), body, BodyElements.from_body(model, body, element_length)) for body in chosen]


class RFT3DCoupling(NativeRFTStepper):
    """A :class:`Robot3D` on the flat 3D RFT terrain with coefficient map `table` (module docstring);
    `time_step` (s) is MuJoCo's step; `control_interval` (s) how often :meth:`advance` calls a
    controller, its commands held in between."""

    LOAD_SIZE = 6  # force (N) and torque about the centre of mass (N·m), world axes

    def __init__(self, robot: Robot3D, table: rft.RFTCoefficients | str = "generic", *,
                 time_step: float = RFT3D_TIME_STEP, control_interval: float | None = None) -> None:
        self.robot = robot
        self._start(time_step, RFT_CONTROL_INTERVAL if control_interval is None else control_interval)
        self.table = rft.coefficient_table(table)
        model = robot.model
        model.opt.timestep = self._dt  # MuJoCo's step is the implicit correction's dt
        mujoco.mj_forward(model, robot.data)
        self._native = _core.Robot3DStepper(
            mujoco_library(), model._address, robot.data._address,
            [(b.body_id, b.elements.centre, b.elements.normal, b.elements.area) for b in robot.coupled],
            [(s.actuator, s.dof, s.kv, s.gear, s.lower, s.upper) for s in _velocity_servos(model, robot.data)],
            robot.surface, self.table.terms, self.table.zeta, self._dt, rft.REGULARISATION_SPEED,
            NEWTON_ITERATIONS, NEWTON_HALVINGS, NEWTON_TOLERANCE)

    # -- what the run loop records --------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """The terrain and the coupled bodies, for the run file."""
        return {"terrain": {"kind": "rft3d", "surface": self.robot.surface, "zeta": self.table.zeta,
                            "coefficients": dict(self.table.coefficients),
                            "source": self.table.source, "time_step": self._dt,
                            "elements": {b.name: len(b.elements) for b in self.robot.coupled}},
                "robot": {"coupled": [b.name for b in self.robot.coupled], "mujoco": mujoco.__version__}}

    def body_sample(self, k: int) -> dict[str, Any]:
        """Coupled body `k`'s RFT force (N) and torque (N·m, about its centre of mass), world frame,
        averaged since :meth:`reset_body_means` (the load of each step weighted by its dt; the load
        now before any step), and its lowest element's z (m)."""
        body, model, data = self.robot.coupled[k], self.robot.model, self.robot.data
        if self.time > self._since:
            wrench = self.load_means()[k]
        else:
            mujoco.mj_forward(model, data)
            twist = np.zeros(6)  # [angular, linear] at the centre of mass, world axes
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body.body_id, twist, 0)
            wrench = np.concatenate(body_wrench(body.elements, data.xpos[body.body_id],
                                                data.xmat[body.body_id].reshape(3, 3), data.xipos[body.body_id],
                                                twist[3:], twist[:3], self.robot.surface, self.table))
        return {"force": wrench[:3].copy(), "torque": wrench[3:].copy(), "lowest_z": self.lowest_z(k)}

    def lowest_z(self, k: int) -> float:
        """The lowest z (m) of coupled body `k`'s element centres now."""
        body, data = self.robot.coupled[k], self.robot.data
        rotation = data.xmat[body.body_id].reshape(3, 3)
        return float((data.xpos[body.body_id] + body.elements.centre @ rotation.T)[:, 2].min())

    def frame_fields(self) -> dict[str, np.ndarray]:
        """A frame of the coupled bodies (no grains): their elements' centres seen from the side,
        ``body_position`` (x, z) m, and the velocities there, ``body_velocity`` (v_x, v_z) m/s."""
        data = self.robot.data
        positions, velocities = [], []
        for body in self.robot.coupled:
            b = body.body_id
            rotation = data.xmat[b].reshape(3, 3)
            points = data.xpos[b] + body.elements.centre @ rotation.T
            twist = np.zeros(6)
            mujoco.mj_objectVelocity(self.robot.model, data, mujoco.mjtObj.mjOBJ_XBODY, b, twist, 0)
            velocity = twist[3:] + np.cross(twist[:3], points - data.xpos[b])
            positions.append(points[:, [0, 2]])
            velocities.append(velocity[:, [0, 2]])
        return {"body_position": np.concatenate(positions), "body_velocity": np.concatenate(velocities)}

    def static_arrays(self) -> dict[str, np.ndarray]:
        """Each coupled body's elements in its frame (``/static/rft3d/<body>/...``) and the body of each
        row of the frames' body fields (``/static/bodies/index``)."""
        arrays = {"bodies/index": np.concatenate([np.full(len(b.elements), k, dtype=np.int32)
                                                  for k, b in enumerate(self.robot.coupled)])}
        for body in self.robot.coupled:
            arrays.update({f"rft3d/{body.name}/centre": body.elements.centre,
                           f"rft3d/{body.name}/normal": body.elements.normal,
                           f"rft3d/{body.name}/area": body.elements.area})
        return arrays

    def state(self) -> dict[str, Any]:
        """MuJoCo's state and the stepper's memory as plain data (a checkpoint's ``progress["robot"]``)."""
        sums = self._native.load_sums
        return {**mujoco_state(self.robot), "sums": [sums[6 * k:6 * k + 6] for k in range(len(self.robot.coupled))],
                "since": self._since}

    def restore_state(self, saved: dict[str, Any]) -> None:
        """Puts back a :meth:`state`."""
        restore_mujoco_state(self.robot, saved)
        self._divergences = divergences(self.robot.data)
        self._native.load_sums = [float(v) for row in saved["sums"] for v in row]
        self._since = float(saved["since"])
