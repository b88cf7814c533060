"""Rigid-body geometry generators (terrasph.bodies): spacing, shapes, normals, rotation, checks."""

import math

import numpy as np
import pytest
from terrasph import bodies

# chapter 3 legs at a coarse spacing: 2R = 7.62 cm hip to toe, thickness 0.64 cm, width 2.54 cm
R, T, W, DX = 0.0762, 0.0064, 0.0254, 0.002


def _distances(p: np.ndarray) -> np.ndarray:
    d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    return d


def _shapes():
    return [
        bodies.flat_leg(R, T, W, DX),
        bodies.c_leg(R, T, W, DX),
        bodies.reversed_c_leg(R, T, W, DX),
        bodies.l_leg(R, T, W, DX, foot_ratio=0.67),
        bodies.reversed_l_leg(R, T, W, DX, foot_ratio=0.33),
        bodies.wheel(0.04, 0.005, 0.1, 0.001),
        bodies.leg_wheel("c-leg", 5, 0.04, 0.005, 0.1, 0.001),
    ]


@pytest.mark.parametrize("shape", _shapes(), ids=lambda s: s.name)
def test_spacing_and_unit_normals(shape):
    nearest = _distances(shape.position).min(axis=1)
    assert nearest.min() >= 0.5 * shape.spacing  # duplicates merged
    assert np.median(nearest) == pytest.approx(shape.spacing, rel=0.02)
    assert nearest.max() <= 1.05 * shape.spacing  # no holes
    assert np.allclose(np.hypot(*shape.normal.T), 1.0)


def test_flat_leg_points_down_to_R():
    leg = bodies.flat_leg(R, T, W, DX)
    # particles are spaced R/round(R/Δx) along the leg, so 'min z − Δx/2' is within a hair of −R
    assert leg.lowest_point(0.0, (0.0, 0.0)) == pytest.approx(-R, abs=0.02 * DX)
    assert leg.position[:, 1].max() <= 0.0
    assert np.abs(leg.position[:, 0]).max() < 0.5 * T  # rows inside the bar
    n_rows = round(T / DX)
    assert len(np.unique(np.round(leg.position[:, 0], 12))) == n_rows


def test_positive_rotation_is_clockwise():
    """docs/design.md §2: legs turn clockwise (positive) when the robot moves in +x. Clockwise in the x–z plane
    with z up takes 'down' (6 o'clock) to 'back' (9 o'clock, −x): the tip at (0, −R) goes to (−R, 0)."""
    leg = bodies.flat_leg(R, T, W, DX)
    tip = np.argmin(leg.position[:, 1])
    p, n = leg.transformed(math.pi / 2, (0.0, 0.0))
    assert p[tip, 0] == pytest.approx(-R + 0.5 * DX, abs=0.02 * R)
    assert abs(p[tip, 1]) < T
    assert p[:, 0].max() < T  # the whole leg is now behind the axle
    # at the start of the chapter 3 sweep (θ = −π/4) the tip is in front of and below the axle
    q, _ = leg.transformed(-math.pi / 4, (0.1, 0.02))
    assert q[tip, 0] > 0.1 and q[tip, 1] < 0.02
    # normals rotate with the body and stay unit
    assert np.allclose(np.hypot(*n.T), 1.0)
    assert leg.lowest_point(math.pi / 2, (0.0, 0.0)) == pytest.approx(-0.5 * len(np.unique(np.round(leg.position[:, 0], 12))) * DX, abs=1e-12)


def test_transformed_translates_the_reference_point():
    leg = bodies.c_leg(R, T, W, DX)
    p, n = leg.transformed(0.0, (0.12, 0.17))
    assert np.allclose(p - leg.position, [0.12, 0.17])
    assert np.allclose(n, leg.normal)
    assert leg.lowest_point(0.0, (0.12, 0.17)) == pytest.approx(leg.lowest_point(0.0, (0.0, 0.0)) + 0.17)


def test_c_leg_annulus_and_bulge_behind():
    leg = bodies.c_leg(R, T, W, DX)
    centre = np.array([0.0, -R / 2])
    rho = np.hypot(*(leg.position - centre).T)
    half = 0.5 * round(T / DX) * DX
    assert rho.min() >= R / 2 - half - 1e-12 and rho.max() <= R / 2 + half + 1e-12
    # half circle on the rear (−x) side: the letter "C" seen with the robot moving in +x
    assert leg.position[:, 0].max() <= half
    assert leg.position[:, 0].min() == pytest.approx(-R / 2 - half + 0.5 * DX, abs=1e-9)
    # hip at the axle and toe at (0, −R): particles reach both ends of the chord
    assert leg.position[:, 1].max() == pytest.approx(half - 0.5 * DX, abs=0.1 * DX)
    assert leg.lowest_point() == pytest.approx(-R - half, abs=0.1 * DX)


def test_reversed_c_is_mirror_image():
    c = bodies.c_leg(R, T, W, DX)
    rc = bodies.reversed_c_leg(R, T, W, DX)
    assert rc.position[:, 0].min() >= -0.5 * T  # bulge forward
    assert np.allclose(rc.position, c.position * [-1, 1])
    assert np.allclose(rc.normal, c.normal * [-1, 1])


@pytest.mark.parametrize("fl", [0.33, 0.67, 1.0])
def test_l_leg_foot_forward_with_length_fl_R(fl):
    leg = bodies.l_leg(R, T, W, DX, foot_ratio=fl)
    flat = bodies.flat_leg(R, T, W, DX)
    toe = leg.position[:, 0].max() + 0.5 * DX
    assert toe == pytest.approx(fl * R, abs=0.5 * DX)
    assert leg.position[:, 0].min() == pytest.approx(flat.position[:, 0].min())  # nothing behind the leg
    foot = leg.position[leg.position[:, 0] > 0.5 * T]
    assert foot[:, 1].min() - 0.5 * DX == pytest.approx(-R, abs=1e-9)  # underside flush with the tip
    assert foot[:, 1].max() < -R + T
    assert leg.lowest_point() == pytest.approx(-R, abs=0.02 * DX)
    rl = bodies.reversed_l_leg(R, T, W, DX, foot_ratio=fl)
    assert rl.position[:, 0].min() - 0.5 * DX == pytest.approx(-fl * R, abs=0.5 * DX)
    assert np.allclose(rl.position, leg.position * [-1, 1])
    # a longer foot adds particles
    assert len(leg) > len(flat)


def test_normals_point_out_of_the_body():
    flat = bodies.flat_leg(R, T, W, DX)
    x, z = flat.position.T
    side = (np.abs(x) > 0.25 * DX) & (z < -T) & (z > -R + T)
    assert np.all(np.sign(flat.normal[side, 0]) == np.sign(x[side]))
    assert np.allclose(flat.normal[side, 1], 0.0)
    tip = z < -R + 0.5 * DX + 1e-12
    assert np.all(flat.normal[tip & (np.abs(x) < 0.5 * T - DX)] @ [0, 1] == -1.0)

    c = bodies.c_leg(R, T, W, DX)
    rel = c.position - [0.0, -R / 2]
    rho = np.hypot(*rel.T)
    radial = rel / rho[:, None]
    mid = np.abs(c.position[:, 0]) > T  # away from the hip and toe caps
    outer, inner = mid & (rho > R / 2 + 0.25 * DX), mid & (rho < R / 2 - 0.25 * DX)
    assert np.all(np.einsum("ij,ij->i", c.normal[outer], radial[outer]) > 0.99)
    assert np.all(np.einsum("ij,ij->i", c.normal[inner], radial[inner]) < -0.99)

    w = bodies.wheel(0.04, 0.005, 0.1, 0.001)
    rho = np.hypot(*w.position.T)
    out = np.einsum("ij,ij->i", w.normal, w.position / rho[:, None])
    mid_row = 0.04 - 0.0025  # 5 rows: the middle one is a tie between the faces; it goes to the outer face
    assert np.all(out[rho > mid_row - 0.25e-3] > 0.99) and np.all(out[rho < mid_row - 0.25e-3] < -0.99)


def test_wheel_rim_annulus():
    w = bodies.wheel(0.04, 0.005, 0.1, 0.001)
    rho = np.hypot(*w.position.T)
    assert rho.max() == pytest.approx(0.04 - 0.0005, abs=1e-12)
    assert rho.min() == pytest.approx(0.04 - 0.0045, abs=1e-12)
    for angle in (0.0, 0.3, 2.0):
        assert w.lowest_point(angle, (0.0, 0.05)) == pytest.approx(0.05 - 0.04, abs=0.01 * 0.001)


@pytest.mark.parametrize("spoke,n,kw", [("c-leg", 5, {}), ("reversed-l-leg", 3, {"foot_ratio": 0.5}),
                                        (bodies.flat_leg, 2, {})])
def test_leg_wheel_has_n_fold_symmetry(spoke, n, kw):
    lw = bodies.leg_wheel(spoke, n, 0.04, 0.005, 0.1, 0.001, **kw)
    single = bodies.leg_wheel(spoke, 1, 0.04, 0.005, 0.1, 0.001, **kw)
    assert len(single) * n >= len(lw) > len(single) * (n - 1)
    rotated, _ = lw.transformed(2 * math.pi / n, (0.0, 0.0))
    gap = np.hypot(*(rotated[:, None, :] - lw.position[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert gap.max() < 0.5 * lw.spacing
    # but not symmetric under a rotation by half the spoke angle
    half, _ = lw.transformed(math.pi / n, (0.0, 0.0))
    gap = np.hypot(*(half[:, None, :] - lw.position[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert gap.max() > 2 * lw.spacing


def test_minimum_thickness_matches_wall_layers():
    from terrasph.geometry import wall_layers_needed
    assert bodies.minimum_thickness(0.001, 1.3) == pytest.approx(3 * 0.001)
    assert bodies.minimum_thickness(0.001, 1.6) == pytest.approx(wall_layers_needed(1.6) * 0.001)
    bodies.check_thickness(0.0064, 0.002, 1.3)  # chapter 3 leg at Δx = 2 mm: 3 layers = 6 mm, fine
    with pytest.raises(ValueError, match=r"thickness.*0\.0064.*minimum allowed 0\.008"):
        bodies.check_thickness(0.0064, 0.002, 2.0)
    thin = bodies.flat_leg(R, 0.003, W, 0.002)
    with pytest.raises(ValueError, match=r"thickness of 'flat-leg'.*minimum allowed 0.006"):
        bodies.check_thickness(thin, h_factor=1.3)


@pytest.mark.parametrize("call,word", [
    (lambda: bodies.flat_leg(-R, T, W, DX), "radius"),
    (lambda: bodies.flat_leg(R, 0.0, W, DX), "thickness"),
    (lambda: bodies.c_leg(R, T, float("nan"), DX), "width"),
    (lambda: bodies.wheel(R, T, W, 0), "spacing"),
    (lambda: bodies.flat_leg(R, 2 * R, W, DX), "thickness"),
    (lambda: bodies.l_leg(R, T, W, DX, foot_ratio=0.0), r"foot_ratio.*\(0, 1\.5\]"),
    (lambda: bodies.l_leg(R, T, W, DX, foot_ratio=1.6), r"foot_ratio.*\(0, 1\.5\]"),
    (lambda: bodies.leg_wheel("c-leg", 0, R, T, W, DX), "n_spokes"),
    (lambda: bodies.leg_wheel("d-leg", 3, R, T, W, DX), "spoke"),
])
def test_bad_input_names_the_parameter(call, word):
    with pytest.raises(ValueError, match=word):
        call()


def test_shape_is_immutable():
    leg = bodies.flat_leg(R, T, W, DX)
    with pytest.raises(ValueError):
        leg.position[0, 0] = 1.0


def _signed_area(loop: np.ndarray) -> float:
    """Shoelace formula: positive for a counter-clockwise loop in x–z."""
    x, z = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


def _winding(points: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Winding number of `loop` around each point (sum of the edges' subtended angles / 2π)."""
    a = loop[None, :, :] - points[:, None, :]
    b = np.roll(loop, -1, axis=0)[None, :, :] - points[:, None, :]
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    dot = (a * b).sum(-1)
    return np.rint(np.arctan2(cross, dot).sum(axis=1) / (2 * math.pi))


@pytest.mark.parametrize("make", [lambda: bodies.flat_leg(0.05, 0.006, 0.1, 0.002),
                                  lambda: bodies.c_leg(0.05, 0.006, 0.1, 0.002),
                                  lambda: bodies.reversed_c_leg(0.05, 0.006, 0.1, 0.002),
                                  lambda: bodies.l_leg(0.05, 0.006, 0.1, 0.002, 0.5),
                                  lambda: bodies.reversed_l_leg(0.05, 0.006, 0.1, 0.002, 0.5),
                                  lambda: bodies.wheel(0.04, 0.006, 0.1, 0.002),
                                  lambda: bodies.plate(0.04, 0.004, 0.1, 0.002)])
def test_outline_bounds_the_particles(make):
    """The outline is the boundary the particles fill: every particle lies inside it (winding number
    1 summed over the loops), and the loops' signed area (holes negative) is the particles' area
    M·Δx² within 3 % (each particle is a Δx × Δx cell; the arcs' rows are resampled to ≈Δx)."""
    shape = make()
    assert shape.outline, "a generated shape carries its outline"
    inside = sum(_winding(shape.position, loop) for loop in shape.outline)
    assert np.all(inside == 1)
    area = sum(_signed_area(loop) for loop in shape.outline)
    assert area == pytest.approx(len(shape) * shape.spacing ** 2, rel=0.03)


def test_leg_wheel_outline_is_the_rotated_spokes():
    """A leg-wheel's loops are its spokes' loops rotated by 2πk/n: each keeps its area and
    orientation, and every particle lies inside at least one of them."""
    leg = bodies.c_leg(0.04, 0.006, 0.1, 0.002)
    wheel = bodies.leg_wheel("c-leg", 3, 0.04, 0.006, 0.1, 0.002)
    assert len(wheel.outline) == 3 * len(leg.outline)
    for loop in wheel.outline:
        assert _signed_area(loop) == pytest.approx(_signed_area(leg.outline[0]), rel=1e-12)
    inside = sum(_winding(wheel.position, loop) for loop in wheel.outline)
    assert np.all(inside >= 1)


@pytest.mark.parametrize("shape", _shapes(), ids=lambda s: s.name)
def test_lowest_point_is_the_lowest_of_all_particles_to_the_bit(shape):
    """lowest_point moves only the shape's rim; at every pose it is the minimum over all particles moved,
    bit for bit, including the poses that put an edge level (multiples of 1/4 degree) and random ones."""
    rng = np.random.default_rng(46)
    angles = np.concatenate([np.arange(-720, 721) * math.pi / 720, rng.uniform(-40.0, 40.0, 1500)])
    for angle in angles:
        origin = tuple(rng.uniform(-1.0, 1.0, 2))
        every = shape.position @ bodies.rotation_matrix(angle).T + np.asarray(origin, dtype=float)
        assert shape.lowest_point(angle, origin) == float(every[:, 1].min() - 0.5 * shape.spacing)
    assert len(shape.rim) < len(shape.position)  # a rim, not the whole body


def test_rim_holds_the_convex_hull_and_nothing_deep_inside():
    """A disc of lattice points: its rim is the points near its circle, none deeper than a spacing."""
    dx = 0.001
    grid = np.stack(np.meshgrid(np.arange(-20, 21), np.arange(-20, 21)), axis=-1).reshape(-1, 2) * dx
    disc = grid[np.hypot(*grid.T) <= 0.02 + 1e-12]
    shape = bodies.BodyShape("disc", disc, np.zeros_like(disc), dx, 0.02, 0.1, 0.02)
    radii = np.hypot(*shape.rim.T)
    assert radii.max() == pytest.approx(0.02) and radii.min() > 0.02 - 1.5 * dx
    square = bodies.BodyShape("square", grid, np.zeros_like(grid), dx, 0.04, 0.1, 0.02)
    assert len(square.rim) == 4 * 40  # every particle on the square's edges, collinear ones included
