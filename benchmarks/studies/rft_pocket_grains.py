"""Do the grains in a leg's pocket ride with it? (docs/rft.md, "Carried grains")

For each frame of an SPH leg-rotation run (``terrasph run leg-rotation --leg reversed-c-leg --omega 0.2
--bed-depth 0.08 --settle-time 0.3 --frame-interval 0.25 --out RUN.h5``), the grains inside the leg's
pockets (terrasph.terrain.rft.SurfaceElements: between its outline and its convex hull) are counted, their
mean speed relative to the leg's rigid motion at their places is given as a fraction of that motion's
speed (0: carried as part of the leg), and their weight ρ0 Δx² w g:

    python benchmarks/studies/rft_pocket_grains.py RUN.h5
"""

from __future__ import annotations

import argparse

import numpy as np
from terrasph import bodies
from terrasph.config import glass_beads
from terrasph.io import read_run
from terrasph.scene import GRAVITY
from terrasph.scenes.leg_rotation import LegRotation
from terrasph.terrain import rft


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="an SPH leg-rotation run file with frames")
    args = parser.parse_args()
    run = read_run(args.run)
    fields = run.config["leg_rotation"]
    config = LegRotation(**{k: v for k, v in fields.items() if k in LegRotation.__dataclass_fields__})
    shape = config.shape()
    elements = rft.SurfaceElements.from_shape(shape)
    hull = rft.convex_hull(np.concatenate(shape.outline))
    grain_weight = glass_beads().reference_density * config.grid_spacing ** 2 * config.width * GRAVITY
    print(f"{args.run}: {config.leg}; pocket area {1e4 * elements.cell_area.sum():.2f} cm²")
    print("θ (rad) | grains in the pockets | below the surface | |v − v_rigid| / |v_rigid| | weight (N)")
    for k in range(run.n_frames):
        time = float(run.times[k])
        if time <= config.settle_time + 1e-9:
            continue
        frame = run.frame(k)
        angle = min(config.end_angle, config.start_angle + config.omega * (time - config.settle_time))
        turn = bodies.rotation_matrix(angle)
        hip = frame["body_position"].mean(axis=0) - turn @ shape.position.mean(axis=0)
        local = (frame["position"] - hip) @ turn  # the grains in the leg's frame
        pocket = (rft._winding(local, (hull,)) > 0) & (rft._winding(local, shape.outline) <= 0)
        if not pocket.any():
            print(f"{angle:+.3f} | 0 | | |")
            continue
        arm = frame["position"][pocket] - hip
        rigid = config.omega * np.column_stack([arm[:, 1], -arm[:, 0]])
        slip = np.linalg.norm(frame["velocity"][pocket] - rigid, axis=1).mean() / np.linalg.norm(rigid, axis=1).mean()
        below = np.count_nonzero(frame["position"][pocket, 1] < hip[1] - config.hip_height)
        print(f"{angle:+.3f} | {pocket.sum()} | {below} | {slip:.2f} | {pocket.sum() * grain_weight:.2f}")


if __name__ == "__main__":
    main()
