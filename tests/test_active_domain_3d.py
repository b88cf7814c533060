"""The active domain (numerics.freeze_speed with numerics.active_radius) in 3D (``Simulation3D``).

Scene: a lithostatic bed 24 × 6 × 5 cells (Δx = 4 mm, 9.6 cm long) in an open box, a 3 × 3 × 2
cell box body resting half a spacing above the surface over the bed's left end; it is held, then
pushed 5 cm/s down into the bed. The run with the active domain (freeze speed 1 mm/s over 20
steps, active radius 2 cm) is compared with the same run without it. References:
* grains farther than 5 cm from every body particle are frozen by the end of the hold and stay
  bitwise unchanged (position, velocity, density, stress) while the body is pushed in (the push
  wakes grains out to about 4.4 cm: the awake region grows from the radius as the grains near it
  start to move);
* no grain within the radius of a body particle is frozen;
* the near field (grains within 1.5 cm of the body, which the push moves by 0.5 mm) matches the
  full run: positions within 5e-6 m [measured 1.5e-6 m] and velocities within 1e-3 m/s [measured
  2.1e-4 m/s, against the push's 5 cm/s]; the body's force within 1 % of the full run's [measured
  0.30 %] (the frozen far field's small settling is all that differs);
* 1, 2 and 3 threads give bitwise the same run.
"""

from __future__ import annotations

import numpy as np
import pytest
from sph3d_helpers import BODY, box_body, box_walls, lithostatic_bed, params, with_body
from terrasph import _core

DX = 0.004
BED = (24, 6, 5)
SURFACE = BED[2] * DX
BODY_CENTRE = np.array([3 * DX, 3 * DX, SURFACE + 1.5 * DX])  # its bottom row half a spacing above the grains
HOLD, PUSH = 0.03, 0.02  # s: the body held, then pushed down
PUSH_SPEED = 0.05  # m/s
RADIUS = 0.02  # m, numerics.active_radius
FAR = 0.05  # m: beyond what the push wakes
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
FIELDS = ("position", "velocity", "density", "stress")


def run(active: bool) -> dict[str, np.ndarray]:
    """The bed with its body held, then pushed down; with `active` the active domain is on. The
    grains' state after the hold (`held_*`) and at the end, the body's final force and particles."""
    p = params(DX)
    if active:
        p.numerics.freeze_speed = 1e-3
        p.numerics.freeze_steps = 20
        p.numerics.active_radius = RADIUS
    position, normal = box_body(BODY_CENTRE, (3, 3, 2), DX)
    sim = _core.Simulation3D(p, lithostatic_bed(p, BED, DX), with_body(box_walls(BED, DX), position, normal, DX))
    sim.add_body(BODY, BODY_CENTRE, IDENTITY, [[HOLD, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                                               [np.inf, 0.0, 0.0, -PUSH_SPEED, 0.0, 0.0, 0.0]])
    out = {}
    for stage, t_end in (("held_", HOLD), ("", HOLD + PUSH)):
        sim.advance(t_end, 100_000)
        for name in FIELDS:
            out[stage + name] = np.array(getattr(sim, name))
        out[stage + "frozen"] = np.array(sim.field("frozen"), bool) if active else np.zeros(len(sim.mass), bool)
    out["force"] = np.asarray(sim.body_state(0)["force"])
    out["body"] = np.array(sim.wall_position)[np.array(sim.field("group", "walls")) == BODY]
    out["steps"] = np.array(sim.step)
    return out


def distance_to(points: np.ndarray, body: np.ndarray) -> np.ndarray:
    """Each point's distance to the nearest body particle."""
    return np.min(np.linalg.norm(points[:, None, :] - body[None, :, :], axis=2), axis=1)


@pytest.fixture(scope="module")
def runs() -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    return run(active=True), run(active=False)


def test_far_grains_freeze_and_stay_bitwise_put_while_the_body_is_pushed_in(runs) -> None:
    active, _ = runs
    far = distance_to(active["held_position"], active["body"]) > FAR
    assert far.sum() > 200
    assert active["held_frozen"][far].all() and active["frozen"][far].all()
    for name in FIELDS:
        assert np.array_equal(active["held_" + name][far], active[name][far]), name


def test_no_grain_within_the_radius_of_the_body_is_frozen(runs) -> None:
    active, _ = runs
    near = distance_to(active["position"], active["body"]) < RADIUS
    assert near.sum() > 50
    assert not active["frozen"][near].any()


def test_the_near_field_and_the_body_force_match_the_full_run(runs) -> None:
    active, full = runs
    assert active["steps"] == full["steps"]
    near = distance_to(full["position"], full["body"]) < 0.015
    moved = np.abs(full["position"][near] - full["held_position"][near]).max()
    assert moved > 2e-4  # the push moves the near field
    assert np.abs(active["position"][near] - full["position"][near]).max() < 5e-6
    assert np.abs(active["velocity"][near] - full["velocity"][near]).max() < 1e-3
    force = full["force"]
    assert np.linalg.norm(force) > 0.0
    assert np.linalg.norm(active["force"] - force) < 1e-2 * np.linalg.norm(force)


def test_bitwise_with_one_two_and_three_threads(restore_threads) -> None:
    states = []
    for threads in (1, 2, 3):
        _core.set_num_threads(threads)
        states.append(run(active=True))
    assert states[0]["frozen"].any()
    for other in states[1:]:
        for name, value in states[0].items():
            assert np.array_equal(value, other[name]), name
