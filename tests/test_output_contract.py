"""The output contract of a run (docs/hdf5_schema.md), the same for every registered scene, plain
SPH and MuJoCo-coupled alike, on the SPH terrain and on resistive force theory's (docs/rft.md),
since all go through one run loop (terrasph.run_loop.RunLoop).

For each scene of :data:`terrasph.scenes.SCENES`, and the leg-wheel, the leg rotation and a
non-planar MJCF robot (the 3D RFT terrain) on the RFT terrain (frames of the bodies, no grains), at a
tiny size:

* a completed run's file says ``completed`` with the time, steps, leak counter, particle counts
  and wall time reached; ``/results`` holds the scene's summary; the XDMF sidecar, the PNG and a
  checkpoint are beside it;
* ``terrasph resume RUN.h5 --until T2`` continues the completed run, and an interrupted one (a
  stop requested at a step boundary, as Ctrl-C does), into files bitwise equal — every frame and
  every series but the wall time — to a run straight to T2 (the reference: the uninterrupted run);
* a run that blows up says ``unstable`` with its message, readable, with its sidecar (on the RFT
  terrain: a robot state MuJoCo cannot integrate; the RFT step is fixed, there is no SPH step to
  push past its bound, and a leg's prescribed sweep cannot blow up).

The command line's safe output: a second run into a file another run is writing refuses in one
line (exit 2) and leaves the first run's file whole; bad time options end in one line or work.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os

import h5py
import numpy as np
import pytest
from terrasph import InstabilityError, run_loop
from terrasph.cli import main
from terrasph.io import read_run
from terrasph.robots import ROVER4
from terrasph.run_loop import checkpoint_path, claimed_output
from terrasph.scenes import SCENES, ColumnCollapse, LegRotation, PlateIntrusion
from terrasph.scenes.leg_wheel import LegWheel
from terrasph.scenes.mjcf_scene import MjcfScene
from terrasph.scenes.plate_drag import PlateDrag
from terrasph.scenes.plate_intrusion_3d import PlateIntrusion3D
from terrasph.scenes.rover import Rover

#: gymnasium's MuJoCo models (the test extra installs gymnasium)
GYMNASIUM_ASSETS = os.path.join(os.path.dirname(__import__("gymnasium").__file__), "envs", "mujoco", "assets")
ANT = os.path.join(GYMNASIUM_ASSETS, "ant.xml")

#: Tiny versions of every registered scene (a few seconds each on one thread), the end time T1 of
#: the first run, and the later end time T2 that the continued runs and the reference reach.
CASES = {
    "column-collapse": (ColumnCollapse(t_end=0.03), 0.03, 0.05),
    "leg-rotation": (LegRotation(bed_width=0.14, bed_depth=0.07, omega=6.0, settle_time=0.005, end_angle=-0.55,
                                 frame_interval=0.01), 0.02, 0.035),
    "plate-intrusion": (PlateIntrusion(bed_width=0.06, bed_depth=0.04, plate_length=0.02, max_depth=0.006,
                                       speed=0.1, settle_time=0.0, frame_interval=0.01), 0.02, 0.035),
    "plate-drag": (PlateDrag(bed_width=0.14, bed_depth=0.08, spacing=0.005, plate_length=0.04, start_depth=0.03,
                             travel=0.004, speed=0.1, settle_time=0.0, samples=4), 0.02, 0.035),
    "leg-wheel": (LegWheel(wheel="c-leg", spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.2,
                           bed_depth=0.04, start_x=0.08, settle_time=0.01, t_end=0.03, load=2.0,
                           series_interval=0.005, frame_interval=0.01), 0.03, 0.05),
    "rover": (Rover(spacing=0.005, thickness=0.015, leg_length=0.04, bed_width=0.3, bed_depth=0.04, start_x=0.12,
                    settle_time=0.01, t_end=0.03, omega=2.0, frame_interval=0.01, series_interval=0.005),
              0.03, 0.05),
    # gymnasium's hopper, unmodified, its joints held (the test extra installs gymnasium)
    "mjcf": (MjcfScene(model=os.path.join(GYMNASIUM_ASSETS, "hopper.xml"),
                       bed_width=0.8, bed_depth=0.06, spacing=0.02, settle_time=0.01, t_end=0.03,
                       ctrl=tuple(f"{joint}=hold:2000,100" for joint in ("thigh_joint", "leg_joint", "foot_joint")),
                       series_interval=0.005, frame_interval=0.01), 0.03, 0.05),
    # the leg-wheel on the RFT terrain (docs/rft.md): its frames hold the robot's bodies, no grains
    "leg-wheel on rft": (LegWheel(terrain="rft", settle_time=0.02, t_end=0.1, series_interval=0.01,
                                  frame_interval=0.02), 0.1, 0.2),
    # the leg's prescribed sweep on the RFT terrain: nothing in it can become unstable
    "leg-rotation on rft": (LegRotation(terrain="rft", omega=6.0, settle_time=0.005, end_angle=-0.55,
                                        frame_interval=0.01), 0.02, 0.035),
    # a non-planar robot (the four-wheeled rover on a free joint) on the 3D RFT terrain, coarse
    # elements: it falls 5 mm onto the sand by 0.03 s, and its wheels spin from 0.04 s
    "mjcf on rft": (MjcfScene(model=str(ROVER4), terrain="rft", element_length=0.03, settle_time=0.04, t_end=0.06,
                              ctrl=tuple(f"{wheel}_motor=3" for wheel in ("front_left", "front_right", "rear_left",
                                                                         "rear_right")),
                              series_interval=0.005, frame_interval=0.01), 0.06, 0.09),
    # a box plate pushed into a 3D bed (granular SPH in 3D, docs/sph3d.md): 1 152 grains
    "plate-intrusion-3d": (PlateIntrusion3D(spacing=0.005, bed_length=0.06, bed_breadth=0.06, bed_depth=0.04,
                                            plate_length=0.02, plate_breadth=0.02, max_depth=0.006, speed=0.1,
                                            settle_time=0.0, frame_interval=0.01), 0.02, 0.035),
    # gymnasium's ant, unmodified, on a 3D SPH bed at its coarse default spacing (4 232 grains): every body
    # coupled, one hip driven from 0.01 s
    "mjcf on sph3d": (MjcfScene(model=ANT, terrain="sph3d", couple_below=1.0, settle_time=0.01, t_end=0.03,
                                ctrl=("hip_1=0.5",), series_interval=0.01, frame_interval=0.01), 0.03, 0.05),
}
#: the cases whose runs have no SPH step to make unstable (test_unstable_run_is_recorded)
RFT_CASES = ("leg-wheel on rft", "leg-rotation on rft", "mjcf on rft")


def scene_of(case: str) -> str:
    """The registered scene of a case: its name, or what precedes " on <terrain>"."""
    return case.split(" on ")[0]


def test_every_registered_scene_has_a_case() -> None:
    assert {scene_of(case) for case in CASES} == set(SCENES)


def run(case: str, out, until: float | None = None, **changes):
    """The tiny case, run into `out` (to `until` if given)."""
    config, t1, _ = CASES[case]
    if changes:
        config = dataclasses.replace(config, **changes)
    return SCENES[scene_of(case)].run(config, output=out, progress=False, until=t1 if until is None else until)


def assert_same_run(path, reference) -> None:
    """Every frame, static array and series row (but wall time) of two run files bitwise equal."""
    a, b = read_run(path), read_run(reference)
    assert np.array_equal(a.times, b.times) and np.array_equal(a.steps, b.steps)
    assert set(a.fields) == set(b.fields) and set(a.series) == set(b.series)
    for name in b.fields:
        assert np.array_equal(a.fields[name], b.fields[name]), f"frame field {name} differs"
    for group, columns in b.series.items():
        for key, values in columns.items():
            if key != "wall_time":
                assert np.array_equal(a.series[group][key], values, equal_nan=True), (group, key)
    ours, theirs = a.group_attrs["/results"], b.group_attrs["/results"]
    assert set(ours) == set(theirs)
    for key in theirs:
        if key != "wall_time":
            assert np.array_equal(ours[key], theirs[key]), key


class StopAfter(run_loop.StopRequest):
    """A stop request that comes after `polls` checks at step boundaries: the run loop's reaction to
    Ctrl-C, at a known point."""

    polls = 1  # after the first stretch of steps (the decided step reaches the tiny cases' ends in few)

    def __init__(self) -> None:
        self.checks = 0

    @property
    def requested(self) -> bool:
        self.checks += 1
        return self.checks > self.polls

    @requested.setter
    def requested(self, value: bool) -> None:
        """A real signal's request is not needed: the stop comes anyway."""


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """Per scene: the run straight to T2 (computed once, on first use)."""
    out = tmp_path_factory.mktemp("references")
    made = {}

    def reference(scene: str):
        if scene not in made:
            made[scene] = out / f"{scene}.h5"
            run(scene, made[scene], until=CASES[scene][2])
        return made[scene]

    return reference


@pytest.mark.parametrize("scene", list(CASES))
def test_completed_run_keeps_its_contract_and_continues_bitwise(scene, tmp_path, references, capsys) -> None:
    out = tmp_path / "run.h5"
    run(scene, out)
    _, t1, t2 = CASES[scene]
    data = read_run(out)
    status = data.group_attrs["/run"]
    assert status["status"] == "completed"
    assert status["time"] >= t1 * (1 - 1e-12) and status["time"] == pytest.approx(data.times[-1])
    assert status["steps"] == data.steps[-1] > 0 and status["wall_time"] > 0
    grains = data.fields["position"].shape[1] if "position" in data.fields else 0
    assert status["leaked_particles"] >= 0 and status["granular_particles"] == grains
    if scene in RFT_CASES:  # no grains: the frames are the robot's, moving
        assert grains == 0 and data.n_frames >= 2 and not np.array_equal(*data.fields["body_position"][[0, -1]])
    assert status["checkpoint"] == checkpoint_path(out).name and checkpoint_path(out).is_file()
    results = data.group_attrs["/results"]
    assert results and all(not isinstance(v, float) or math.isfinite(v) for v in results.values())
    assert out.with_suffix(".xdmf").is_file() and out.with_suffix(".png").is_file()
    assert main(["info", str(out), "--json"]) == 0
    json.loads(capsys.readouterr().out, parse_constant=lambda name: pytest.fail(f"{name} in info --json"))

    assert main(["resume", str(out), "--until", str(t2), "--no-progress", "--threads", "1"]) == 0
    printed = json.loads(capsys.readouterr().out, parse_constant=lambda name: pytest.fail(f"{name} in the summary"))
    assert printed["output"] == str(out)
    assert read_run(out).group_attrs["/run"]["status"] == "completed"
    assert_same_run(out, references(scene))


@pytest.mark.slow  # ~15 s for the five scenes; the fast suite continues a completed run of each
@pytest.mark.parametrize("scene", list(CASES))
def test_interrupted_run_continues_bitwise(scene, tmp_path, references, monkeypatch, capsys) -> None:
    out = tmp_path / "run.h5"
    monkeypatch.setattr(run_loop, "StopRequest", StopAfter)
    with pytest.raises(KeyboardInterrupt):
        run(scene, out, until=CASES[scene][2])
    monkeypatch.undo()
    data = read_run(out)
    status = data.group_attrs["/run"]
    assert status["status"] == "interrupted" and 0 < status["time"] < CASES[scene][2]
    assert status["time"] == data.times[-1] and status["steps"] == data.steps[-1]  # the last frame: the stop
    assert checkpoint_path(out).is_file() and out.with_suffix(".xdmf").is_file()
    assert main(["resume", str(out), "--until", str(CASES[scene][2]), "--no-progress", "--threads", "1"]) == 0
    capsys.readouterr()
    assert_same_run(out, references(scene))


@pytest.mark.parametrize("scene", [case for case in CASES if case not in RFT_CASES])
def test_unstable_run_is_recorded(scene, tmp_path) -> None:
    """A fixed step far past the stable bound blows up at the first step: the file says so. (Not on
    the RFT terrain, whose step is fixed and has no stability bound: there a robot's run is unstable
    when MuJoCo cannot integrate the robot, test_a_coupled_run_whose_robot_diverges_is_unstable, and
    a leg's prescribed sweep, a closed-form pose and a load that is a finite function of it, has
    nothing that can blow up.)"""
    out = tmp_path / "run.h5"
    with pytest.raises(InstabilityError):
        run(scene, out, numerics={**CASES[scene][0].numerics, "fixed_dt": 0.01})
    data = read_run(out)
    status = data.group_attrs["/run"]
    assert status["status"] == "unstable" and "fixed_dt" in status["message"]
    assert status["steps"] == 0 and data.n_frames == 1 and "checkpoint" not in status
    assert out.with_suffix(".xdmf").is_file()


@pytest.mark.parametrize("force", [False, True], ids=["plain", "force"])
def test_a_second_writer_refuses_and_the_first_file_stays_whole(tmp_path, capsys, force) -> None:
    """Two runs into one file started together: the one that comes second refuses in one line,
    exit 2, before any work, naming the first run (its pid), even with --force; the first writes
    its run undisturbed."""
    out = tmp_path / "run.h5"
    with claimed_output(out, force=False):  # the first run holds the file
        with pytest.raises(SystemExit) as refused:
            main(["run", "column-collapse", "--t-end", "0.01", "--no-progress", "--out", str(out),
                  *(["--force"] if force else [])])
        assert refused.value.code == 2
        err = capsys.readouterr().err
        assert f"another run is writing it (pid {os.getpid()} on " in err and len(err.strip().splitlines()) == 1
        run("column-collapse", out)
        with pytest.raises(SystemExit) as refused:  # resume leaves a file being written alone too
            main(["resume", str(out), "--no-progress"])
        assert refused.value.code == 2 and f"pid {os.getpid()}" in capsys.readouterr().err
    assert read_run(out).group_attrs["/run"]["status"] == "completed"
    assert not run_loop.lock_path(out).exists()


def test_two_concurrent_forced_runs_one_writes_the_other_refuses(tmp_path) -> None:
    """`terrasph run ... --force` into one existing file, a second such run started while the first
    writes it: the second refuses in one line naming the first (its pid; no raw errno) and leaves its
    file alone; the first, stopped by Ctrl-C afterwards, leaves a readable file."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "run.h5"
    out.write_bytes(b"an earlier run's file")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p), "OMP_NUM_THREADS": "1"}
    command = [sys.executable, "-m", "terrasph.cli", "run", "leg-rotation", "--no-progress", "--threads", "1",
               "--out", str(out), "--force"]  # minutes of run: still writing when the second starts
    first = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not run_loop.lock_path(out).exists() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        second = subprocess.run(command, env=env, capture_output=True, text=True, timeout=300)
        assert first.poll() is None, first.communicate()[1]
    finally:
        first.send_signal(signal.SIGINT)
        first_err = first.communicate(timeout=300)[1]
    refusal = second.stderr.strip()
    assert second.returncode == 2, refusal
    assert f"another run is writing it (pid {first.pid} on " in refusal and "Errno" not in refusal, refusal
    assert len(refusal.splitlines()) == 1
    assert first.returncode == 130, first_err
    assert read_run(out).group_attrs["/run"]["status"] == "interrupted"


def test_an_empty_file_left_by_a_killed_run_does_not_block_the_next(tmp_path) -> None:
    """A run killed (SIGKILL) before it wrote anything leaves its empty claim; no live run holds it,
    so the next run into that file starts without --force."""
    out = tmp_path / "run.h5"
    out.write_bytes(b"")
    with claimed_output(out, force=False):
        run("column-collapse", out)
    assert read_run(out).group_attrs["/run"]["status"] == "completed"


def test_a_claim_is_released_when_the_run_cannot_start(tmp_path) -> None:
    out = tmp_path / "run.h5"
    with pytest.raises(ValueError), claimed_output(out, force=False):
        raise ValueError("the scene cannot be built")
    assert not out.exists()


def test_a_stale_checkpoint_is_refused_without_force(tmp_path) -> None:
    out = tmp_path / "run.h5"
    checkpoint_path(out).write_bytes(b"")
    with pytest.raises(FileExistsError, match="checkpoint"), claimed_output(out, force=False):
        pass
    with claimed_output(out, force=True):
        assert not checkpoint_path(out).exists()


def test_a_run_ended_in_the_settling_pause_has_a_valid_summary(tmp_path, capsys) -> None:
    """A leg-wheel run stopped and resumed within its pause (no driven phase yet; a run configured to end
    in its pause is refused, tests/test_settle_time.py): the undefined means print as null, valid
    JSON; a leg rotation resumed within its pause gives a summary without a sweep."""
    out = tmp_path / "wheel.h5"
    run("leg-wheel", out, until=0.004, settle_time=0.02)
    assert main(["resume", str(out), "--until", "0.008", "--no-progress", "--threads", "1"]) == 0
    summary = json.loads(capsys.readouterr().out, parse_constant=lambda name: pytest.fail(f"{name} printed"))
    assert summary["mean_slip"] is None and summary["final_sinkage"] is not None
    leg = tmp_path / "leg.h5"
    run("leg-rotation", leg, until=0.002, settle_time=0.01)
    assert main(["resume", str(leg), "--until", "0.004", "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out, parse_constant=lambda name: pytest.fail(f"{name} printed"))
    assert summary["peak_lift"] is None and summary["status"] == "completed"
    assert leg.with_suffix(".png").is_file()
    with h5py.File(leg, "r") as file:
        assert "peak_lift" not in file["results"].attrs and file["results"].attrs["time"] >= 0.004 * (1 - 1e-12)


def test_a_run_that_fails_says_so_in_its_file(tmp_path) -> None:
    """An error that is not a blow-up (here raised by the caller's frame callback after the second
    frame) is recorded as ``failed`` with its message before it propagates; the file stays readable."""
    from terrasph.scenes import build_column_collapse
    from terrasph.simulation import Simulation

    scene, material, numerics = build_column_collapse(ColumnCollapse())
    sim = Simulation(scene, material, numerics)
    frames = []

    def fail_on_second_frame(_: Simulation) -> None:
        frames.append(sim.time)
        if len(frames) == 2:
            raise RuntimeError("the caller's callback broke")

    out = tmp_path / "run.h5"
    with pytest.raises(RuntimeError, match="callback broke"):
        sim.run(0.01, output=out, frame_interval=0.002, progress=False, on_frame=fail_on_second_frame)
    status = read_run(out).group_attrs["/run"]
    assert status["status"] == "failed" and "callback broke" in status["message"]
    assert status["time"] == pytest.approx(frames[-1]) and "checkpoint" not in status


def test_a_run_stopped_inside_a_step_names_no_checkpoint_it_has_not_got(tmp_path, monkeypatch) -> None:
    """A second Ctrl-C stops the run at once, maybe inside a step (here: raised in the second call
    into the stepper): no state of that instant is saved; the file is readable, says
    ``interrupted``, and names a checkpoint only if the run has one from before (here none)."""
    from terrasph.simulation import Simulation

    advance, calls = Simulation.advance, [0]

    def advance_then_stop(self, t_end, max_steps=2**62):
        calls[0] += 1
        if calls[0] == 2:
            raise KeyboardInterrupt
        return advance(self, t_end, max_steps)

    monkeypatch.setattr(Simulation, "advance", advance_then_stop)
    out = tmp_path / "run.h5"
    with pytest.raises(KeyboardInterrupt):
        run("column-collapse", out)
    data = read_run(out)
    status = data.group_attrs["/run"]
    assert status["status"] == "interrupted" and "checkpoint" not in status
    assert not checkpoint_path(out).exists() and data.n_frames == 1


@pytest.mark.parametrize("case", ["leg-wheel", "leg-wheel on rft"])
def test_a_coupled_run_whose_robot_diverges_is_unstable(case, tmp_path, monkeypatch) -> None:
    """MuJoCo does not fail on a state it cannot integrate: it resets the robot to its initial pose
    and counts a warning. The coupled step, on the SPH terrain and on RFT's, turns that into an
    InstabilityError, which the run loop records as ``unstable`` with the frames so far (here the
    robot's speed is made non-finite after 0.01 s). MuJoCo's warning reaches the user as a Python
    warning, not as a MUJOCO_LOG.TXT in the working directory."""
    from terrasph.mjcf.model import MujocoWarning
    from terrasph.robots.run import run_coupled
    from terrasph.scenes.leg_wheel import build_leg_wheel

    monkeypatch.chdir(tmp_path)  # where MuJoCo's own handler would write its log
    sand = build_leg_wheel(CASES[case][0])

    def spoil(run) -> None:
        if run.time >= 0.01:
            run.robot.data.qvel[0] = math.nan

    out = tmp_path / "run.h5"
    with pytest.raises(InstabilityError, match="MuJoCo could not integrate"), \
            pytest.warns(MujocoWarning, match="MuJoCo: Nan, Inf or huge value"):
        run_coupled(sand, 0.03, output=out, control=spoil)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    data = read_run(out)
    status = data.group_attrs["/run"]
    assert status["status"] == "unstable" and status["particle"] == -1
    assert status["time"] == pytest.approx(0.01, abs=0.002) and "checkpoint" not in status
    assert data.n_frames >= 1 and out.with_suffix(".xdmf").is_file()


def test_ctrl_c_on_a_sweep_says_how_to_go_on(tmp_path, monkeypatch, capsys) -> None:
    """Ctrl-C on a sweep (the run itself replaced) ends in one line, exit 130, that names the sweep
    and the command that runs its remaining cases — not the single run's message."""
    from terrasph.sweeps import runner

    def interrupted_sweep(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "run_sweep", interrupted_sweep)
    from sweep_helpers import tiny_spec

    spec = tmp_path / "spec.yaml"
    spec.write_text(json.dumps(tiny_spec()))  # JSON is YAML
    with pytest.raises(SystemExit) as stopped:
        main(["sweep", str(spec), "--out", str(tmp_path / "sweep"), "--no-progress"])
    err = capsys.readouterr().err
    assert stopped.value.code == 130 and len(err.strip().splitlines()) == 1
    assert "sweep interrupted" in err and f"terrasph sweep {spec} --out {tmp_path / 'sweep'}" in err


#: a leg-wheel driven long enough that its motor works across the checkpoint, with the scene's own
#: sampling (a sample every 0.01 s, a frame every 0.05 s)
DRIVEN_WHEEL = ["run", "leg-wheel", "--spacing", "0.005", "--thickness", "0.015", "--leg-length", "0.04",
                "--bed-width", "0.2", "--bed-depth", "0.04", "--start-x", "0.08", "--settle-time", "0.02",
                "--load", "2", "--no-progress", "--threads", "1"]


def test_a_resumed_robot_run_has_the_summary_of_the_run_that_never_stopped(tmp_path, capsys) -> None:
    """`terrasph run ... --t-end 0.25` then `terrasph resume --until 0.3` against a run straight to
    0.3 s (the motor does positive work at the checkpoint, 0.24 s): the summaries bitwise equal, the
    motor work and the cost of transport included (they sum the motor's power, force × speed, over
    every step: the speed at the checkpoint must be the one the run had, not one MuJoCo recomputes).
    Then the end time and the time shown: a plain resume
    continues to the last --until, so the finished run is refused, and so is an --until before the
    time reached (the time `terrasph info` shows), without running anything again."""
    def summary(argv: list[str]) -> dict:
        assert main(argv) == 0
        printed = json.loads(capsys.readouterr().out)
        return {key: value for key, value in printed.items() if key not in ("output", "plot")}

    resumed, straight = tmp_path / "resumed.h5", tmp_path / "straight.h5"
    summary([*DRIVEN_WHEEL, "--t-end", "0.25", "--out", str(resumed)])
    continued = summary(["resume", str(resumed), "--until", "0.3", "--no-progress", "--threads", "1"])
    reference = summary([*DRIVEN_WHEEL, "--t-end", "0.3", "--out", str(straight)])
    assert continued["motor_work"] > 0
    assert continued == reference
    assert_same_run(resumed, straight)

    reached = read_run(resumed).group_attrs["/run"]["time"]
    assert main(["info", str(resumed)]) == 0
    assert f"reached t = {reached:.6g} s" in capsys.readouterr().out
    steps = read_run(resumed).group_attrs["/run"]["steps"]
    for argv, words in ((["resume", str(resumed)], "already ran to its end"),
                        (["resume", str(resumed), "--until", "0.3"], f"allowed > the time the run reached, "
                                                                      f"t = {reached:.6g} s")):
        with pytest.raises(SystemExit) as refused:
            main([*argv, "--no-progress"])
        err = capsys.readouterr().err
        assert refused.value.code == 2 and words in err and len(err.strip().splitlines()) == 1, err
    assert read_run(resumed).group_attrs["/run"]["steps"] == steps  # nothing ran again


def test_a_plate_drag_stopped_before_its_measured_part_is_undefined_without_warnings(tmp_path) -> None:
    """The tiny plate drag stopped at T1, before the measured part of its travel: its means are NaN
    (null in JSON), said so by the summary, with no numpy warning ("mean of empty slice")."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        summary = run("plate-drag", tmp_path / "drag.h5").summary()
    assert all(math.isnan(summary[key]) for key in ("alpha_x", "alpha_z", "alpha_x_spread", "alpha_z_spread"))
