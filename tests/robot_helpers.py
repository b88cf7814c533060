"""Shared builders of the robot tests: MJCF text of small planar robots and coarse scenes."""

from __future__ import annotations

from collections.abc import Callable

from terrasph.config import Material, Numerics, glass_beads
from terrasph.geometry import wall_layers_needed
from terrasph.mjcf.model import Coupling, PlanarRobot
from terrasph.scene import Scene
from terrasph.simulation import Simulation
from terrasph.terrain.interface import Terrain
from terrasph.terrain.interface import couple as terrain_for
from terrasph.terrain.sph_coupling import CoupledSimulation

DX = 0.005
#: glass beads of the robot scenes (3 mm, ρ_s = 2600 kg/m³, packing 0.63, μ1 = tan 23°, μ2 = tan 33°)
BEADS = glass_beads()

PLANAR_JOINTS = ('<joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>'
                 '<joint name="pitch" type="hinge" axis="0 1 0"/>')


def mjcf(body: str, *, joints: str = PLANAR_JOINTS, actuators: str = "", floor: bool = False,
         options: str = "") -> str:
    """A model with one body ``body`` at the given pose and joints (the body's XML goes inside)."""
    ground = '<geom name="floor" type="plane" size="1 1 0.1" friction="1 0.005 0.0001"/>' if floor else ""
    return (f'<mujoco><option gravity="0 0 -9.81" {options}/><worldbody>{ground}{body.format(joints=joints)}'
            f'</worldbody><actuator>{actuators}</actuator></mujoco>')


def far_grains_scene(x_body: float = 0.4) -> Scene:
    """A small bed on a floor at x ∈ [0, 0.05], far (≥ 0.2 m) from any body placed near `x_body`,
    and a domain box that holds both: an empty domain for the bodies."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, 0.05, 0.02)
    scene.add_wall("floor", [(0.0, 0.04), (0.0, 0.0), (0.05, 0.0), (0.05, 0.04)], layers=wall_layers_needed(1.3))
    scene.domain_lower, scene.domain_upper = (-0.1, -0.2), (x_body + 0.3, 0.5)
    return scene


def sph_terrain(xml: str, couplings: dict[str, object], scene: Scene, numerics: Numerics | None = None,
                material: Material = BEADS) -> Terrain:
    """Robot + scene + simulation, coupled: the terrain of :func:`terrasph.terrain.interface.couple`."""
    robot = PlanarRobot(xml, {k: v if v is None or isinstance(v, Coupling) else Coupling(v)
                              for k, v in couplings.items()})
    robot.add_to_scene(scene)
    return terrain_for(robot, "sph", simulation=Simulation(scene, material, numerics or Numerics(spacing=DX)))


def couple(xml: str, couplings: dict[str, object], scene: Scene, numerics: Numerics | None = None,
           material: Material = BEADS) -> CoupledSimulation:
    """Robot + scene + simulation, coupled: the coupling of :func:`sph_terrain`."""
    return sph_terrain(xml, couplings, scene, numerics, material).coupling


def run_interrupted(monkeypatch, run: Callable[[], object], stop_at: int) -> None:
    """Runs `run` with SIGINT sent to this process during coupled step `stop_at` (caught by the run
    loop and honoured after that step), expecting the KeyboardInterrupt it ends with."""
    import os
    import signal

    import pytest

    step, taken = CoupledSimulation.step, [0]

    def interrupted_step(self: CoupledSimulation) -> float:
        taken[0] += 1
        if taken[0] == stop_at:
            os.kill(os.getpid(), signal.SIGINT)
        return step(self)

    monkeypatch.setattr(CoupledSimulation, "step", interrupted_step)
    with pytest.raises(KeyboardInterrupt):
        run()
    monkeypatch.setattr(CoupledSimulation, "step", step)


def assert_same_series(a, b) -> None:
    """Every series of two run files (terrasph.io.RunData) bitwise equal, but the wall time."""
    import numpy as np

    assert set(a.series) == set(b.series)
    for group in a.series:
        for key in a.series[group]:
            if key != "wall_time":
                assert np.array_equal(a.series[group][key], b.series[group][key], equal_nan=True), (group, key)
