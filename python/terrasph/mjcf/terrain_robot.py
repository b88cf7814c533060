"""Any planar MuJoCo model on the granular bed: the floor replaced by the bed, the bodies that meet
the terrain chosen and given their geoms' shapes, the model placed on the bed's surface.

* **Floor.** The model's horizontal plane geoms, and the world body's other collision geoms whose
  top lies at the floor's height, are the floor: their contacts are switched off in the compiled
  model (``geom_contype = geom_conaffinity = 0``; the file is not changed), one log line says so,
  and the bed's free surface takes the floor's place.
* **Coupled bodies.** By default every body with a collision geom whose lowest point at the start
  pose lies less than ``couple_below`` above the floor; or the bodies named. Each becomes a terrain
  body whose shape is its collision geoms (:func:`terrasph.mjcf.geoms.body_shape`). Bodies not
  coupled do not feel the grains (nor, the floor being off, the ground): give every part that may
  touch the bed a place among the coupled bodies.
* **Placement.** Every child of the world body is shifted so the floor's height becomes the bed's
  surface and the robot's centre of mass lies at ``x``: positions in the run are the bed's frame.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from terrasph.config import ConfigError
from terrasph.mjcf.geoms import body_shape, geom_support, is_collision_geom
from terrasph.mjcf.model import Coupling, PlanarRobot, body_name, coupled_body_id, load_model

__all__ = ["COUPLE_BELOW", "FLOOR_TOLERANCE", "check_couple_below", "coupled_body_ids", "floor_geoms",
           "lowest_points", "switch_off_floor", "terrain_model", "terrain_robot", "world_support"]

LOG = logging.getLogger(__name__)

#: default height (m) above the floor under which a body's collision geom makes it a coupled body
COUPLE_BELOW = 0.15
#: a world geom whose top lies within this (m) of the floor's height is part of the floor
FLOOR_TOLERANCE = 1e-6


def _geom_name(model: mujoco.MjModel, geom: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"#{geom}"


def world_support(model: mujoco.MjModel, data: mujoco.MjData, geom: int, direction: Sequence[float]) -> np.ndarray:
    """The point of collision geom `geom` farthest along `direction` (world frame) at `data`'s pose."""
    return geom_support(model, geom, data.geom_xpos[geom], data.geom_xmat[geom].reshape(3, 3),
                        np.asarray([direction], dtype=float))[0]


def floor_geoms(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[list[int], float]:
    """The floor's geoms and its height (m; 0 without a plane): the world's horizontal planes, then
    its other collision geoms whose top lies at that height. A tilted plane is refused (the bed is level)."""
    world = [g for g in range(model.ngeom) if model.geom_bodyid[g] == 0 and is_collision_geom(model, g)]
    planes = [g for g in world if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    heights = []
    for g in planes:
        normal = data.geom_xmat[g].reshape(3, 3)[:, 2]
        if abs(normal[2] - 1.0) > 1e-9:
            raise ConfigError(f"geom '{_geom_name(model, g)}' is a plane with normal {normal.round(6).tolist()}; "
                              "the granular bed that replaces the floor is level (normal 0 0 1)")
        heights.append(float(data.geom_xpos[g][2]))
    if len(set(heights)) > 1:
        raise ConfigError(f"the model has floor planes at several heights {sorted(set(heights))}; the bed replaces one")
    level = heights[0] if heights else 0.0
    others = [g for g in world if g not in planes
              and abs(world_support(model, data, g, (0.0, 0.0, 1.0))[2] - level) <= FLOOR_TOLERANCE]
    return planes + others, level


def switch_off_floor(model: mujoco.MjModel, geoms: Sequence[int]) -> None:
    """Switches the floor geoms' contacts off in the compiled model and logs one line naming them."""
    for g in geoms:
        model.geom_contype[g] = 0
        model.geom_conaffinity[g] = 0
    if geoms:
        names = ", ".join(f"'{_geom_name(model, g)}'" for g in geoms)
        LOG.warning("terrasph: the model's floor (geom %s) is replaced by the terrain (the SPH bed or RFT's "
                    "sand); its MuJoCo contacts are switched off", names)


def lowest_points(model: mujoco.MjModel, data: mujoco.MjData) -> dict[int, float]:
    """Lowest z (m, world) of each body's collision geoms at `data`'s pose, for the bodies that have any."""
    lowest: dict[int, float] = {}
    for g in range(model.ngeom):
        body = int(model.geom_bodyid[g])
        if body > 0 and is_collision_geom(model, g):
            z = float(world_support(model, data, g, (0.0, 0.0, -1.0))[2])
            lowest[body] = min(z, lowest.get(body, math.inf))
    return lowest


def terrain_model(mjcf: str | os.PathLike[str] | mujoco.MjModel, *, bodies: Sequence[str] = (),
                  couple_below: float | None = COUPLE_BELOW, data: mujoco.MjData | None = None,
                  ) -> tuple[mujoco.MjModel, mujoco.MjData, float, list[int]]:
    """The MJCF model with its floor switched off (module docstring), its data at the start pose (or
    `data`, the caller's of the compiled model given, at its pose), the floor's height (m) and the
    ids of the bodies that meet the terrain (:func:`coupled_body_ids`; `couple_below` None: every
    body with a collision geom). Both terrains of the scenes start here: the SPH's
    :func:`terrain_robot` and the 3D RFT's (:func:`terrasph.terrain.rft3d_coupling.rft_robot`)."""
    if couple_below is not None:
        check_couple_below(couple_below)
    model = load_model(mjcf)
    data = mujoco.MjData(model) if data is None else data
    mujoco.mj_forward(model, data)
    floor, level = floor_geoms(model, data)
    chosen = coupled_body_ids(model, data, level, bodies, couple_below)
    switch_off_floor(model, floor)
    return model, data, level, chosen


def check_couple_below(couple_below: float) -> None:
    """ConfigError naming `couple_below` unless it is a finite height > 0 (m)."""
    if not (isinstance(couple_below, (int, float)) and math.isfinite(couple_below) and couple_below > 0):
        raise ConfigError(f"parameter 'couple_below' = {couple_below!r} is invalid: allowed a finite number > 0 (m)")


def coupled_body_ids(model: mujoco.MjModel, data: mujoco.MjData, level: float, bodies: Sequence[str],
                     couple_below: float | None) -> list[int]:
    """The ids of the bodies that meet the terrain: `bodies` (by name) or, if none are named, those
    with a collision geom lower than `couple_below` (m) above the floor at `level` (m) at `data`'s
    pose, or every body with a collision geom if `couple_below` is None; ConfigError if none is."""
    if bodies:
        return [coupled_body_id(model, name) for name in bodies]
    lowest = lowest_points(model, data)
    if couple_below is None:
        chosen = sorted(lowest)
        if not chosen:
            raise ConfigError("no body of the model has a collision geom to meet the terrain with")
        return chosen
    chosen = sorted(b for b, z in lowest.items() if z - level < couple_below)
    if not chosen:
        raise ConfigError(f"no body of the model has a collision geom lower than couple_below = {couple_below:g} m "
                          "above the floor; raise it or name the bodies that meet the terrain")
    return chosen


def terrain_robot(mjcf: str | os.PathLike[str] | mujoco.MjModel, spacing: float, surface: float, x: float, *,
                  bodies: Sequence[str] = (), couple_below: float | None = COUPLE_BELOW,
                  widths: Mapping[str, float] | None = None, gravity: float = 9.81,
                  data: mujoco.MjData | None = None) -> PlanarRobot:
    """A :class:`PlanarRobot` of the MJCF model with its floor replaced by a bed whose free surface is
    at z = `surface` and its centre of mass at `x` (module docstring); coupled bodies `bodies` (by
    name) or, if none are named, those with a collision geom lower than `couple_below` (m) above
    the floor at start (:func:`terrain_model`); each body's shape from its collision geoms at
    `spacing` Δx, its width from them unless `widths` gives it (m, by body name). The remaining
    checks (planar joints, gravity, mass) are :class:`PlanarRobot`'s and :class:`CoupledSimulation`'s.
    With `data` (the caller's, of the compiled model given) the robot moves that data, else new data."""
    given = data
    model, data, level, chosen = terrain_model(mjcf, bodies=bodies, couple_below=couple_below, data=data)
    widths = dict(widths or {})
    couplings = {}
    for body in chosen:
        name = body_name(model, body)
        couplings[name] = Coupling(body_shape(model, body, spacing, widths.pop(name, None)))
    if widths:
        raise ConfigError(f"parameter 'widths' names {sorted(widths)}, which are not coupled bodies "
                          f"(coupled: {sorted(couplings)})")
    shift = np.array([x - float(data.subtree_com[0][0]), 0.0, surface - level])
    for body in range(1, model.nbody):
        if model.body_parentid[body] == 0:
            model.body_pos[body] += shift
    return PlanarRobot(model, couplings, gravity=gravity, data=given)
