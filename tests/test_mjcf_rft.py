"""Scene ``mjcf`` on the 3D RFT terrain (``--terrain rft``, docs/mjcf.md): any MJCF model — a free
joint, hinges about any axis — from the command line. The output contract (status, files, resume
bit for bit) is tests/test_output_contract.py's case "mjcf on rft"; the bad options are rows of
tests/test_cli_errors.py. Here: the non-planar refusal on the SPH names the joint and the terrain
that takes it, a box dropped on the sand comes to rest where the hand computation puts it (the
scene's summary, not only the stepper: tests/test_rft3d.py), the wheels found for slip, and the
rover's one-liner with its figure."""

from __future__ import annotations

import json
import math

import pytest
from terrasph.cli import main
from terrasph.io import read_run
from terrasph.robots import ROVER4
from terrasph.robots.run import wheel_radii
from terrasph.scenes.mjcf_scene import MjcfScene, run_mjcf
from terrasph.terrain import rft
from terrasph.terrain.rft3d_coupling import rft_robot

WHEELS = ("front_left", "front_right", "rear_left", "rear_right")


def test_a_non_planar_robot_on_the_sph_is_refused_naming_its_joint_and_the_rft_terrain(tmp_path, capsys) -> None:
    out = tmp_path / "rover.h5"
    with pytest.raises(SystemExit) as refused:
        main(["run", "mjcf", str(ROVER4), "--out", str(out), "--no-progress"])
    errors = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert refused.value.code == 2 and len(errors) == 1
    assert "joint 'root' is a free joint" in errors[0] and "--terrain rft" in errors[0]
    assert not out.exists()


def test_a_box_dropped_on_the_sand_rests_at_the_depth_of_the_hand_computation(tmp_path) -> None:
    """A 2 kg box 8 × 6 cm, its bottom 1 mm above the floor (whose height is the sand's surface): RFT
    resists the motion only, so it stops where ζ A d²/2 = m g (d + h), d = 34.5 mm, and then carries
    its weight (tests/test_rft3d.py checks the stepper alone; here the scene's summary and series)."""
    model = tmp_path / "box.xml"
    model.write_text('<mujoco><worldbody><geom name="floor" type="plane" size="1 1 0.1"/><body name="box" '
                     'pos="0.3 -0.2 0.011"><freejoint/><geom type="box" size="0.04 0.03 0.01" mass="2"/></body>'
                     '</worldbody></mujoco>')
    run = run_mjcf(MjcfScene(model=str(model), terrain="rft", element_length=0.01, settle_time=0.0, t_end=0.6),
                   tmp_path / "box.h5")
    stiffness, weight, drop = rft.GENERIC.zeta * 0.08 * 0.06, 2 * 9.81, 0.001
    depth = (weight + math.sqrt(weight**2 + 2 * stiffness * weight * drop)) / stiffness
    summary = run.summary()
    assert summary["terrain"] == "rft" and summary["coupled_bodies"] == ["box"]
    assert summary["box_final_sinkage"] == pytest.approx(depth, rel=0.02)
    assert summary["final_com"] == pytest.approx([0.3, -0.2, 0.01 - depth], rel=0.02)  # the model's own frame
    assert summary["lift_over_weight"] == pytest.approx(1.0, abs=0.01)
    assert summary["box_mean_force"][2] == pytest.approx(weight, rel=0.01)
    assert "distance" not in summary and "box_mean_slip" not in summary  # no actuators, no wheel
    assert read_run(tmp_path / "box.h5").series["robot/box"]["surface"][0] == 0.0


def test_the_wheels_are_the_bodies_turning_about_their_centre_of_mass_on_one_hinge(tmp_path) -> None:
    rover = wheel_radii(robot := rft_robot(ROVER4))
    assert sorted(robot.coupled[k].name for k in rover) == sorted(WHEELS)  # not the chassis (a free joint)
    assert all(radius == pytest.approx(0.06, rel=1e-9) for _, radius in rover.values())
    model = tmp_path / "two.xml"  # a balanced disc and one whose mass sits off its axle (a swinging leg)
    model.write_text('<mujoco><worldbody><body name="a" pos="0 0 0.1"><joint type="hinge" axis="1 0 0"/>'
                     '<geom type="cylinder" size="0.05 0.01" euler="0 90 0"/></body><body name="b" pos="0.3 0 0.1">'
                     '<joint type="hinge" axis="1 0 0"/><geom type="cylinder" size="0.05 0.01" euler="0 90 0" '
                     'pos="0 0 -0.02"/></body></worldbody></mujoco>')
    found = wheel_radii(two := rft_robot(str(model)))
    assert [two.coupled[k].name for k in found] == ["a"] and found[0][1] == pytest.approx(0.05, rel=1e-9)


def test_the_rover_runs_on_the_sand_from_the_command_line(tmp_path, capsys) -> None:
    """The documented one-liner, short and with coarse elements: every wheel's slip, the final
    pose, each body's load in the summary; the 3D figure redrawn by ``terrasph plot``."""
    out = tmp_path / "rover.h5"
    assert main(["run", "mjcf", str(ROVER4), "--terrain", "rft", "--element-length", "0.03", "--settle-time", "0.04",
                 "--t-end", "0.1", *[f"--ctrl={wheel}_motor=3" for wheel in WHEELS], "--out", str(out),
                 "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["terrain"] == "rft" and sorted(summary["coupled_bodies"]) == sorted(["chassis", *WHEELS])
    assert {f"{wheel}_mean_slip" for wheel in WHEELS} <= set(summary) and "chassis_mean_slip" not in summary
    assert summary["root_body"] == "chassis" and len(summary["final_com"]) == 3
    assert summary["distance"] > 0 and all(0 < summary[f"{wheel}_mean_slip"] <= 1 for wheel in WHEELS)
    assert summary["front_left_final_sinkage"] > 0 and summary["plot"] == str(out.with_suffix(".png"))
    series = read_run(out).series
    assert series["robot/front_left"]["quaternion"].shape[1] == 4 and "slip" not in series["robot/chassis"]
    out.with_suffix(".png").unlink()
    assert main(["plot", str(out), "--force"]) == 0 and out.with_suffix(".png").is_file()
