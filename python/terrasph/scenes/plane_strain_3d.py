"""The planar scenes in 3D: a slab one body-width wide between smooth side walls, in which a body
extruded across the slab moves as in the planar scene, and a plate narrower than a wider bed
(docs/sph3d.md#the-slab-against-the-planar-scenes).

Plane strain in 3D needs the out-of-plane direction y to carry no shear and no flow: the slab's
two walls facing ±y are the core's smooth (free-slip) ghost walls, which remove the shear traction
σn − (n·σn)n of their ghost stress and resist only the grains' approach along their normal
(cpp/src/stress_pass.cpp, cpp/src/force_pass.cpp). Periodic sides would do the same without the
walls' kernel-support deficit, but need a periodic neighbour search in the core; the smooth walls
need nothing new. Every definition of the body, its motion and the bed comes from the planar
scene's own configuration (:class:`terrasph.scenes.leg_rotation.LegRotation`,
:class:`terrasph.scenes.plate_intrusion.PlateIntrusion`), so the slab and the planar run differ only
in the dimension; the planar "width" of those configurations, for which the planar loads are
reported, is the slab's breadth, so the loads compare as they are (N).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from terrasph import _core
from terrasph.bodies import BodyShape
from terrasph.config import ConfigError
from terrasph.geometry import wall_layers_needed
from terrasph.motion import Motion
from terrasph.scenes.leg_rotation import LegResult, LegRotation, build_leg_rotation, container_freeboard
from terrasph.scenes.plate_intrusion import (
    WALL_FREEBOARD,
    PlateIntrusion,
    PlateResult,
    build_plate_intrusion,
    stroke_samples,
)
from terrasph.simulation import RunResult
from terrasph.sph3d import Bed3D, BodyShape3D, extrude, geostatic_bed, turn_about_y
from terrasph.sph3d_run import Body3D, Simulation3D

__all__ = ["LegSlab", "PlateSlab", "build_leg_slab", "build_plate_slab", "planar_motion_rows",
           "run_leg_slab", "run_plate_slab"]

def planar_motion_rows(motion: Motion) -> tuple[tuple[float, ...], ...]:
    """A planar :class:`terrasph.motion.Motion` as the 3D core's rows (duration, v (3), ω (3)):
    (vx, vz) is (vx, 0, vz), and the planar clockwise spin ω the right-handed turn ω about +y
    (docs/sph3d.md, conventions)."""
    return tuple((duration, vx, 0.0, vz, 0.0, omega, 0.0)
                 for duration, vx, vz, omega in (piece.row() for piece in motion.pieces))


def _without_grains_near(bed: Bed3D, section: np.ndarray, breadth: tuple[float, float], distance: float) -> Bed3D:
    """``bed`` without the grains closer than ``distance`` in x–z to a point of ``section`` (N, 2)
    whose y lies in ``breadth`` (y0, y1): the planar scene's clearing of a body's place, for a body
    extruded over that breadth."""
    x = bed.granular["position"]
    both = np.concatenate([x[:, [0, 2]], section])
    offsets, indices = _core.neighbour_lists(both, distance)
    rows = np.repeat(np.arange(len(both)), np.diff(offsets))
    near = np.zeros(len(x), bool)
    near[rows[(rows < len(x)) & (indices >= len(x))]] = True
    keep = ~(near & (x[:, 1] > breadth[0]) & (x[:, 1] < breadth[1]))
    return dataclasses.replace(bed, granular={k: v[keep] for k, v in bed.granular.items()}, depth=bed.depth[keep])


def _across(section: BodyShape, breadth: float, bed: Bed3D, layers: int, h_factor: float) -> BodyShape3D:
    """``section`` extruded to ``breadth``; a body as broad as the bed reaches on through the side
    walls' ``layers``. Measured: a plate ending at the walls' surface let grains into the slot
    between its end faces and the smooth walls (24 grains inside the plate of the planar scene at
    1.7 s, its resistance levelled off from 2 cm deep, ζ −96 %); reaching through, the body seals
    the slot as the planar body, continuous in y, does."""
    dx = section.spacing
    if round(breadth / dx) >= round(bed.size[1] / dx):
        return extrude(section, bed.size[1] + 2 * layers * dx, h_factor)
    return extrude(section, breadth, h_factor)


def _domain(bed: Bed3D, rim: float, layers: int, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The domain box around the bed's walls (as the planar container's: (layers + 2) Δx beyond them,
    0.1 m above the rim)."""
    margin = (layers + 2) * spacing
    return (np.array([-margin, -margin, -margin]),
            np.array([bed.size[0] + margin, bed.size[1] + margin, bed.size[2] + rim + 0.1]))


def _check_breadth(name: str, value: float, least: float, most: float) -> float:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and least * (1 - 1e-9) <= value <= most):
        raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed [{least:g}, {most:g}] m")
    return float(value)


@dataclass(frozen=True)
class LegSlab:
    """The rotating leg of :class:`LegRotation` in a slab as wide as the leg (``config.width``)
    between smooth side walls, walls rising ``rim`` above the bed (None: as high as the planar
    scene's container, :func:`terrasph.scenes.leg_rotation.container_freeboard`). Measured: side
    walls 3 cm high let the grains the C-leg carries up in its hollow rise over them (1 717 grains
    above their top at 1.9 s, up to 3.7 cm above the surface), slide across y off the leg's
    ends, which reach through the walls' layers, and leave the domain box (the run stopped at
    t = 1.96 s); the planar container's walls reach the leg's top (9.6 cm)."""

    config: LegRotation
    rim: float | None = None


def build_leg_slab(slab: LegSlab) -> Simulation3D:
    """The planar leg-rotation scene extruded across a slab: the bed (``bed_width`` × the leg's
    width × ``bed_depth``, Jáky's K0 start) with smooth ±y walls and rough floor and ends, the leg's
    section (:meth:`LegRotation.shape`) extruded to the slab's breadth at its start angle, its hip
    ``hip_height`` above the surface at mid-length, turning about +y as the planar leg turns
    clockwise (:func:`terrasph.motion.hold_then_rotate`), the grains in its place removed."""
    config = slab.config
    numerics = config.build_numerics()
    scene = build_leg_rotation(config)[0]
    scene.validate(numerics)  # the planar scene's checks: the leg clears the floor and the walls
    planar = scene.bodies[0]
    dx, layers = config.grid_spacing, wall_layers_needed(numerics.h_factor)
    section = cast(BodyShape, planar.shape)  # a body of the planar scene has its shape
    rim = container_freeboard(config, section, scene.gravity) if slab.rim is None else slab.rim
    bed = geostatic_bed((config.bed_width, config.width, config.bed_depth), config.bed_material(), dx,
                        h_factor=numerics.h_factor, rim=rim, smooth_y_walls=True)
    leg = _across(section, bed.size[1], bed, layers, numerics.h_factor)
    hip = (0.5 * bed.size[0], 0.5 * bed.size[1], bed.size[2] + config.hip_height)
    placed, _ = section.transformed(config.start_angle, (hip[0], hip[2]))
    bed = _without_grains_near(bed, placed, (0.0, bed.size[1]), dx)
    motion = planar_motion_rows(planar.motion)
    lower, upper = _domain(bed, rim, layers, dx)
    body = Body3D("leg", leg, hip, turn_about_y(config.start_angle), motion)
    return Simulation3D(bed, config.bed_material(), numerics, lower, upper, (body,))


def run_leg_slab(slab: LegSlab, *, output: str | None = None, progress: bool = False,
                 resume: bool = False) -> LegResult:
    """Runs the leg's slab to the end of the sweep (``resume``: continues the run in ``output`` from
    its checkpoint, bitwise the run that never stopped) and returns the planar scene's
    :class:`LegResult`: lift F_z, thrust F_x and the torque about the hip's +y axis (the planar
    clockwise torque), each a time average over 1/samples_per_radian of the sweep, in N for the
    leg's ``width`` as the planar scene reports them: the slab's load over its breadth on the
    lattice (a whole number of spacings, e.g. 12 × 2.13 = 25.6 mm for 25.4 mm) times ``width``."""
    config = slab.config
    sim = build_leg_slab(slab)
    interval = 1.0 / (config.samples_per_radian * config.omega)
    run = sim.run(config.end_time, output=output, body_interval=interval, frame_interval=config.frame_interval,
                  progress=progress, resume=resume,
                  config={"scene": "leg-rotation-slab", "leg_rotation": dataclasses.asdict(config), **sim.describe()})
    series = run.bodies["leg"]
    time, q = np.asarray(series["time"]), np.asarray(series["orientation"])
    turning = time > config.settle_time + 1e-9
    angle = 2.0 * np.arctan2(q[:, 2], q[:, 0])  # the turn about +y (turn_about_y inverted)
    per_width = config.width / sim.bed.size[1]
    force, torque = per_width * np.asarray(series["mean_force"]), per_width * np.asarray(series["mean_torque"])
    return LegResult(angle[turning], force[turning, 2], force[turning, 0], torque[turning, 1], config,
                     len(sim.core.mass), sim.leaked_particles, run)


@dataclass(frozen=True)
class PlateSlab:
    """The plate of :class:`PlateIntrusion`, ``config.width`` broad along y, in a bed ``bed_breadth``
    broad (None: as broad as the plate, the plane-strain slab) between smooth side walls."""

    config: PlateIntrusion
    bed_breadth: float | None = None

    @property
    def breadth(self) -> float:
        """The bed's breadth along y (m)."""
        return self.config.width if self.bed_breadth is None else self.bed_breadth


def build_plate_slab(slab: PlateSlab) -> Simulation3D:
    """The planar plate-intrusion scene in 3D: the bed (``bed_width`` × breadth × ``bed_depth``,
    Jáky's K0 start) with smooth ±y walls and rough floor and ends, the plate's section
    (:func:`terrasph.bodies.plate`) extruded to ``config.width`` at the middle of the breadth, its
    underside ``start_gap`` above the surface, moving as the planar plate (down, then up)."""
    config = slab.config
    if config.buried:
        raise ConfigError("parameter 'buried_depth' is invalid for the 3D plate: allowed None (a plate pushed in "
                          "from above)")
    numerics = config.build_numerics()
    dx, layers = config.spacing, wall_layers_needed(numerics.h_factor)
    least = math.ceil(2.0 * numerics.h_factor) * dx
    _check_breadth("width", config.width, least, slab.breadth)
    bed = geostatic_bed((config.bed_width, _check_breadth("bed_breadth", slab.breadth, least, math.inf),
                         config.bed_depth), config.material(), dx, h_factor=numerics.h_factor,
                        rim=WALL_FREEBOARD, smooth_y_walls=True)
    scene = build_plate_intrusion(config)[0]
    scene.validate(numerics)  # the planar scene's checks
    section = cast(BodyShape, scene.bodies[0].shape)
    plate = _across(section, config.width, bed, layers, numerics.h_factor)
    half = 0.5 * dx * round(config.plate_thickness / dx)
    centre = (0.5 * bed.size[0], 0.5 * bed.size[1], bed.size[2] + config.start_gap + half)
    lower, upper = _domain(bed, WALL_FREEBOARD, layers, dx)
    body = Body3D("plate", plate, centre, motion=planar_motion_rows(config.motion()))
    return Simulation3D(bed, config.material(), numerics, lower, upper, (body,))


def run_plate_slab(slab: PlateSlab, *, output: str | None = None, progress: bool = False) -> PlateResult:
    """Runs the plate's 3D bed to ``config.end_time`` and returns the planar scene's
    :class:`PlateResult`: F_z (N, the whole plate) against the depth of its underside, per load
    sample; its ``config.width`` is the plate's breadth on the lattice (a whole number of spacings),
    so ``alpha()`` = k/(ρ0 g L W) and ζ = k/(L W) are per unit area of the plate as built."""
    config = slab.config
    sim = build_plate_slab(slab)
    run: RunResult = sim.run(config.end_time, output=output, body_interval=config.sample_interval,
                             frame_interval=config.frame_interval, progress=progress,
                             config={"scene": "plate-intrusion-slab", "bed_breadth": slab.breadth,
                                     "plate_intrusion": dataclasses.asdict(config), **sim.describe()})
    series = run.bodies["plate"]
    half = 0.5 * config.spacing * round(config.plate_thickness / config.spacing)
    underside = np.asarray(series["reference"])[:, 2] - half
    force = np.asarray(series["mean_force"])
    planar = {"time": np.asarray(series["time"]), "sinkage": sim.bed.size[2] - underside,
              "force": force[:, [0, 2]]}
    depth, force_z, phase, time = stroke_samples(planar, config)
    breadth = min(float(np.ptp(sim.bodies[0].shape.position[:, 1])) + config.spacing, sim.bed.size[1])
    return PlateResult(depth, force_z, phase, time, dataclasses.replace(config, width=breadth), len(sim.core.mass),
                       sim.leaked_particles, config.material().reference_density, run)
