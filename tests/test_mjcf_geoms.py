"""MJCF geoms as terrain bodies (terrasph.mjcf.geoms) and actuator specs (terrasph.robots.control).

References independent of the code: the areas and extents of the solids' projections from their
closed forms (disc πr², stadium 4hr + πr², ellipse πac, rectangle), a box geom against the plate
generator of terrasph.bodies (rows along the centre line, cell-centred), and the geometry of the
normals (each surface particle's normal leads out of the union of the parts)."""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np
import pytest
from terrasph.bodies import plate
from terrasph.config import ConfigError
from terrasph.mjcf.geoms import body_shape
from terrasph.robots.control import parse_spec, spec_controller

DX = 0.01


def _model(geoms: str, body_pos: str = "0 0 1", extra: str = "") -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(
        f'<mujoco><asset>{extra}</asset><worldbody><body name="b" pos="{body_pos}"><joint type="slide" axis="0 0 1"/>'
        f'{geoms}</body></worldbody></mujoco>')


def _area(loop: np.ndarray) -> float:
    """Shoelace area, positive for a counter-clockwise loop."""
    x, z = loop.T
    return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


#: geom XML, the area of its projection on x–z, its extent across the plane and its least width in
#: the plane (closed forms)
CASES = {
    "sphere": ('<geom type="sphere" size="0.05" pos="0.02 0 -0.03"/>', math.pi * 0.05**2, 0.1, 0.1),
    "capsule at 30°": ('<geom type="capsule" size="0.04 0.1" euler="0 30 0"/>', 4 * 0.1 * 0.04 + math.pi * 0.04**2,
                       0.08, 0.08),
    "capsule fromto": ('<geom type="capsule" size="0.03" fromto="-0.1 0 0 0.1 0 -0.1"/>',
                       2 * math.hypot(0.2, 0.1) * 0.03 + math.pi * 0.03**2, 0.06, 0.06),
    "cylinder along y": ('<geom type="cylinder" size="0.05 0.02" euler="90 0 0"/>', math.pi * 0.05**2, 0.04, 0.1),
    "cylinder along x": ('<geom type="cylinder" size="0.05 0.1" euler="0 90 0"/>', 0.2 * 0.1, 0.1, 0.1),
    "ellipsoid": ('<geom type="ellipsoid" size="0.08 0.03 0.05" euler="0 40 0"/>', math.pi * 0.08 * 0.05, 0.06, 0.1),
    "box at 20°": ('<geom type="box" size="0.1 0.04 0.03" euler="0 20 0"/>', 0.2 * 0.06, 0.08, 0.06),
}


@pytest.mark.parametrize("case", CASES)
def test_a_geom_becomes_its_outline_filled_with_particles(case: str) -> None:
    xml, area, width, thickness = CASES[case]
    shape = body_shape(_model(xml), 1, DX)
    (loop,) = shape.outline
    # the support polygon lies within r(1 − cos(π/256)) of a round outline: area to 3e-4
    assert _area(loop) == pytest.approx(area, rel=3e-4)
    assert shape.width == pytest.approx(width, rel=1e-12)
    assert shape.thickness == pytest.approx(thickness, rel=1e-9)
    # the particles fill it: N Δx² is the area within the perimeter × Δx/2 band a lattice can miss
    perimeter = float(np.sum(np.hypot(*(np.roll(loop, -1, axis=0) - loop).T)))
    assert abs(len(shape) * DX**2 - area) < 0.5 * perimeter * DX
    assert np.allclose(np.hypot(*shape.normal.T), 1.0)


def test_a_mesh_becomes_the_convex_hull_of_its_projection() -> None:
    # a tetrahedron whose x–z shadow is the triangle (0,0), (0.1,0), (0,0.1) (the fourth vertex projects inside)
    mesh = '<mesh name="t" vertex="0 0 0  0.1 0 0  0 0 0.1  0.02 0.05 0.02"/>'
    shape = body_shape(_model('<geom type="mesh" mesh="t"/>', extra=mesh), 1, DX)
    (loop,) = shape.outline
    assert len(loop) == 3 and _area(loop) == pytest.approx(0.005, rel=1e-6)  # MuJoCo keeps vertices in float32
    assert shape.width == pytest.approx(0.05, rel=1e-6)


def test_a_box_geom_is_the_plate_of_the_particle_generators() -> None:
    """The two routes to a body meet: a 10 × 3 cm box geom gives bodies.plate's particles exactly."""
    shape = body_shape(_model('<geom type="box" size="0.05 0.02 0.015"/>'), 1, DX)
    reference = plate(0.1, 0.03, 0.04, DX)
    ours = sorted(map(tuple, np.round(shape.position / DX, 9)))
    theirs = sorted(map(tuple, np.round(reference.position / DX, 9)))
    assert ours == theirs
    assert shape.width == pytest.approx(reference.width) and shape.thickness == pytest.approx(reference.thickness)


def test_normals_of_a_union_lead_out_of_it() -> None:
    """An L of two overlapping boxes: every particle within Δx of the union's outer surface has a
    normal that points toward the nearest point of that surface, none toward the buried sides."""
    xml = '<geom type="box" size="0.1 0.02 0.02"/><geom type="box" size="0.02 0.02 0.08" pos="-0.08 0 0.06"/>'
    shape = body_shape(_model(xml), 1, DX)
    a, b = shape.outline

    def inside(points: np.ndarray, loop: np.ndarray) -> np.ndarray:
        lo, hi = loop.min(axis=0), loop.max(axis=0)  # both loops are axis-aligned rectangles
        return np.all((points > lo + 1e-12) & (points < hi - 1e-12), axis=1)

    def perimeter(loop: np.ndarray) -> np.ndarray:  # 0.1 mm apart along the rectangle's sides
        (x0, z0), (x1, z1) = loop.min(axis=0), loop.max(axis=0)
        t = np.linspace(0, 1, 2001)[:, None]
        corners = [(x0, z0), (x1, z0), (x1, z1), (x0, z1), (x0, z0)]
        return np.concatenate([np.array(p) + t * (np.array(q) - np.array(p)) for p, q in itertools.pairwise(corners)])

    # the union's outer surface, brute force: each side's points not strictly inside the other part
    outer = np.concatenate([perimeter(a)[~inside(perimeter(a), b)], perimeter(b)[~inside(perimeter(b), a)]])
    p = shape.position
    distance = np.hypot(*(p[:, None, :] - outer[None, :, :]).transpose(2, 0, 1))
    nearest = distance.min(axis=1)
    surface = nearest < DX
    assert surface.sum() > 40
    for k in np.flatnonzero(surface):
        # the ways out: toward each nearest outer point (several on a tie between two faces)
        towards = outer[distance[k] <= nearest[k] + 1e-6] - p[k]  # samples 0.08 mm apart: within 2e-7 m
        cosine = towards @ shape.normal[k] / np.hypot(*towards.T)
        # within 45° of a way out (exactly 45° at a corner); a normal of a buried side (an edge
        # of one rectangle inside the other) would be 90° or more off
        assert cosine.max() > np.cos(np.radians(45)) - 1e-9, (p[k], shape.normal[k])
    # the particles of the overlap are merged: none closer than Δx/2 to another
    gaps = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1)) + np.eye(len(p))
    assert gaps.min() >= 0.5 * DX - 1e-12


def test_a_geom_that_cannot_become_a_body_is_named() -> None:
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body name="ground"><geom name="ramp" type="plane" size="1 1 0.1"/></body>'
        '</worldbody></mujoco>')
    with pytest.raises(ConfigError, match="geom 'ramp' is a plane, which cannot become a terrain body"):
        body_shape(model, 1, DX)


# -- actuator specs -----------------------------------------------------------------------------

ARM = mujoco.MjModel.from_xml_string(
    '<mujoco><worldbody><body name="arm"><joint name="hip" type="hinge" axis="0 1 0"/>'
    '<geom type="capsule" size="0.02 0.1"/></body></worldbody>'
    '<actuator><motor joint="hip" gear="10"/></actuator></mujoco>')


def test_specs_give_the_commanded_inputs() -> None:
    data = mujoco.MjData(ARM)
    data.qpos[0], data.qvel[0] = 0.3, -0.5
    hold = spec_controller(["hip=hold:20,4"], ARM, data, start=1.0)
    data.qpos[0] = 0.4  # 0.1 rad past the angle at start: τ = −20·0.1 − 4·(−0.5) = 0 N·m
    assert hold(0.0, ARM, data)[0] == pytest.approx(0.0, abs=1e-12)
    data.qvel[0] = 0.0
    assert hold(0.0, ARM, data)[0] == pytest.approx(-20 * 0.1 / 10)  # torque / gear
    sine = spec_controller(["#0=sin:0.5,2,90,0.1"], ARM, data, start=1.0)
    assert sine(0.5, ARM, data)[0] == 0.0  # before the start
    assert sine(1.5, ARM, data)[0] == pytest.approx(0.1 + 0.5 * math.sin(math.pi / 2 + math.pi / 2))
    knots = spec_controller(["hip=knots:0/0,2/1"], ARM, data, start=1.0)
    assert knots(2.0, ARM, data)[0] == pytest.approx(0.5)


@pytest.mark.parametrize(("spec", "message"), [
    ("hip", "parameter 'ctrl'"), ("hip=sin:1", "parameter 'ctrl'"), ("hip=sin:1,0", "period"),
    ("hip=hold:-1,0", "KP and KD"), ("hip=knots:0/1,x", "knots are T/U pairs"), ("hip=wave:1", "parameter 'ctrl'"),
])
def test_bad_specs_are_refused_naming_ctrl(spec: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_spec(spec)


def test_unknown_or_repeated_actuators_are_refused() -> None:
    data = mujoco.MjData(ARM)
    with pytest.raises(ConfigError, match=r"actuator 'knee'.*its actuators: \['hip/#0'\]"):
        spec_controller(["knee=1"], ARM, data)
    with pytest.raises(ConfigError, match="twice"):
        spec_controller(["hip=1", "#0=2"], ARM, data)
