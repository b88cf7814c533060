"""The load of the grains on the fixed walls (Simulation.track_wall_loads, the coupling's momentum
balance with the container's share).

References, independent of the code under test:
* a bed at rest in its container: the container carries the grains' weight, F_z = −M g, and its
  moment, the clockwise torque about a point p of the grains on the walls = (x̄ − p_x) M g with x̄
  the grains' centre of mass (the grains' moment balance; the side walls' thrusts, equal and
  opposite at equal heights, add no moment), time-averaged over 0.04–0.12 s, within 0.2 % [measured 4e-5];
* tracking is a read-out: a run that tracks the wall loads is bitwise the run that does not;
* an interrupted run that tracks them resumes bitwise (the checkpoint keeps the running impulses);
* the momentum balance with a robot part beside the container is in test_robot_coupling.py.
"""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest
from terrasph.bodies import plate
from terrasph.checkpoint import CheckpointError
from terrasph.config import ConfigError, Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.io import read_run
from terrasph.motion import Motion, Move
from terrasph.scene import Scene
from terrasph.simulation import Simulation

DX = 0.005
G = 9.81
WIDTH = 0.1  # m, the sample's real out-of-plane width
MATERIAL = Material()


def bed_in_container(*, with_plate: bool = False) -> Scene:
    """A 10 × 3 cm bed in a container; optionally a plate pushed down into it by a schedule."""
    scene = Scene(spacing=DX)
    surface, _ = scene.add_bed_in_container(0.1, 0.03, 0.03, layers=wall_layers_needed(1.3))
    if with_plate:
        scene.add_body("plate", plate(0.04, 3 * DX, WIDTH, DX), reference=(0.05, surface - 0.01),
                       motion=Motion([Move(0.2, (0.0, -0.05))]))
    return scene


def test_the_container_carries_the_weight_and_moment_of_a_bed_at_rest(tmp_path) -> None:
    sim = Simulation(bed_in_container(), MATERIAL, Numerics(spacing=DX), width=WIDTH)
    sim.track_wall_loads(about=(0.0, 0.0))
    weight = float(sim.mass.sum()) * WIDTH * G
    centre = float(sim.mass @ sim.position[:, 0] / sim.mass.sum())
    out = tmp_path / "bed.h5"
    result = sim.run(0.12, output=out, body_interval=0.02, progress=False, frame_interval=0.12)
    series = read_run(out).series["walls/container"]
    assert np.array_equal(series["force"], result.walls["container"]["force"])
    window = series["time"] > 0.04 + 1e-9  # samples of the mean over 0.04–0.12 s
    force = series["force"][window].mean(axis=0)
    torque = series["torque"][window].mean()
    assert force[1] == pytest.approx(-weight, rel=0.002)
    assert abs(force[0]) < 0.002 * weight
    assert torque == pytest.approx(centre * weight, rel=0.002)
    assert sim.leaked_particles == 0


@pytest.mark.parametrize("with_plate", [False, True])
def test_tracking_the_wall_loads_leaves_the_run_unchanged(with_plate: bool) -> None:
    """Bitwise, with no body (another force pass) and with a driven plate (the same pass)."""
    runs = []
    for tracked in (False, True):
        sim = Simulation(bed_in_container(with_plate=with_plate), MATERIAL, Numerics(spacing=DX), width=WIDTH)
        if tracked:
            sim.track_wall_loads(about=(0.05, 0.03))
        sim.advance(1.0, max_steps=150)
        runs.append(sim)
    untracked, tracked = runs
    assert untracked.wall_loads() == {}
    assert np.abs(tracked.wall_loads()["container"]["force_now"]).max() > 0
    for name in ("position", "velocity", "density", "acceleration"):
        assert np.array_equal(getattr(untracked.core, name), getattr(tracked.core, name)), name
    if with_plate:
        a, b = untracked.body_state("plate"), tracked.body_state("plate")
        assert np.array_equal(a["force_now"], b["force_now"]) and a["torque_now"] == b["torque_now"]
        assert "plate" not in tracked.wall_loads()  # a body's load is its own, not a fixed wall's


def test_bad_wall_load_requests_are_refused(tmp_path) -> None:
    sim = Simulation(bed_in_container(), MATERIAL, Numerics(spacing=DX))
    with pytest.raises(ConfigError, match=r"parameter 'about' .* allowed a point \(x, z\)"):
        sim.track_wall_loads(about=(0.0, float("nan")))
    active = Simulation(bed_in_container(), MATERIAL, Numerics(spacing=DX, freeze_speed=1e-3))
    with pytest.raises(ConfigError, match=r"active domain on \(numerics.freeze_speed > 0\)"):
        active.track_wall_loads()
    sim.track_wall_loads()
    sim.advance(1.0, max_steps=5)
    saved = sim.checkpoint(tmp_path / "tracked.checkpoint.h5")
    untracked = Simulation(bed_in_container(), MATERIAL, Numerics(spacing=DX))
    with pytest.raises(CheckpointError, match=r"does not fit this simulation: .*call track_wall_loads before restoring"):
        untracked.restore(saved)
    elsewhere = Simulation(bed_in_container(), MATERIAL, Numerics(spacing=DX))
    elsewhere.track_wall_loads(about=(0.01, 0.0))
    with pytest.raises(CheckpointError, match=r"does not fit this simulation: .*about another point"):
        elsewhere.restore(saved)
    tracking = Simulation(bed_in_container(), MATERIAL, Numerics(spacing=DX))
    tracking.track_wall_loads()
    with pytest.raises(CheckpointError, match=r"does not fit this simulation: .*does not track wall loads"):
        tracking.restore(untracked.checkpoint(tmp_path / "untracked.checkpoint.h5"))


def _interrupt_after_frames(frames: int):
    """An on_frame callback that sends this process SIGINT at the `frames`-th frame (the run stops
    at the next step boundary and checkpoints)."""
    seen = [0]

    def on_frame(_: Simulation) -> None:
        seen[0] += 1
        if seen[0] == frames:
            os.kill(os.getpid(), signal.SIGINT)

    return on_frame


def test_an_interrupted_run_that_tracks_wall_loads_resumes_bitwise(tmp_path) -> None:
    """Checkpoints keep the tracked loads (the last force and torque and the running impulses): the
    resumed run's wall series, frames and body series equal the uninterrupted run's bit for bit."""
    def tracked_run(out, *, resume: bool = False, on_frame=None):
        sim = Simulation(bed_in_container(with_plate=True), MATERIAL, Numerics(spacing=DX), width=WIDTH)
        sim.track_wall_loads(about=(0.05, 0.0))
        return sim.run(0.06, output=out, frame_interval=0.01, body_interval=0.007, progress=False,
                       checkpoint_every=None, resume=resume, on_frame=on_frame)

    straight, stopped = tmp_path / "straight.h5", tmp_path / "stopped.h5"
    tracked_run(straight)
    with pytest.raises(KeyboardInterrupt):
        tracked_run(stopped, on_frame=_interrupt_after_frames(3))
    assert read_run(stopped).series["walls/container"]["time"][-1] < 0.05
    resumed = tracked_run(stopped, resume=True)
    a, b = read_run(stopped), read_run(straight)
    # the resumed run's result holds the whole run's wall series, as its file does
    assert np.array_equal(resumed.walls["container"]["force"], b.series["walls/container"]["force"])
    for group in ("walls/container", "bodies/plate"):
        assert set(a.series[group]) == set(b.series[group])
        for name, values in b.series[group].items():
            assert np.array_equal(a.series[group][name], values), f"{group}/{name}"
    assert np.array_equal(a.times, b.times)
    assert np.array_equal(a.fields["velocity"], b.fields["velocity"])


def test_a_coupled_run_samples_the_fixed_walls_loads(tmp_path) -> None:
    """run_coupled writes ``walls/<name>`` (and, for a robot without actuators, no actuator series): here the floor under a small far bed carries its weight
    (the bed is released at its hydrostatic density: within 2 % from the start, measured 0.3 %)."""
    from robot_helpers import PLANAR_JOINTS, far_grains_scene, mjcf, sph_terrain
    from terrasph.robots.run import run_coupled

    body = '<body name="plate" pos="0.4 0 0.3">{joints}<geom type="box" size="0.02 0.025 0.0075" mass="0.5"/></body>'
    sand = sph_terrain(mjcf(body, joints=PLANAR_JOINTS), {"plate": plate(0.04, 3 * DX, 0.05, DX)}, far_grains_scene())
    sand.coupling.sim.track_wall_loads()
    out = tmp_path / "robot.h5"
    series = run_coupled(sand, 0.03, output=out, series_interval=0.01)
    floor = read_run(out).series["walls/floor"]
    assert np.array_equal(floor["force"], series["walls/floor"]["force"])
    assert len(floor["time"]) == 4  # each row averages the load over the time since the previous one
    assert np.allclose(floor["averaged_over"][1:], np.diff(floor["time"]), rtol=0, atol=1e-12)
    weight = float(sand.coupling.sim.mass.sum()) * sand.coupling.sim.width * G
    assert floor["force"][1:, 1] == pytest.approx(-weight, rel=0.02)
    assert "robot/actuators" not in series
