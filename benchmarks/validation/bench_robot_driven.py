"""Stability of the explicit MuJoCo–SPH coupling for a driven leg-wheel against its mass.

The plate of bench_robot_coupling.py measures the limit for a body at rest; this is the driven
case. The leg-wheel rig of the scene ``leg-wheel`` (terrasph.scenes.leg_wheel) at the README's
coarse size: Δx = 5 mm (or ``--spacing=DX``), a C-leg with 3 legs 1.5 cm thick and 5 cm long,
10 cm wide, on a 30 × 5 cm bed of 3 mm glass beads; a 0.1 s pause, then ω = 1.5 rad/s clockwise
until 0.5 s (``--t-end``). What isolates the coupling from MuJoCo's own dynamics:

* no load and a chassis of 1e-6 kg: the wheel's own mass is all that the granular load moves in
  x and z, so the ratio judged is the wheel's, as the coupling's refusal judges it
  (``--load=4.9``: the scene's load instead, the wheel pressed into the bed; the chassis then
  weighs the load less the wheel's weight, so the weight on the bed is the same for every ratio);
* the motor is the scene's velocity servo (gain 20 N·m·s/rad) with a torque limit of 1000 N·m,
  which it never reaches: MuJoCo's implicitfast integrator then integrates the servo's damping
  exactly, a first-order lag of time constant I/k_v with no ringing (the first slice's light
  wheels rang because the servo sat at its 5 N·m limit, where the implicit damping no longer
  matches the clamped force). The granular force and torque still enter explicitly.

``--torque=T``: the servo replaced by a motor of constant torque T N·m after the pause, so the
granular torque enters the wheel's spin explicitly too (I α = T + τ_granular, lagged by a step):
the rotational side of the coupling, which the stiff servo masks.

The mass ratio is the wheel's mass over that of the grains its shape displaces; the wheel's
density is ratio × ρ0, so its inertia scales with it too. The coupling's refusal is switched off
here. A run is stable when it ends without a blow-up, the axle never moves faster than 0.5 m/s
(the rim speed is 0.075 m/s) and never rises more than 5 cm above its start (a leg-wheel walking
on its legs lifts it by about 2.5 cm), and MuJoCo reports no bad acceleration (its own instability:
it then resets its state). Printed per ratio: status, when it failed, max axle speed
and rise, the driven phase's mean v_x and slip (Eq. 4.8, R = 5 cm), the final sinkage, the
largest granular force over the wheel's weight (a light wheel's load per weight grows as 1/ratio),
and the wall time.

    python benchmarks/validation/bench_robot_driven.py [--spacing=DX] [--t-end=T] [--load=N] [--torque=T] [ratios ...]
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time

import mujoco
import numpy as np
from terrasph import InstabilityError
from terrasph.config import glass_beads
from terrasph.mjcf.model import Coupling, PlanarRobot
from terrasph.robots.metrics import slip
from terrasph.scenes.leg_wheel import LegWheel, bed_and_wheel, leg_wheel_mjcf
from terrasph.simulation import Simulation
from terrasph.terrain import sph_coupling as coupling
from terrasph.terrain.sph_coupling import CoupledSimulation, undisturbed_surface

MAX_SPEED = 0.5  #: m/s: faster than this, the wheel has been thrown (rim speed ωR = 0.075 m/s)
MAX_RISE = 0.05  #: m: higher than this above its start, the wheel has left the bed
SETTLE = 0.1  #: s of pause before the spin


def rig(ratio: float, dx: float, t_end: float, load: float) -> LegWheel:
    """The coarse leg-wheel rig with a wheel of `ratio` × ρ0 and an unsaturated servo; chassis and
    wheel weigh `load` N together (the chassis nothing if `load` is 0)."""
    density = ratio * glass_beads().reference_density
    config = LegWheel(wheel="c-leg", legs=3, omega=1.5, load=0.0, leg_length=0.05, thickness=0.015, width=0.1,
                    spacing=dx, bed_width=0.3, bed_depth=0.05, start_x=0.08, settle_time=SETTLE, t_end=t_end,
                    wheel_density=density, motor_gain=20.0, motor_torque=1000.0)
    if load == 0:
        return config
    shape = config.shape()
    wheel_weight = density * len(shape) * dx * dx * config.width * 9.81
    if wheel_weight >= load:
        raise SystemExit(f"ratio {ratio}: the wheel alone weighs {wheel_weight:.3g} N, more than the load {load} N")
    return dataclasses.replace(config, load=load - wheel_weight)


def build(config: LegWheel, torque: float | None) -> CoupledSimulation:
    """terrasph.scenes.leg_wheel.build_leg_wheel, with a constant-torque motor if `torque` is given."""
    scene, numerics, surface, shape = bed_and_wheel(config)
    axle = (config.start_x, surface - shape.lowest_point() + 0.5 * config.spacing)
    xml = leg_wheel_mjcf(config, shape, axle, scene.gravity)
    if torque is not None:
        start = xml.index("<velocity")
        xml = xml[:start] + '<motor name="motor" joint="axle" gear="1"/>' + xml[xml.index("/>", start) + 2:]
    robot = PlanarRobot(xml, {"wheel": Coupling(shape, config.width)}, gravity=scene.gravity)
    robot.add_to_scene(scene)
    return CoupledSimulation(robot, Simulation(scene, glass_beads(), numerics))


def run(ratio: float, dx: float, t_end: float, load: float, torque: float | None) -> dict[str, float | str]:
    config = rig(ratio, dx, t_end, load)
    coupled = build(config, torque)
    data = coupled.robot.data
    wheel = coupled.robot.coupled[0]
    mass = float(coupled.robot.model.body_mass[wheel.body_id])
    weight = mass * coupled.sim.scene.gravity
    z0 = float(data.qpos[1])
    max_speed = max_rise = max_load = 0.0
    driven_vx, driven_omega, driven_torque = [], [], []
    status, failed_at = "stable", math.nan
    start = time.perf_counter()
    try:
        while coupled.time < t_end * (1 - 1e-12):
            if torque is None:
                data.ctrl[0] = float(config.commanded_omega(coupled.time))
            else:
                data.ctrl[0] = torque if coupled.time >= SETTLE else 0.0
            coupled.step()
            vx, vz = float(data.qvel[0]), float(data.qvel[1])
            max_speed = max(max_speed, math.hypot(vx, vz))
            max_rise = max(max_rise, float(data.qpos[1]) - z0)
            max_load = max(max_load, float(np.linalg.norm(coupled.granular_load(wheel)[0])) / weight)
            if coupled.time > SETTLE:
                driven_vx.append(vx)
                driven_omega.append(float(data.qvel[2]))
                driven_torque.append(float(data.actuator_force[0]))
            if data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
                status, failed_at = "mujoco", coupled.time
                break
            if max_speed > MAX_SPEED or max_rise > MAX_RISE:
                status, failed_at = "thrown", coupled.time
                break
    except InstabilityError as error:
        status, failed_at = f"blew up ({str(error)[:40]})", coupled.time
    result: dict[str, float | str] = {"ratio": ratio, "mass": mass, "status": status, "failed_at": failed_at,
                                      "max_speed": max_speed, "max_rise": max_rise, "max_load": max_load,
                                      "steps": coupled.sim.step_count, "wall": time.perf_counter() - start}
    if status == "stable":
        speed, spin = float(np.mean(driven_vx)), float(np.mean(driven_omega))
        lowest = coupled.sim.body_state("wheel")["lowest_z"]
        result.update(mean_vx=speed, mean_omega=spin, mean_torque=float(np.mean(driven_torque)), slip=float(slip(speed, spin, wheel.shape.radius)),
                      sinkage=undisturbed_surface(coupled) - lowest, leaks=coupled.sim.leaked_particles)
    return result


if __name__ == "__main__":
    coupling.MIN_MASS_RATIO = coupling.ACCURATE_MASS_RATIO = 0.0  # measure below the limits the coupling sets
    args = sys.argv[1:]
    dx, t_end, load, torque = 0.005, 0.5, 0.0, None
    for option in [a for a in args if a.startswith("--")]:
        name, value = option[2:].split("=")
        if name == "spacing":
            dx = float(value)
        elif name == "t-end":
            t_end = float(value)
        elif name == "load":
            load = float(value)
        elif name == "torque":
            torque = float(value)
        else:
            raise SystemExit(f"unknown option {option}")
    ratios = [float(a) for a in args if not a.startswith("--")] or [1.0, 0.1, 0.01, 1e-3, 3e-4, 1e-4]
    motor = "servo to 1.5 rad/s" if torque is None else f"constant torque {torque} N·m"
    print(f"spacing {dx} m, t_end {t_end} s (pause {SETTLE} s, then {motor}), load {load} N")
    print("ratio   mass_kg   status    failed_at_s  max_speed  max_rise_mm  max_load/weight  mean_vx  mean_omega"
          "  slip   torque_Nm  sinkage_mm  leaks  steps  wall_s")
    for ratio in ratios:
        r = run(ratio, dx, t_end, load, torque)
        print(f"{r['ratio']:<7g} {r['mass']:.2e}  {r['status']:<9} {r['failed_at']:<11.4g}  {r['max_speed']:.3f}"
              f"      {1000 * r['max_rise']:7.2f}      {r['max_load']:10.3g}     {r.get('mean_vx', math.nan):.4f}"
              f"   {r.get('mean_omega', math.nan):.3f}      {r.get('slip', math.nan):.3f}  {r.get('mean_torque', math.nan):.4f}  "
              f"{1000 * r.get('sinkage', math.nan):7.2f}     {r.get('leaks', -1)}  {r['steps']}  {r['wall']:.0f}",
              flush=True)
