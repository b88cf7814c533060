"""Resistive force theory in 3D, built from the planar maps of :mod:`terrasph.terrain.rft`.

Li et al.'s map α(β, γ) (terrasph.terrain.rft) gives the stress on a plate whose normal and velocity lie in
one vertical plane. A 3D body's surface element generally has neither in the x–z plane. Following
the idea of Treers, Cao & Stuart (2021, IEEE RA-L 6:1887, "Granular resistive force theory
implementation for three-dimensional trajectories") — reduce each element's motion to a vertical
plane in which 2D RFT applies — an element with outward unit normal n, velocity v, area A, at
depth d = z_s − z below a flat free surface is loaded here as follows (what was adopted, not their
full method: they superpose two projected 2D cases with factors fitted to their experiments, which
this code has no data for):

* **the plane of motion**: r̂ = v_h / |v_h| (v_h the horizontal part of v), the vertical plane
  spanned by r̂ and ẑ contains v; the element's in-plane velocity is (|v_h|, v_z) and γ its angle
  below r̂, exactly as in 2D;
* **the normal in that plane**: n = n_r r̂ + n_t (ẑ × r̂) + n_z ẑ; β is that of the in-plane part
  (n_r, n_z) normalised, and the out-of-plane part n_t only shrinks the element's area to its
  projection A·|(n_r, n_z)| (a plate yawed by ψ against its motion pushes grains with A cos ψ of
  its face; n_t carries no load of its own);
* **the stress** is the 2D map's there, F = (−α_x r̂ + α_z ẑ)·d·A·|(n_r, n_z)|, for a leading face
  (n·v > 0) only, times min(1, n·v / v_ε) with v_ε = :data:`terrasph.terrain.rft.REGULARISATION_SPEED`
  (as in 2D, so the load is continuous in the velocity);
* **near-vertical motion**: r̂ is undefined when v_h → 0, and the plane would jump with the
  direction of a vanishing horizontal velocity. Below |v_h| = v_ε the load is blended linearly
  with the one taken in the vertical plane of the normal (r̂ = n_h / |n_h|, where n_t = 0 and
  the 2D law applies with its own mirroring for v·r̂ < 0), which the map's symmetry under
  vertical intrusion (α_z even, α_x odd in β at γ = ±π/2) makes independent of the sign of r̂.

For motion in the x–z plane and a face whose normal lies in it, this is the planar law exactly
(tests/test_rft3d.py compares an extruded box with :func:`terrasph.terrain.rft.body_load`), and the load is
invariant under a rotation of body and motion about the vertical (it is built from ẑ and the two
vectors only).

The law has one definition, in the compiled core (cpp/src/rft3d.cpp, ``element_force``), which
:func:`element_forces` calls and the native 3D stepper (terrasph.terrain.rft3d_coupling) uses with the
law's analytic velocity Jacobian.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from terrasph import _core
from terrasph.config import ConfigError
from terrasph.mjcf.geoms import body_surface
from terrasph.terrain.rft import REGULARISATION_SPEED, RFTCoefficients

__all__ = ["ELEMENT_FRACTION", "BodyElements", "body_wrench", "element_forces"]

#: default element size as a fraction of the body's bounding radius (MuJoCo's ``geom_rbound``, the
#: largest of its collision geoms): a 5 cm wheel gets 5 mm elements
ELEMENT_FRACTION = 0.1


@dataclass(frozen=True)
class BodyElements:
    """A body's outer surface as 3D RFT elements in its own frame (MuJoCo's body frame): `centre`
    (E, 3) m, unit outward `normal` (E, 3), `area` (E,) m²."""

    centre: np.ndarray
    normal: np.ndarray
    area: np.ndarray

    @classmethod
    def from_body(cls, model: mujoco.MjModel, body: int, element_length: float | None = None) -> BodyElements:
        """Elements of MuJoCo body `body` from its collision geoms (terrasph.mjcf.geoms.body_surface,
        the geoms the SPH terrain reads), about `element_length` m across (default
        :data:`ELEMENT_FRACTION` of its largest geom's bounding radius)."""
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
        bound = max((float(model.geom_rbound[g]) for g in geoms), default=0.0)
        length = ELEMENT_FRACTION * bound if element_length is None else element_length
        if isinstance(length, bool) or not isinstance(length, (int, float)) or not (math.isfinite(length) and length > 0):
            raise ConfigError(f"parameter 'element_length' = {element_length!r} is invalid: allowed a finite number "
                              "> 0 (m)")
        return cls(*body_surface(model, body, float(length)))

    def __len__(self) -> int:
        return len(self.area)


def element_forces(normal: np.ndarray, velocity: np.ndarray, depth: np.ndarray, area: np.ndarray,
                   table: RFTCoefficients, regularisation: float = REGULARISATION_SPEED) -> np.ndarray:
    """The 3D RFT force (E, 3) N on each element (world frame) of unit outward `normal` (E, 3) moving
    with `velocity` (E, 3) m/s at `depth` (E,) m below the free surface with `area` (E,) m² (the
    module docstring's law; 0 above the surface and on trailing faces)."""
    force, _ = _core.rft3d_element_loads(normal, velocity, depth, area, table.terms, table.zeta,
                                         regularisation)
    return force


def body_wrench(elements: BodyElements, position: np.ndarray, rotation: np.ndarray, point: np.ndarray,
                linear: np.ndarray, angular: np.ndarray, surface: float, table: RFTCoefficients,
                regularisation: float = REGULARISATION_SPEED) -> tuple[np.ndarray, np.ndarray]:
    """Force (3,) N and torque (3,) N·m about `point` (world) of the RFT load on a body whose frame is
    at `position` with 3×3 `rotation` (body axes as columns), moving with velocity `linear` (m/s) at
    `point` and angular velocity `angular` (rad/s), all world frame, for a flat free surface at
    z = `surface` (m)."""
    centre = position + elements.centre @ rotation.T
    depth = surface - centre[:, 2]
    below = depth > 0
    if not below.any():
        return np.zeros(3), np.zeros(3)
    arm = centre[below] - point
    velocity = linear + np.cross(angular, arm)
    force = element_forces(elements.normal[below] @ rotation.T, velocity, depth[below], elements.area[below], table,
                           regularisation)
    return force.sum(axis=0), np.cross(arm, force).sum(axis=0)
