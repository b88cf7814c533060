"""Resistive force theory (terrasph.terrain.rft): the generic map's published properties, hand-computed plates,
the geometry read from a shape's outline, coefficient tables and bad input."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import robot_helpers
from terrasph import bodies
from terrasph.config import ConfigError
from terrasph.mjcf.model import PlanarRobot
from terrasph.scenes.leg_rotation import LegRotation, run_leg_rotation
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel
from terrasph.terrain import rft, rft_coupling

G = rft.GENERIC
ZETA = G.zeta
WIDTH = 0.0254


def _plate_elements(length: float = 0.04, thickness: float = 0.0075) -> rft.SurfaceElements:
    return rft.SurfaceElements.from_shape(bodies.plate(length, thickness, WIDTH, 0.0025), 0.001)


# -- the generic map (Li, Zhang & Goldman 2013, Table S2) ------------------------------------------

def test_generic_map_is_normalised_to_a_plate_pushed_down():
    """The generic coefficients are normalised so that a horizontal plate pushed straight down
    (β = 0, γ = π/2) has α̂_z = A00 + A10 + B11 + B01 + B−11 = 1: ζ is that plate's stress per depth,
    the largest vertical coefficient of the map."""
    ax, az = G.alpha(0.0, math.pi / 2)
    assert az == pytest.approx(ZETA, rel=1e-12)
    assert abs(ax) < 1e-9 * ZETA
    beta, gamma = np.meshgrid(np.linspace(-math.pi / 2, math.pi / 2, 61), np.linspace(-math.pi / 2, math.pi / 2, 61))
    assert G.alpha(beta, gamma)[1].max() <= ZETA * (1 + 1e-12)


def test_generic_map_pull_out_is_a_quarter_of_push_in():
    """Pulled straight up, the horizontal plate meets −0.25 of the push-in stress (the figure the
    issue quotes for RFT's generic fit): downward, a quarter of it."""
    _, up = G.alpha(0.0, -math.pi / 2)
    assert up / ZETA == pytest.approx(-0.25, abs=1e-12)


def test_generic_map_symmetries_of_vertical_intrusion():
    """Straight down or up (γ = ±π/2) the motion is mirror-symmetric: α_z even and α_x odd in β."""
    beta = np.linspace(-math.pi / 2, math.pi / 2, 37)
    for gamma in (math.pi / 2, -math.pi / 2):
        ax, az = G.alpha(beta, gamma)
        ax_m, az_m = G.alpha(-beta, gamma)
        np.testing.assert_allclose(az, az_m, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(ax, -ax_m, rtol=1e-12, atol=1e-9)


def test_generic_map_horizontal_drag_is_resisted_and_lifts():
    """A plate dragged horizontally is resisted at every attack angle (α_x > 0: the force opposes
    the motion) and a horizontal one is lifted (α_z(0, 0) = A00 + A10 = 0.375 ζ), as Li et al. found."""
    ax, _ = G.alpha(np.linspace(-math.pi / 2, math.pi / 2, 91), 0.0)
    assert ax.min() > 0.1 * ZETA
    assert G.alpha(0.0, 0.0)[1] == pytest.approx(0.375 * ZETA, rel=1e-12)


def test_fourier_basis_reproduces_the_map():
    """The basis a calibration fits with gives the map's values (α̂ = basis @ coefficients)."""
    beta, gamma = np.meshgrid(np.linspace(-1.5, 1.5, 7), np.linspace(-1.5, 1.5, 7))
    bx, bz = rft.fourier_basis(beta, gamma)
    ax, az = G.alpha(beta, gamma)
    np.testing.assert_allclose(ZETA * (bx @ G.vector), ax, rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(ZETA * (bz @ G.vector), az, rtol=1e-12, atol=1e-6)


def _random_series(rng: np.random.Generator, order: tuple[int, int] = (3, 3)) -> rft.RFTCoefficients:
    names = rft.series_names(*order)
    return rft.RFTCoefficients(dict(zip(names, rng.normal(0.0, 0.2, len(names)).tolist())), zeta=1.5e5)


def test_every_term_name_of_the_series_reads_back():
    names = rft.series_names(rft.MAX_ORDER, rft.MAX_ORDER)
    assert len(set(names)) == len(names)
    assert all(rft.term_name(rft.parse_term(name)) == name for name in names)
    assert set(rft.series_names(1, 1)) == set(rft.COEFFICIENT_NAMES)  # Li et al.'s nine are order (1, 1)


def test_any_map_of_the_series_keeps_vertical_motion_mirror_symmetric(rng):
    """Pushed straight down or up, a plate and its mirror image (β → −β) meet the same α_z and opposite
    α_x: the symmetry the x → −x mirroring of the law needs, which the terms' parity rule guarantees
    for every map, not only Li et al.'s."""
    table = _random_series(rng, (rft.MAX_ORDER, rft.MAX_ORDER))
    beta = np.linspace(-1.5, 1.5, 13)
    for gamma in (math.pi / 2, -math.pi / 2):
        ax, az = table.alpha(beta, gamma)
        ax_m, az_m = table.alpha(-beta, gamma)
        np.testing.assert_allclose(az, az_m, atol=1e-9 * table.zeta)
        np.testing.assert_allclose(ax, -ax_m, atol=1e-9 * table.zeta)


def test_compiled_load_evaluates_a_higher_order_map_as_its_basis_does(rng):
    """One horizontal element at depth d below the surface, its normal leading, moving in direction γ:
    the compiled core's load (angle addition of the multiples, cpp/src/rft.cpp) is (−α_x, α_z) d ℓ w of
    the map evaluated term by term in numpy (RFTCoefficients.alpha), and its velocity Jacobian matches
    central differences."""
    table = _random_series(rng)
    element = rft.SurfaceElements(np.array([[0.0, -0.03]]), np.array([[0.0, -1.0]]), np.array([0.002]), WIDTH)
    for gamma in (0.3, 0.9, 1.4):
        velocity = 0.02 * np.array([math.cos(gamma), -math.sin(gamma)])
        load = rft.body_load(element, 0.0, (0.0, 0.0), velocity, 0.0, 0.0, table, jacobian=True)
        ax, az = table.alpha(0.0, gamma)
        assert load.force == pytest.approx([-ax * 0.03 * 0.002 * WIDTH, az * 0.03 * 0.002 * WIDTH], rel=1e-12)
        for k in range(2):
            step = np.zeros(2)
            step[k] = 1e-7
            up = rft.body_load(element, 0.0, (0.0, 0.0), velocity + step, 0.0, 0.0, table).force
            down = rft.body_load(element, 0.0, (0.0, 0.0), velocity - step, 0.0, 0.0, table).force
            np.testing.assert_allclose(load.jacobian[:2, k], (up - down) / 2e-7, rtol=1e-5, atol=1e-9)


# -- hand-computed plates ---------------------------------------------------------------------------

@pytest.mark.parametrize("speed, alpha_hat", [(-0.01, 1.0), (0.01, -0.25)])
def test_horizontal_plate_pushed_down_and_pulled_up(speed, alpha_hat):
    """A horizontal plate wholly below the surface moving straight down (up) is loaded on its
    underside (top face) only: F_z = α̂_z ζ d L W with d the depth of that face, F_x = 0. Its
    vertical end faces move parallel to themselves and take no load."""
    elements = _plate_elements()
    half = 0.5 * 0.0075
    centre = -0.03
    face_depth = -(centre - half) if speed < 0 else -(centre + half)
    load = rft.body_load(elements, 0.0, (0.0, centre), np.array([0.0, speed]), 0.0, 0.0, G)
    assert load.force[1] == pytest.approx(alpha_hat * ZETA * face_depth * 0.04 * WIDTH, rel=1e-9)
    assert abs(load.force[0]) < 1e-9 * abs(load.force[1])
    assert abs(load.torque) < 1e-9


def test_vertical_plate_dragged_forward():
    """A vertical flat leg, hip at the surface, dragged forward: only its front face (at x = t/2)
    leads, with α_x(π/2, 0) = (−C11 + C01 − C−11) ζ = 0.370 ζ and α_z(π/2, 0) = (A00 − A10) ζ = 0.037 ζ.
    Integrating the depth over the face: F_x = −α_x W D²/2, F_z = α_z W D²/2, and the clockwise torque
    about the hip ∫ (r_z dF_x − r_x dF_z) = α_x W D³/3 − (t/2) α_z W D²/2 (the backward load on the
    tip turns the leg clockwise)."""
    depth, half = 0.06, 0.0032
    elements = rft.SurfaceElements.from_shape(bodies.flat_leg(depth, 2 * half, WIDTH, 0.0016), 0.0005)
    load = rft.body_load(elements, 0.0, (0.0, 0.0), np.array([0.05, 0.0]), 0.0, 0.0, G)
    k = G.coefficients
    alpha_x, alpha_z = (-k["C11"] + k["C01"] - k["Cm11"]) * ZETA, (k["A00"] - k["A10"]) * ZETA
    assert load.force[0] == pytest.approx(-alpha_x * WIDTH * depth ** 2 / 2, rel=1e-6)
    assert load.force[1] == pytest.approx(alpha_z * WIDTH * depth ** 2 / 2, rel=1e-6)
    expected = alpha_x * WIDTH * depth ** 3 / 3 - half * alpha_z * WIDTH * depth ** 2 / 2
    assert load.torque == pytest.approx(expected, rel=1e-4)


def test_mirror_image_gets_the_mirrored_load():
    """The reversed C-leg is the C-leg mirrored x → −x: turned by −θ and moving with (−v_x, v_z, −ω)
    it feels (−F_x, F_z) and the opposite torque, whatever the pose (the map's mirror rule for faces
    moving backward)."""
    args = (0.0762, 0.0064, WIDTH, 0.0021)
    c_leg = rft.SurfaceElements.from_shape(bodies.c_leg(*args))
    mirrored = rft.SurfaceElements.from_shape(bodies.reversed_c_leg(*args))
    for angle, velocity, omega in [(-0.5, (0.03, -0.02), 0.4), (0.3, (-0.01, 0.01), 0.2), (0.0, (0.0, -0.05), 0.0)]:
        a = rft.body_load(c_leg, angle, (0.0, 0.02), np.array(velocity), omega, 0.0, G)
        b = rft.body_load(mirrored, -angle, (0.0, 0.02), np.array([-velocity[0], velocity[1]]), -omega, 0.0, G)
        np.testing.assert_allclose(b.force, [-a.force[0], a.force[1]], rtol=1e-9, atol=1e-9)
        assert b.torque == pytest.approx(-a.torque, rel=1e-9, abs=1e-12)


def test_load_converges_with_the_element_length():
    """A C-leg wheel's load changes by less than 1 % between elements of R/20 and R/80."""
    shape = bodies.leg_wheel("c-leg", 3, 0.08, 0.005, 0.1, 0.005 / 3)
    loads = [rft.body_load(rft.SurfaceElements.from_shape(shape, 0.08 / n), 0.3, (0.0, 0.05),
                           np.array([0.08, -0.01]), 1.5, 0.0, G) for n in (20, 80)]
    assert np.linalg.norm(loads[0].force - loads[1].force) < 0.01 * np.linalg.norm(loads[1].force)


def test_jacobian_matches_finite_differences():
    """The load's derivative in (v_x, v_z, ω) agrees with central differences of the load itself."""
    elements = rft.SurfaceElements.from_shape(bodies.leg_wheel("c-leg", 3, 0.08, 0.005, 0.1, 0.005 / 3))
    twist = np.array([0.05, -0.01, 1.2])

    def load(x):
        result = rft.body_load(elements, 0.4, (0.0, 0.05), x[:2], x[2], 0.0, G)
        return np.r_[result.force, result.torque]

    analytic = rft.body_load(elements, 0.4, (0.0, 0.05), twist[:2], twist[2], 0.0, G, jacobian=True).jacobian
    numeric = np.column_stack([(load(twist + h) - load(twist - h)) / (2 * 1e-7)
                               for h in np.eye(3) * 1e-7])
    np.testing.assert_allclose(analytic, numeric, rtol=1e-4, atol=1e-4 * np.abs(numeric).max())


# -- geometry -----------------------------------------------------------------------------------------

def test_overlapping_spokes_keep_only_the_outer_surface():
    """Three flat spokes overlap at the hub: the faces inside another spoke are dropped, so the
    elements' total length is the outline of the union, three spokes' perimeters minus the hub
    parts (less than the sum of the loops, more than the sum minus the spokes' inner ends)."""
    shape = bodies.leg_wheel("flat-leg", 3, 0.08, 0.006, 0.1, 0.002)
    elements = rft.SurfaceElements.from_shape(shape)
    loops = sum(float(np.sum(np.hypot(*np.diff(np.vstack([loop, loop[:1]]), axis=0).T))) for loop in shape.outline)
    assert loops - 3 * 3 * 0.006 < elements.length.sum() < loops - 0.006
    # the plain wheel's rim: both loops (outer surface and the hole's) are surface
    rim = bodies.wheel(0.08, 0.006, 0.1, 0.002)
    assert rft.SurfaceElements.from_shape(rim).length.sum() == pytest.approx(2 * math.pi * (0.08 + 0.074), rel=1e-3)


# -- carried grains ------------------------------------------------------------------------------------

def _cup(spacing: float = 0.0005) -> tuple[bodies.BodyShape, float]:
    """The reversed C-leg of chapter 3 (a half ring opening backward, −x) and its cup's area, the half
    disc inside the ring, π (R/2 − t/2)²/2 (hand geometry)."""
    radius, thickness = 0.0762, 0.0064
    return bodies.reversed_c_leg(radius, thickness, WIDTH, spacing), 0.5 * math.pi * (0.5 * radius - 0.5 * thickness) ** 2


def test_pockets_are_the_open_regions_between_outline_and_hull():
    """The reversed C-leg has one pocket, its cup, of the half disc's area (to 1 %); a flat leg has
    none; a rim's hole, closed by the body, holds no grains and is no pocket."""
    shape, area = _cup()
    cup = rft.SurfaceElements.from_shape(shape)
    assert set(cup.cell_pocket) == {0} and cup.cell_area.sum() == pytest.approx(area, rel=0.01)
    assert np.count_nonzero(cup.wall_pocket == 0) > 0.3 * len(cup)  # the cup's inside faces it
    assert len(rft.SurfaceElements.from_shape(bodies.flat_leg(0.0762, 0.0064, WIDTH, 0.0005)).cell_area) == 0
    assert len(rft.SurfaceElements.from_shape(bodies.wheel(0.08, 0.006, 0.1, 0.002)).cell_area) == 0


def test_a_cup_pushing_its_opening_forward_carries_the_weight_of_its_grains():
    """Buried and pushed opening first (−x, its inside leading), the cup adds the weight ρ0 g A w of
    the grains it holds (A the half disc; the inside's tips, tangent to the motion, lead a little
    less, so 0.9–1.0 of it); half buried (the surface through the ring's centre), half that weight;
    drawn away from its opening (+x, its inside trailing) it carries nothing."""
    shape, area = _cup()
    elements = rft.SurfaceElements.from_shape(shape)
    weight = rft.GLASS_BEADS_DENSITY * 9.81 * area * WIDTH
    bare = dataclasses.replace(G, density=0.0)

    def carried(speed: float, surface: float) -> float:
        args = (elements, 0.0, (0.0, 0.0), np.array([speed, 0.0]), 0.0, surface)
        return rft.body_load(*args, G).force[1] - rft.body_load(*args, bare).force[1]

    assert -weight <= carried(-0.01, 0.2) < -0.9 * weight
    assert carried(-0.01, -0.0381) == pytest.approx(0.5 * carried(-0.01, 0.2), rel=0.02)
    assert carried(0.01, 0.2) == 0.0


def test_jacobian_with_pockets_matches_finite_differences_where_the_walls_turn():
    """Moving at the regularisation's speed, the cup's walls fade in and out of leading, and with
    them the carried weight: its derivative agrees with central differences of the load."""
    elements = rft.SurfaceElements.from_shape(_cup(0.001)[0])
    twist = np.array([-0.6, 0.3, 0.5]) * rft.REGULARISATION_SPEED

    def load(x: np.ndarray) -> np.ndarray:
        result = rft.body_load(elements, 0.3, (0.0, 0.02), x[:2], x[2], 0.0, G)
        return np.r_[result.force, result.torque]

    analytic = rft.body_load(elements, 0.3, (0.0, 0.02), twist[:2], twist[2], 0.0, G, jacobian=True).jacobian
    h = 1e-9
    numeric = np.column_stack([(load(twist + d) - load(twist - d)) / (2 * h) for d in np.eye(3) * h])
    np.testing.assert_allclose(analytic, numeric, rtol=1e-4, atol=1e-4 * np.abs(numeric).max())


# -- tables and bad input ------------------------------------------------------------------------------

def test_coefficient_table_round_trip(tmp_path):
    table = rft.RFTCoefficients({name: 1.1 * value for name, value in G.coefficients.items()} | {"A22": 0.02},
                                zeta=3.0e5, source="test", density=1500.0)
    path = rft.save_coefficients(table, tmp_path / "map.json", correlation=0.9)
    assert rft.coefficient_table(str(path)) == table
    assert json.loads(path.read_text())["units"]["zeta"] == "N/m^3"


@pytest.mark.parametrize("content, message", [
    ("{not json", "is not JSON"),
    ('{"format": "other"}', "malformed"),
    ('{"format": "terrasph-rft-coefficients", "zeta": 1.0, "coefficients": {}}', "a mapping of term names"),
    ('{"format": "terrasph-rft-coefficients", "zeta": 1.0, "coefficients": {"A01": 1}}', "not a term of the map"),
    ('{"format": "terrasph-rft-coefficients", "zeta": 1.0, "coefficients": {"E10": 1}}', "not a term's name"),
    ('{"format": "terrasph-rft-coefficients", "zeta": 1.0, "coefficients": {"A50": 1}}', "not a term"),
    ('{"format": "terrasph-rft-coefficients", "zeta": -1.0, "coefficients": '
     + json.dumps(dict.fromkeys(rft.COEFFICIENT_NAMES, 0.1)) + "}", "'zeta'"),
    ('{"format": "terrasph-rft-coefficients", "zeta": 1.0, "density": -5, "coefficients": '
     + json.dumps(dict.fromkeys(rft.COEFFICIENT_NAMES, 0.1)) + "}", "'density'"),
])
def test_malformed_table_is_refused(tmp_path, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(ConfigError, match=message):
        rft.coefficient_table(str(path))


def test_unknown_table_and_shape_without_outline_are_refused():
    with pytest.raises(ConfigError, match="rft_table"):
        rft.coefficient_table("poppy")
    bare = bodies.BodyShape("dots", np.zeros((1, 2)), np.array([[0.0, -1.0]]), 0.001, 0.003, 0.01, 0.01)
    with pytest.raises(ConfigError, match="no outline"):
        rft.SurfaceElements.from_shape(bare)


# -- the RFT terrain for MuJoCo robots ---------------------------------------------------------------

def _plate_on_sand(mass: float, time_step: float = rft_coupling.RFT_TIME_STEP) -> rft_coupling.RFTCoupling:
    """A 4 cm plate of `mass` kg, free to slide vertically, its underside on the surface z = 0."""
    xml = robot_helpers.mjcf('<body name="foot" pos="0 0 0.00375">{joints}'
                             f'<inertial pos="0 0 0" mass="{mass}" diaginertia="1e-4 1e-4 1e-4"/></body>',
                             joints='<joint name="z" type="slide" axis="0 0 1"/>')
    robot = PlanarRobot(xml, {"foot": bodies.plate(0.04, 0.0075, WIDTH, 0.0025)})
    return rft_coupling.RFTCoupling(robot, 0.0, G, time_step=time_step)


def test_plate_dropped_on_the_sand_stops_at_twice_the_bearing_depth():
    """A plate released at rest on the RFT sand: the resistance ζ d L W grows like a spring's but
    is not given back (pulled up the plate meets a downward −0.25 of it), so it stops where the
    work of its weight equals the work of sinking, m g d = ζ L W d²/2: d = 2 m g / (ζ L W)
    (hand-computed), and stays. The load fades below 0.1 mm/s of sinking, so at rest it creeps:
    after 0.2 s it lies within 0.5 % of that depth and the creep (≤ 0.1 mm/s) above it. The load
    is taken at the step's start pose, a first-order error: 5 % at the robots' 2 ms step, whose
    slip and sinkage converge far better (docs/rft.md), 0.15 % at the 0.5 ms used here."""
    mass = 0.3
    coupled = _plate_on_sand(mass, time_step=5e-4)
    coupled.advance(0.2)
    body = coupled.robot.coupled[0]
    depth = -body.shape.lowest_point(0.0, tuple(coupled.robot.reference(body)))
    expected = 2 * mass * 9.81 / (ZETA * 0.04 * WIDTH)
    assert 0.995 * expected < depth < 1.005 * expected + rft.REGULARISATION_SPEED * 0.2
    velocity, _ = coupled.robot.velocity(body)
    assert abs(velocity[1]) <= rft.REGULARISATION_SPEED  # at rest but for the creep, no chatter


@pytest.mark.slow
def test_leg_wheel_on_rft_runs_and_is_deterministic(tmp_path):
    """``terrain='rft'``: the leg-wheel scene's run loop and series on the RFT terrain; the C-leg wheel
    drives forward with a slip in (0, 1), and a second run gives the same series bit for bit."""
    config = LegWheel(terrain="rft", settle_time=0.1, t_end=0.5)
    first = run_leg_wheel(config, output=tmp_path / "a.h5")
    second = run_leg_wheel(config, plot=False)
    summary = first.summary()
    assert 0 < summary["mean_slip"] < 1 and summary["mean_forward_speed"] > 0
    assert 0 < summary["mean_sinkage"] < config.leg_length
    assert np.array_equal(first.series["robot/wheel"]["reference"], second.series["robot/wheel"]["reference"])
    assert (tmp_path / "a.png").exists()


def test_leg_rotation_on_rft_and_its_bad_input():
    """``terrain='rft'`` gives the leg-rotation scene's result at once; a leg that never reaches the
    sand, an unknown terrain and an unknown table are refused before any work."""
    result = run_leg_rotation(LegRotation(leg="flat", terrain="rft"), progress=False, plot=False)
    assert result.peak_lift > 0 and result.peak_thrust > 0
    with pytest.raises(ConfigError, match="terrain"):
        LegRotation(terrain="dem")
    with pytest.raises(ConfigError, match="rft_table"):
        LegWheel(terrain="rft", rft_table="nowhere")
    # a setting of the SPH bed only is refused on RFT, never ignored; at its default it is fine
    for name, value in (("water_content", 0.005), ("mu2_deg", 35.0), ("bed_depth", 0.2)):
        with pytest.raises(ConfigError, match=f"'{name}' = .* on the RFT terrain"):
            LegWheel(terrain="rft", **{name: value})
        LegWheel(terrain="sph", **{name: value})
    with pytest.raises(ConfigError, match=r"'bed_depth' = .* on the RFT terrain"):
        LegRotation(terrain="rft", bed_depth=0.08)
    with pytest.raises(ConfigError, match="no element"):
        run_leg_rotation(LegRotation(terrain="rft", hip_height=0.06, start_angle=-1.2, end_angle=-1.1),
                         progress=False, plot=False)


def test_leg_rotation_on_rft_samples_the_load_as_the_sph_does():
    """The RFT sweep goes through the run loop with the SPH's sampling: a sample every
    1/(samples_per_radian ω) s, its force the mean load over its interval. Checked against an
    independent quadrature of the load over each interval (the mean of 41 points: the sweep's loads
    differ from it by the midpoint rule's O(Δθ²) only), and against the pose at the sample's time."""
    config = LegRotation(leg="c-leg", terrain="rft", settle_time=0.5, omega=1.0, samples_per_radian=20.0)
    result = run_leg_rotation(config, progress=False, plot=False)
    series = result.run.bodies["leg"]
    interval = 1.0 / (config.samples_per_radian * config.omega)
    spans = np.diff(series["time"])  # the last one ends at the end of the sweep
    np.testing.assert_allclose(spans[:-1], interval, rtol=0, atol=1e-9)
    assert 0 < spans[-1] <= interval + 1e-9
    elements = rft.SurfaceElements.from_shape(config.shape(), width=config.width)
    hip = (0.0, config.hip_height)
    turning = series["time"] > config.settle_time + 1e-9
    peak = np.abs(result.lift).max()
    assert result.theta.size == math.ceil((config.end_angle - config.start_angle) / (config.omega * interval) - 1e-9)
    for t, span, theta, lift in zip(series["time"][turning], spans[turning[1:]], result.theta, result.lift):
        assert theta == pytest.approx(config.start_angle + config.omega * (t - config.settle_time), abs=1e-12)
        angles = theta - config.omega * span * np.linspace(0.0, 1.0, 41)
        loads = [rft.body_load(elements, a, hip, np.zeros(2), config.omega, 0.0, G).force[1] for a in angles]
        mean = np.trapezoid(loads, dx=1.0) / 40.0
        assert lift == pytest.approx(mean, abs=0.01 * peak)
    assert not series["force"][~turning].any()  # a leg at rest takes no RFT load


# -- calibration ------------------------------------------------------------------------------------

def _sampled(table: rft.RFTCoefficients, rng: np.random.Generator, points: int = 49, noise: float = 0.0):
    beta, gamma = rng.uniform(-math.pi / 2, math.pi / 2, (2, points))
    ax, az = table.alpha(beta, gamma)
    scale = noise * table.zeta
    return beta, gamma, ax + scale * rng.standard_normal(points), az + scale * rng.standard_normal(points)


def test_fit_recovers_a_known_map_from_noisy_samples(rng):
    """49 samples of a map (the generic one with a different ζ and tilted coefficients), with noise of
    2 % of ζ: the fit's ζ is within 2 % and its shape correlates with the true one at r > 0.99 (the
    least-squares error of 9 unknowns from 98 values at that noise)."""
    tilted = G.vector + 0.03 * np.arange(9) / 9
    tilted /= float(rft.fourier_basis(0.0, math.pi / 2)[1] @ tilted)
    truth = rft.RFTCoefficients(dict(zip(rft.COEFFICIENT_NAMES, tilted.tolist())), zeta=3.1e5)
    fitted, quality = rft.fit_coefficients(*_sampled(truth, rng, noise=0.02))
    assert fitted.zeta == pytest.approx(truth.zeta, rel=0.02)
    correlation = rft.map_correlation(fitted, truth)
    assert correlation["r_x"] > 0.99 and correlation["r_z"] > 0.99
    assert quality["rms_residual"] < 0.03 * truth.zeta


def test_a_higher_order_fit_recovers_its_map_and_leave_one_out_measures_the_noise(rng):
    """Li et al.'s generic map with random terms up to order (2, 3) added, sampled on a 12 × 13 grid with noise of 2 % of ζ: the order-(2, 3) fit gets ζ
    within 3 % (a sum of 35 fitted terms) and its held-out (leave-one-out) rms error is the noise's size, 1.5–3 % of ζ; an order
    (1, 2) fit cannot carry that map, and its held-out error says so (above 3 × the noise)."""
    names = rft.series_names(2, 3)
    values = rng.normal(0.0, 0.1, len(names)) + np.array([G.coefficients.get(name, 0.0) for name in names])
    values /= float(rft.fourier_basis(0.0, math.pi / 2, names)[1] @ values)
    truth = rft.RFTCoefficients(dict(zip(names, values.tolist())), zeta=2.0e5)
    beta, gamma = (a.ravel() for a in np.meshgrid(np.linspace(-math.pi / 2, 1.31, 12), np.linspace(-math.pi / 2, math.pi / 2, 13)))
    ax, az = truth.alpha(beta, gamma)
    noise = 0.02 * truth.zeta
    ax, az = ax + noise * rng.standard_normal(ax.shape), az + noise * rng.standard_normal(az.shape)
    fitted, quality = rft.fit_coefficients(beta, gamma, ax, az, names=names)
    assert fitted.zeta == pytest.approx(truth.zeta, rel=0.03)
    assert 0.75 * noise < quality["rms_loo"] < 1.5 * noise
    _, lower = rft.fit_coefficients(beta, gamma, ax, az, names=rft.series_names(1, 2))
    assert lower["rms_loo"] > 3 * noise


def test_rft_calibrate_command_fits_a_sweep(tmp_path, rng):
    """``terrasph rft-calibrate`` reads a sweep's finished plate-drag cases and writes a table that
    loads and reproduces the map the cases were sampled from; bad input exits 2 in one line."""
    from terrasph.cli import main

    beta, gamma, ax, az = _sampled(G, rng)
    cases = [{"status": "completed", "summary": {"attack_angle": b, "direction": g, "alpha_x": x, "alpha_z": z,
                                                  "spacing": 0.005, "plate_thickness": 0.015}}
             for b, g, x, z in zip(beta, gamma, ax, az)]
    (tmp_path / "manifest.json").write_text(json.dumps({"cases": cases}))
    assert main(["rft-calibrate", str(tmp_path), "--out", str(tmp_path / "map.json"), "--order", "1", "1"]) == 0
    table = rft.coefficient_table(str(tmp_path / "map.json"))
    assert set(table.names) == set(G.names)
    np.testing.assert_allclose([table.coefficients[k] for k in G.names], G.vector, atol=1e-9)
    assert table.zeta == pytest.approx(ZETA, rel=1e-9)
    # the default chooses an order by leave-one-out error; any order holds the generic map exactly
    assert main(["rft-calibrate", str(tmp_path), "--out", str(tmp_path / "auto.json")]) == 0
    chosen = rft.coefficient_table(str(tmp_path / "auto.json"))
    grid = np.meshgrid(np.linspace(-1.5, 1.5, 9), np.linspace(-1.5, 1.5, 9))
    np.testing.assert_allclose(chosen.alpha(*grid), G.alpha(*grid), atol=1e-6 * ZETA)
    with pytest.raises(SystemExit) as stop:
        main(["rft-calibrate", str(tmp_path / "none"), "--out", str(tmp_path / "x.json")])
    assert stop.value.code == 2


@pytest.mark.slow
def test_plate_drag_pushed_down_matches_the_intrusion_scale():
    """The plate-drag scene straight down (β = 0, γ = π/2) at Δx = 5 mm: no horizontal stress (the
    mirror symmetry, to 1 % of α_z) and α_z within 25 % of ζ of the plate-intrusion scene at 2.5 mm
    (GLASS_BEADS_ZETA; another depth, plate and resolution, so a loose band)."""
    from terrasph.scenes.plate_drag import PlateDrag, run_plate_drag

    result = run_plate_drag(PlateDrag(spacing=0.005, travel=0.01, samples=10), progress=False).summary()
    assert abs(result["alpha_x"]) < 0.01 * result["alpha_z"]
    assert result["alpha_z"] == pytest.approx(rft.GLASS_BEADS_ZETA, rel=0.25)
    assert result["leaked_particles"] == 0


def test_rft_terrain_checkpoint_continues_bit_for_bit(tmp_path):
    """A plate on the RFT sand checkpointed mid-fall and continued by a fresh stepper restored from
    the file ends where the uninterrupted one does, bit for bit (MuJoCo's state and the load means)."""
    whole = _plate_on_sand(0.3)
    whole.advance(0.05)
    whole.checkpoint(tmp_path / "c.h5")
    whole.advance(0.1)
    resumed = _plate_on_sand(0.3)
    resumed.restore(tmp_path / "c.h5")
    resumed.advance(0.1)
    assert np.array_equal(whole.robot.data.qpos, resumed.robot.data.qpos)
    assert np.array_equal(whole.body_sample("foot")["force"], resumed.body_sample("foot")["force"])


def test_rft_terrain_calls_its_controller_at_the_control_rate():
    """The native stepper takes many steps per call: a controller is called every
    RFT_CONTROL_INTERVAL of simulated time (at its multiples, five 2 ms steps) and is told that its
    commands hold for that span; the steps taken reach the end time as a call per step would."""
    coupled = _plate_on_sand(0.3)
    calls = []
    taken = coupled.advance(0.1, control=lambda run: calls.append((run.time, run.control_span())))
    interval = rft_coupling.RFT_CONTROL_INTERVAL
    assert taken == coupled.step_count == round(0.1 / rft_coupling.RFT_TIME_STEP)
    assert len(calls) == round(0.1 / interval)
    assert np.allclose([t for t, _ in calls], interval * np.arange(len(calls)), rtol=0, atol=1e-12)
    assert all(span == pytest.approx(interval) for _, span in calls)
    with pytest.raises(ConfigError, match="control_interval"):
        rft_coupling.RFTCoupling(coupled.robot, 0.0, G, control_interval=1e-3)
