"""Planar robots from MJCF (docs/design.md §3.6): loading, the planar check, pairing MuJoCo bodies with
terrasph body shapes, and the mass and inertia of a shape.

Sign convention, verified in ``tests/test_robots.py``: MuJoCo's z is up like terrasph's, and a
rotation by +φ about MuJoCo's +y axis maps (x, z) to (x cos φ + z sin φ, −x sin φ + z cos φ) —
exactly :func:`terrasph.bodies.rotation_matrix`, terrasph's *clockwise* rotation (x right, z up).
So a body's terrasph angle, spin, angular acceleration and torque are MuJoCo's y components,
with no change of sign.
"""

from __future__ import annotations

import contextlib
import math
import os
import pathlib
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from terrasph.bodies import BodyShape
from terrasph.config import ConfigError
from terrasph.scene import Scene

__all__ = ["CoupledBody", "Coupling", "Inertial", "MujocoWarning", "PlanarRobot", "body_name", "check_body_masses",
           "check_planar",
           "load_model", "mujoco_warnings", "shape_inertial"]


class MujocoWarning(UserWarning):
    """A warning of MuJoCo's (its compiler's, e.g. a deprecated attribute of a user's model, or its
    simulation's, e.g. a state it cannot integrate), passed on through Python's warnings."""


@contextlib.contextmanager
def mujoco_warnings() -> Iterator[None]:
    """For the block, MuJoCo's warnings reach the user as Python warnings (:class:`MujocoWarning`:
    shown once per message, filtered and caught as any warning) instead of MuJoCo's default, a line
    appended to MUJOCO_LOG.TXT in the working directory. MuJoCo's handler is process-wide: it is
    installed only here, never at import, and the previous one is put back after the block. (MuJoCo's
    errors already reach Python as exceptions: the bindings raise them.)"""
    previous = mujoco.get_mju_user_warning()

    def warn(text: str) -> None:
        warnings.warn(f"MuJoCo: {' '.join(str(text).split())}", MujocoWarning, stacklevel=2)

    mujoco.set_mju_user_warning(warn)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)

#: tolerance of the planar checks on unit axes and rotation matrices
_PLANAR_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Coupling:
    """How a MuJoCo body meets the terrain: its particle `shape` in the body's frame (x, z, the
    body origin at the shape's reference point) and the real out-of-plane `width` in m (default:
    the shape's width), for which its granular loads are reported and applied."""

    shape: BodyShape
    width: float | None = None


@dataclass(frozen=True)
class CoupledBody:
    """A MuJoCo body paired with a terrasph driven body of the same name."""

    name: str
    body_id: int
    shape: BodyShape
    width: float


@dataclass(frozen=True)
class Inertial:
    """Mass (kg), centre of mass (x, z in the shape's frame, m) and the 3×3 inertia tensor about the
    centre of mass (kg·m², MuJoCo's axes: x, y out of plane, z) of a shape of uniform density."""

    mass: float
    centre: tuple[float, float]
    inertia: np.ndarray

    def mjcf(self) -> str:
        """The ``<inertial>`` element for an MJCF body whose frame is the shape's frame."""
        i = [float(v) for v in (self.inertia[0, 0], self.inertia[1, 1], self.inertia[2, 2], self.inertia[0, 1],
                                self.inertia[0, 2], self.inertia[1, 2])]
        return (f'<inertial pos="{self.centre[0]!r} 0 {self.centre[1]!r}" mass="{self.mass!r}" '
                f'fullinertia="{" ".join(repr(v) for v in i)}"/>')


def shape_inertial(shape: BodyShape, density: float, width: float | None = None) -> Inertial:
    """Mass and inertia of `shape` made of a solid of `density` (kg/m³) and out-of-plane `width`
    (m, default the shape's): each particle is a Δx × Δx × width cell centred on it and on y = 0."""
    if not (isinstance(shape, BodyShape)):
        raise ConfigError("parameter 'shape' must be a terrasph.bodies.BodyShape")
    width = shape.width if width is None else width
    if not (density > 0 and math.isfinite(density)):
        raise ConfigError(f"parameter 'density' = {density!r} is invalid: allowed a finite number > 0 (kg/m³)")
    if not (width > 0 and math.isfinite(width)):
        raise ConfigError(f"parameter 'width' = {width!r} is invalid: allowed a finite number > 0 (m)")
    dx = shape.spacing
    cell = density * dx * dx * width  # mass of one particle's cell
    mass = cell * len(shape)
    centre = shape.position.mean(axis=0)
    x, z = (shape.position - centre).T
    # a cell's own inertia about its centre: (a² + b²)/12 per unit mass for sides a, b
    own_xz, own_xy = dx * dx / 12.0, width * width / 12.0
    ixx = cell * float(np.sum(z * z + dx * dx / 12.0 + own_xy))
    iyy = cell * float(np.sum(x * x + z * z + 2.0 * own_xz))
    izz = cell * float(np.sum(x * x + dx * dx / 12.0 + own_xy))
    ixz = -cell * float(np.sum(x * z))
    inertia = np.array([[ixx, 0.0, ixz], [0.0, iyy, 0.0], [ixz, 0.0, izz]])
    return Inertial(float(mass), (float(centre[0]), float(centre[1])), inertia)


def load_model(mjcf: str | os.PathLike[str] | mujoco.MjModel) -> mujoco.MjModel:
    """Compiles an MJCF file or XML string (a compiled model is taken as it is); MuJoCo's compile
    errors become ConfigErrors."""
    if isinstance(mjcf, mujoco.MjModel):
        return mjcf
    text = os.fspath(mjcf)
    is_xml = text.lstrip().startswith("<")
    if not is_xml and not pathlib.Path(text).is_file():
        raise ConfigError(f"parameter 'mjcf' = {text!r}: no such file (give a path or an XML string)")
    try:
        with mujoco_warnings():
            return mujoco.MjModel.from_xml_string(text) if is_xml else mujoco.MjModel.from_xml_path(text)
    except ValueError as error:  # MuJoCo's message spans lines (an XML parse error's text is on the second)
        raise ConfigError(f"the MJCF model does not compile: {' '.join(str(error).split())}") from None


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int) -> str:
    if kind == mujoco.mjtObj.mjOBJ_BODY:
        return body_name(model, index)
    return mujoco.mj_id2name(model, kind, index) or f"#{index}"


def body_name(model: mujoco.MjModel, body: int) -> str:
    """The name a body goes by in terrasph (series, figures, messages, ``--bodies``): its MJCF name;
    for an unnamed body (gymnasium's ant names its lower legs' bodies only by their geoms) its first
    named geom's name without a ``_geom`` ending, as ``left_ankle``, if no body has that name; else
    its parent's name and its id, as ``aux_1/#4``."""
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body)
    if name:
        return name
    for geom in range(int(model.body_geomadr[body]), int(model.body_geomadr[body] + model.body_geomnum[body])):
        geom_name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom)
        if geom_name:
            readable = geom_name.removesuffix("_geom")
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, readable) < 0:
                return readable
    parent = int(model.body_parentid[body])
    return f"{body_name(model, parent) if parent > 0 else 'world'}/#{body}"


def coupled_body_id(model: mujoco.MjModel, name: str) -> int:
    """The id of the body `name` that is to meet the terrain; ConfigError listing the model's bodies
    if it has none of that name."""
    body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    if body_id < 0:  # an unnamed body, by the name terrasph gives it
        body_id = next((b for b in range(1, model.nbody) if body_name(model, b) == name), -1)
    if body_id < 0:
        bodies = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody)]
        raise ConfigError(f"coupled body '{name}' is not a body of the MJCF model; its bodies: {bodies}")
    return body_id


def check_body_masses(model: mujoco.MjModel, bodies: Sequence[int]) -> None:
    """ConfigError naming the first of the coupled `bodies` (ids) that cannot carry the terrain's
    load: the world body, which does not move, or a body without mass in the model."""
    for body in bodies:
        if body == 0:
            raise ConfigError("coupled body 'world' cannot move; couple a body of the robot")
        if not model.body_mass[body] > 0:
            raise ConfigError(f"coupled body '{body_name(model, body)}' has no mass in the MJCF model; give it geoms "
                              "with mass or an <inertial> (terrasph.mjcf.model.shape_inertial gives a shape's)")


def check_planar(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Every body turned about y only, every joint a slide in the x–z plane or a hinge about ±y, at
    the pose of `data`; ConfigError naming the first body or joint that is not."""
    tol = _PLANAR_TOLERANCE
    for b in range(1, model.nbody):
        rotation = data.xmat[b].reshape(3, 3)
        if max(abs(rotation[0, 1]), abs(rotation[1, 0]), abs(rotation[1, 2]), abs(rotation[2, 1]),
               abs(rotation[1, 1] - 1.0)) > tol:
            raise ConfigError(f"body '{_name(model, mujoco.mjtObj.mjOBJ_BODY, b)}' is turned about an axis other "
                              "than y; a planar robot's bodies may turn about y only")
    for j in range(model.njnt):
        name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        kind = mujoco.mjtJoint(model.jnt_type[j])
        axis = data.xaxis[j]
        if kind == mujoco.mjtJoint.mjJNT_SLIDE:
            if abs(axis[1]) > tol:
                raise ConfigError(f"joint '{name}' slides along {axis.round(6).tolist()}, out of the x–z plane; "
                                  "a planar robot allows slides along x and z (axis with y = 0)")
        elif kind == mujoco.mjtJoint.mjJNT_HINGE:
            if abs(axis[0]) > tol or abs(axis[2]) > tol:
                raise ConfigError(f"joint '{name}' turns about {axis.round(6).tolist()}; a planar robot allows "
                                  "hinges about the y axis only")
        else:
            raise ConfigError(f"joint '{name}' is a {kind.name[6:].lower()} joint; a planar robot allows only "
                              "slide joints in the x–z plane and hinges about y")


class PlanarRobot:
    """A MuJoCo model (MJCF file, XML string or compiled model) moving in the x–z plane, with the bodies that meet
    the terrain paired to terrasph body shapes.

    Checked before any step, each failure a :class:`ConfigError` naming the item: the model
    compiles (an actuator on a missing joint is named by MuJoCo's message), every joint is a slide
    in the x–z plane or a hinge about y, every body turns about y only, gravity is (0, 0, −g) with
    the scene's g, and each coupling names a body of the model and gives it a shape.

    MuJoCo owns the model (``model``) and the state (``data``: a new one, or the caller's `data`
    of the compiled model given, its pose as it is); :meth:`add_to_scene` adds each
    coupled body as a driven terrasph body at MuJoCo's initial pose.
    """

    def __init__(self, mjcf: str | os.PathLike[str] | mujoco.MjModel,
                 couplings: Mapping[str, BodyShape | Coupling | None], *,
                 gravity: float = 9.81, initial: Mapping[str, float] | None = None,
                 data: mujoco.MjData | None = None) -> None:
        self.model = load_model(mjcf)
        self.data = mujoco.MjData(self.model) if data is None else data
        for joint, value in (initial or {}).items():
            self._set_joint(joint, value)
        mujoco.mj_forward(self.model, self.data)
        check_planar(self.model, self.data)
        expected = np.array([0.0, 0.0, -gravity])
        if np.abs(self.model.opt.gravity - expected).max() > 1e-12 * max(gravity, 1.0):
            raise ConfigError(f"the MJCF option 'gravity' = {self.model.opt.gravity.tolist()} differs from the "
                              f"scene's {expected.tolist()}; set <option gravity=\"0 0 {-gravity!r}\"/>")
        if not isinstance(couplings, Mapping) or not couplings:
            raise ConfigError("parameter 'couplings' must map at least one MuJoCo body name to a body shape")
        self.coupled = [self._pair(name, value) for name, value in couplings.items()]

    def _set_joint(self, name: str, value: float) -> None:
        """Initial value of a slide (m) or hinge (rad, clockwise) joint, from the model's qpos0."""
        joint = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint < 0:
            raise ConfigError(f"parameter 'initial' names joint '{name}', which the MJCF model does not have")
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise ConfigError(f"parameter 'initial' of joint '{name}' = {value!r} is invalid: allowed a finite number")
        self.data.qpos[self.model.jnt_qposadr[joint]] = value

    def _pair(self, name: str, value: BodyShape | Coupling | None) -> CoupledBody:
        body_id = coupled_body_id(self.model, name)
        check_body_masses(self.model, [body_id])
        if isinstance(value, BodyShape):
            value = Coupling(value)
        if not isinstance(value, Coupling) or not isinstance(value.shape, BodyShape):
            raise ConfigError(f"coupled body '{name}' has no shape: give a terrasph.bodies.BodyShape "
                              "(or a Coupling of one and a width)")
        width = value.shape.width if value.width is None else value.width
        if not (isinstance(width, (int, float)) and math.isfinite(width) and width > 0):
            raise ConfigError(f"parameter 'width' of coupled body '{name}' = {width!r} is invalid: allowed > 0 (m)")
        return CoupledBody(name, body_id, value.shape, float(width))

    # -- kinematics of a body, in terrasph's terms ----------------------------------------
    def reference(self, body: CoupledBody) -> np.ndarray:
        """(x, z) of the body's frame origin, m."""
        return self.data.xpos[body.body_id][[0, 2]].copy()

    def wrapped_angle(self, body: CoupledBody) -> float:
        """The body's clockwise angle in (−π, π] from its rotation matrix (rotation about +y)."""
        rotation = self.data.xmat[body.body_id]  # row-major 3×3: [0] = R_xx, [2] = R_xz
        return math.atan2(rotation[2], rotation[0])

    def velocity(self, body: CoupledBody) -> tuple[np.ndarray, float]:
        """(v_x, v_z) of the body's frame origin (m/s) and its clockwise spin ω_y (rad/s), world frame."""
        twist = np.zeros(6)  # [angular(3), linear(3)] at the frame origin, world axes
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, body.body_id, twist, 0)
        return twist[[3, 5]].copy(), float(twist[1])

    def apply_load(self, body: CoupledBody, force: np.ndarray, torque: float) -> None:
        """Applies the granular force (F_x, F_z) N and clockwise torque N·m about the body's frame
        origin: MuJoCo's ``xfrc_applied`` acts at the centre of mass, so the torque is moved there,
        τ_com = τ_ref + ((x_ref − x_com) × F)_y with (a × b)_y = a_z b_x − a_x b_z."""
        offset = self.data.xpos[body.body_id] - self.data.xipos[body.body_id]
        moved = torque + offset[2] * force[0] - offset[0] * force[1]
        self.data.xfrc_applied[body.body_id] = (force[0], 0.0, force[1], 0.0, moved, 0.0)

    def add_to_scene(self, scene: Scene) -> None:
        """Adds each coupled body to `scene` as a driven body at MuJoCo's initial pose. A body whose
        particles come closer than Δx to a grain is refused (place the robot above the bed; a body
        overlapping a wall is refused when the Simulation is built)."""
        for body in self.coupled:
            reference, angle = tuple(self.reference(body)), self.wrapped_angle(body)
            position, _ = body.shape.transformed(angle, reference)
            grain = _closest_grain(position, scene.granular_position, scene.spacing)
            if grain is not None:
                raise ConfigError(f"coupled body '{body.name}' overlaps the bed at start (grain at "
                                  f"{np.round(grain, 6).tolist()} closer than Δx = {scene.spacing} to it); "
                                  "place it above the surface in the MJCF")
            scene.add_body(body.name, body.shape, reference=reference, angle=angle, driven=True, width=body.width,
                           clear_granular=False)


def _closest_grain(points: np.ndarray, grains: np.ndarray, distance: float) -> np.ndarray | None:
    """A grain closer than `distance` to any of `points`, or None. Only the grains in the cells (of
    side `distance`) around the points' cells are compared, so a body above a bed of a million
    grains is checked in a fraction of a second (comparing all pairs took minutes at fine spacings)."""
    if not len(points) or not len(grains):
        return None
    origin = np.minimum(points.min(axis=0), grains.min(axis=0)) - distance
    point_cells = np.floor((points - origin) / distance).astype(np.int64)
    grain_cells = np.floor((grains - origin) / distance).astype(np.int64)
    columns = int(max(point_cells[:, 0].max(), grain_cells[:, 0].max())) + 2
    near = np.unique(np.concatenate([(point_cells[:, 0] + dx) + columns * (point_cells[:, 1] + dz)
                                     for dx in (-1, 0, 1) for dz in (-1, 0, 1)]))
    candidates = grains[np.isin(grain_cells[:, 0] + columns * grain_cells[:, 1], near)]
    for start in range(0, len(points), 64):
        chunk = points[start:start + 64]
        gaps = np.linalg.norm(candidates[None, :, :] - chunk[:, None, :], axis=2)
        close = np.argwhere(gaps < distance)
        if len(close):
            return candidates[close[0, 1]]
    return None
