"""Digest of the full simulation state after a fixed number of steps, one line per scene variant.

    python benchmarks/performance/state_digest.py [--threads 1] > before.txt   # then rebuild and compare

A speed change to the core that should not change any result (a reordered loop, a cache, a new
pass structure) must leave every line the same; run it before and after and `diff` the output.
The variants switch each optional term on and off (δ-SPH, XSPH, the rate or hypoelastic μ(I)
model, kernel gradient correction, Shepard filter, the kicked density and the gather in id order
beside the defaults' density advanced first and each pair once in cell order, wall friction, tracked
wall loads) and include a rotating leg, with and without the active domain's radius (and with it,
the gather in id order), so each code path of the two pair passes and of the freezing is hashed; and
a 3D plate pushed into a 3D bed (docs/sph3d.md), with each pair once in cell order and with the
gather, the 3D pair passes, walls and a prescribed 3D body. Same output for any thread count (the core's determinism).
tests/data/state_digests.txt holds the expected output (tests/test_state_digest.py compares it).
"""

from __future__ import annotations

import argparse
import hashlib

import numpy as np
from bench_sph import SPACING, bed
from terrasph import _core
from terrasph.config import Material, Numerics
from terrasph.scenes.leg_rotation import LegRotation, build_leg_rotation
from terrasph.scenes.plate_intrusion_3d import PlateIntrusion3D, build_plate_intrusion_3d
from terrasph.simulation import Simulation
from terrasph.sph3d_run import Simulation3D

STATE = ("position", "velocity", "density", "stress", "acceleration", "density_rate", "pressure")
WALL_LOAD = ("force", "torque", "impulse", "angular_impulse", "impulse_time")
BODY = ("reference", "angle", "velocity", "spin", "force", "torque", "mean_force", "mean_torque", "averaged_over")
BODY_3D = ("reference", "orientation", "velocity", "angular_velocity", "force", "torque", "mean_force", "mean_torque",
           "averaged_over")


def digest(sim: Simulation | Simulation3D) -> str:
    """First 16 hex digits of the SHA-256 of the state arrays and the body states (2D or 3D)."""
    h = hashlib.sha256()
    for name in STATE:
        h.update(np.ascontiguousarray(getattr(sim.core, name)).tobytes())
    for body in range(sim.core.body_count):
        state = sim.core.body_state(body)
        if "orientation" in state:  # a 3D body: its vectors as arrays, hashed to the bit as lists of floats
            h.update(repr({key: np.asarray(state[key]).tolist() for key in BODY_3D}).encode())
        else:
            h.update(repr({key: state[key] for key in BODY}).encode())
    for load in sim.core.state()["wall_loads"]["loads"]:  # none unless tracked
        for key in WALL_LOAD:
            h.update(np.asarray(load[key], dtype=np.float64).tobytes())
    return h.hexdigest()[:16]


def bed_variants() -> dict[str, tuple[Material, Numerics]]:
    """Material and numerics of each bed variant, spanning the optional terms."""
    return {
        "default": (Material(), Numerics(spacing=SPACING)),
        "rate": (Material(model="mu_i_rate"), Numerics(spacing=SPACING)),
        "no-delta": (Material(), Numerics(spacing=SPACING, delta_sph=0.0)),
        "no-xsph": (Material(), Numerics(spacing=SPACING, xsph=0.0)),
        "plain": (Material(model="mu_i_rate"), Numerics(spacing=SPACING, xsph=0.0, delta_sph=0.0)),
        "correction+shepard": (Material(), Numerics(spacing=SPACING, kernel_gradient_correction=True,
                                                    shepard_interval=7)),
        # the defaults advance the density first and take each pair once in cell order: these hash
        # the kicked density and the gather, in id order, each alone and together
        "kicked": (Material(), Numerics(spacing=SPACING, symplectic_density=False)),
        "gather": (Material(), Numerics(spacing=SPACING, cell_order=False, symmetric_pairs=False)),
        "kicked+gather": (Material(), Numerics(spacing=SPACING, symplectic_density=False, cell_order=False,
                                               symmetric_pairs=False)),
        "no-delta+gather": (Material(), Numerics(spacing=SPACING, delta_sph=0.0, cell_order=False,
                                                 symmetric_pairs=False)),
        "strain+wall-friction": (Material(model="mu_i_strain"), Numerics(spacing=SPACING,
                                                                         wall_friction_coefficient=0.4)),
        # the kernel's own ∇W, the default before the normalisation: its digest is that default's
        "own-gradient": (Material(), Numerics(spacing=SPACING, kernel_gradient_normalisation=False)),
    }


# variants that also keep the load of the grains on the box's walls
TRACKS_WALL_LOADS = ("strain+wall-friction",)


def leg_digest(numerics: dict[str, bool | int | float], steps: int) -> str:
    """Digest of a small rotating-leg scene with `numerics` after `steps` steps, and with an active
    domain the number of grains frozen then."""
    config = LegRotation(settle_time=0.0, omega=2.0, bed_depth=0.08, bed_width=0.12, numerics=numerics)
    scene, material, leg_numerics = build_leg_rotation(config)
    sim = Simulation(scene, material, leg_numerics, width=config.width)
    sim.advance(1e9, max_steps=steps)
    if "frozen" not in sim.core.field_names("granular"):
        return digest(sim)
    return f"{digest(sim)} {int(np.sum(sim.core.field('frozen')))} frozen"


def plate_3d_digest(numerics: dict[str, bool | int | float], steps: int) -> str:
    """Digest of a small 3D plate intrusion (1 152 grains; the plate moving down from the start) with
    `numerics` after `steps` steps."""
    config = PlateIntrusion3D(bed_length=0.06, bed_breadth=0.06, bed_depth=0.04, plate_length=0.02,
                              plate_breadth=0.02, max_depth=0.008, settle_time=0.0, speed=0.1, numerics=numerics)
    sim = build_plate_intrusion_3d(config)
    sim.advance(1e9, max_steps=steps)
    return digest(sim)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--steps", type=int, default=150)
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    for name, (material, numerics) in bed_variants().items():
        sim = bed(3000, material, numerics)
        if name in TRACKS_WALL_LOADS:
            sim.track_wall_loads()
        sim.advance(1e9, max_steps=args.steps)
        print(name, digest(sim), flush=True)
    print("leg", leg_digest({}, 2 * args.steps), flush=True)
    # the active domain with a radius about the turning leg: grains freeze, and wake as it nears
    active = {"freeze_speed": 0.05, "freeze_steps": 20, "active_radius": 0.03}
    print("leg+active-radius", leg_digest(active, 2 * args.steps), flush=True)
    # the same with the gather in id order (the defaults take each pair once in cell order)
    gather = {**active, "cell_order": False, "symmetric_pairs": False}
    print("leg+active-radius+gather", leg_digest(gather, 2 * args.steps), flush=True)
    print("3d-plate", plate_3d_digest({}, 2 * args.steps), flush=True)
    print("3d-plate+gather", plate_3d_digest({"cell_order": False, "symmetric_pairs": False}, 2 * args.steps),
          flush=True)


if __name__ == "__main__":
    main()
