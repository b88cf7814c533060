"""Stability of the explicit MuJoCo–SPH coupling against the body's mass.

A plate 6 cm × 1.5 cm × 5 cm wide is set down on a 20 × 4 cm bed of 3 mm glass beads (Δx = 5 mm
or ``--spacing=DX``),
its lowest point Δx/2 above the surface ("rest") or 3 cm higher ("drop": it hits the bed at
0.77 m/s), and left for 0.3 s. The mass ratio is the body's mass over the mass of the grains its volume
displaces (ρ0 × area × width). A run counts as stable when it finishes without a blow-up and the
plate's speed at the end is below 0.05 m/s (it has come to rest on or in the bed); the printed
table gives, per ratio, the end speed, the plate's height change, the lift/weight over the last
0.1 s, and the wall time. The coupling's refusal of light bodies (MIN_MASS_RATIO) is switched off
here, since this is where the limit comes from.

    python benchmarks/validation/bench_robot_coupling.py [--spacing=DX] [--rest-only] [ratios ...]
        (both cases for each ratio, or the hard one, "rest", only)
"""

from __future__ import annotations

import math
import sys
import time

from terrasph import InstabilityError
from terrasph.bodies import plate
from terrasph.config import Numerics, glass_beads
from terrasph.geometry import wall_layers_needed
from terrasph.mjcf.model import PlanarRobot
from terrasph.scene import Scene
from terrasph.simulation import Simulation
from terrasph.terrain import sph_coupling as coupling
from terrasph.terrain.sph_coupling import CoupledSimulation

BEADS = glass_beads()
THICKNESS = 0.015  #: plate thickness (m): 3 particle rows at Δx = 5 mm, 6 at 2.5 mm


def run(ratio: float, drop: float, dx: float = 0.005) -> dict[str, float | str]:
    shape = plate(0.06, THICKNESS, 0.05, dx)
    displaced = BEADS.reference_density * len(shape) * dx * dx * shape.width
    mass = ratio * displaced
    scene = Scene(spacing=dx)
    surface, _ = scene.add_bed_in_container(0.2, 0.04, 0.05, layers=wall_layers_needed(1.3))
    z0 = surface + 0.5 * THICKNESS + 0.5 * dx + drop
    xml = (f'<mujoco><option gravity="0 0 -9.81"/><worldbody><body name="foot" pos="0.1 0 {z0!r}">'
           '<joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>'
           '<joint name="pitch" type="hinge" axis="0 1 0"/>'
           f'<geom type="box" size="0.03 0.025 0.0075" mass="{mass!r}"/></body></worldbody></mujoco>')
    robot = PlanarRobot(xml, {"foot": shape})
    robot.add_to_scene(scene)
    coupled = CoupledSimulation(robot, Simulation(scene, BEADS, Numerics(spacing=dx)))
    start = time.perf_counter()
    try:
        coupled.advance(0.2)
        coupled.sim.reset_body_means()
        coupled.advance(0.3)
    except InstabilityError as error:
        return {"ratio": ratio, "mass": mass, "status": f"blew up: {str(error)[:60]}",
                "wall": time.perf_counter() - start}
    state = coupled.sim.body_state("foot")
    speed = math.hypot(*state["velocity"])
    return {"ratio": ratio, "mass": mass, "status": "stable" if speed < 0.05 else "moving",
            "speed": speed, "dz": state["reference"][1] - z0, "lift/weight": state["force"][1] / (mass * 9.81),
            "wall": time.perf_counter() - start}


if __name__ == "__main__":
    coupling.MIN_MASS_RATIO = 0.0  # measure below the limit the coupling refuses (the limit found here)
    args = sys.argv[1:]
    dx = float(args.pop(0).split("=")[1]) if args and args[0].startswith("--spacing=") else 0.005
    rest_only = "--rest-only" in args
    args = [a for a in args if a != "--rest-only"]
    ratios = [float(r) for r in args] or [2.0, 1.0, 0.5, 0.25, 0.1, 0.05, 0.02]
    print(f"spacing {dx} m")
    print("case  ratio  mass_kg  status   end_speed_m/s  dz_mm   lift/weight  wall_s")
    for ratio in ratios:
        for case, drop in (("rest", 0.0),) if rest_only else (("rest", 0.0), ("drop", 0.03)):
            r = run(ratio, drop, dx)
            print(f"{case}  {r['ratio']:<6} {r['mass']:.4f}  {r['status']:<8} {r.get('speed', float('nan')):.2e}"
                  f"       {1000 * r.get('dz', float('nan')):7.2f}  {r.get('lift/weight', float('nan')):.4f}"
                  f"       {r['wall']:.1f}", flush=True)
