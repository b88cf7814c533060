"""Two geometric corrections of RFT's locality tried on the chapter 3 rotating legs (docs/rft.md,
"The three tiers side by side"): how much could they change the legs' peak loads?

    OMP_NUM_THREADS=1 python benchmarks/studies/rft_occlusion.py [--rft-table generic|TABLE.json]

1. **Occlusion along the motion.** An element moving into sand that another part of the same body has
   already passed through is shadowed: the ray from its centre along its velocity (in the body's frame)
   meets the body. Counted over each sweep (31 poses), among the elements that RFT loads (below the
   surface, leading): a count of 0 means the rule cannot change that leg's loads.
2. **Cavities filled** (the body replaced by the convex hull of its outline, the grains in a cavity
   carried with it; Treers, Cao & Stuart 2021, IEEE RA-L 6:1479, apply RFT to convex hulls): the
   peak lift and thrust of the sweep at 0.2 rad/s, against the leg as it is.
"""

from __future__ import annotations

import argparse

import numpy as np
from terrasph import bodies
from terrasph.scenes.leg_rotation import LEGS, LegRotation
from terrasph.terrain import rft


def _ray_meets(start: np.ndarray, direction: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the ray start + t·direction, t > 0, crosses any segment a[k]–b[k]."""
    edge, offset = b - a, a - start
    denominator = direction[0] * edge[:, 1] - direction[1] * edge[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (offset[:, 0] * edge[:, 1] - offset[:, 1] * edge[:, 0]) / denominator
        u = (offset[:, 0] * direction[1] - offset[:, 1] * direction[0]) / denominator
    return bool(np.any((np.abs(denominator) > 1e-14) & (t > 1e-9) & (u >= 0) & (u <= 1)))


def occluded(config: LegRotation, poses: int = 31) -> tuple[int, int]:
    """(loaded element-poses, of which occluded) over `poses` angles of the sweep."""
    elements = rft.SurfaceElements.from_shape(config.shape(), width=config.width)
    tangent = np.column_stack([-elements.normal[:, 1], elements.normal[:, 0]])
    a = elements.centre - 0.5 * elements.length[:, None] * tangent
    b = elements.centre + 0.5 * elements.length[:, None] * tangent
    loaded = shadowed = 0
    for angle in np.linspace(config.start_angle, config.end_angle, poses):
        rotation = bodies.rotation_matrix(angle)
        arm = elements.centre @ rotation.T
        velocity = config.omega * np.column_stack([arm[:, 1], -arm[:, 0]])  # ω × r, clockwise spin
        body_velocity = velocity @ rotation  # the same vectors in the body's frame
        depth = -(arm[:, 1] + config.hip_height)
        for e in np.flatnonzero((depth > 0) & (np.einsum("ij,ij->i", elements.normal, body_velocity) > 0)):
            loaded += 1
            direction = body_velocity[e] / np.linalg.norm(body_velocity[e])
            others = np.arange(len(elements)) != e
            shadowed += _ray_meets(elements.centre[e], direction, a[others], b[others])
    return loaded, shadowed


def peaks(config: LegRotation, table: rft.RFTCoefficients, filled: bool) -> tuple[float, float]:
    """Peak lift and thrust (N) of the RFT sweep, the leg as it is or its convex hull."""
    shape = config.shape()
    if filled:
        shape = bodies.BodyShape(shape.name, shape.position, shape.normal, shape.spacing, shape.thickness,
                                 shape.width, shape.radius, (rft.convex_hull(np.concatenate(shape.outline)),))
    elements = rft.SurfaceElements.from_shape(shape, width=config.width)
    sweep = config.end_angle - config.start_angle
    count = max(1, round(config.samples_per_radian * sweep))
    theta = config.start_angle + (np.arange(count) + 0.5) * sweep / count
    force = np.array([rft.body_load(elements, a, (0.0, config.hip_height), np.zeros(2), config.omega, 0.0,
                                    table).force for a in theta])
    return float(force[:, 1].max()), float(force[:, 0].max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rft-table", default="generic")
    args = parser.parse_args()
    table = rft.coefficient_table(args.rft_table)
    print(f"coefficient map: {args.rft_table}")
    print("| leg | loaded element-poses | occluded along the motion | peak lift / thrust (N) | cavities filled |")
    print("|---|---|---|---|---|")
    for leg in LEGS:
        config = LegRotation(leg=leg, terrain="rft", rft_table=args.rft_table)
        loaded, shadowed = occluded(config)
        lift, thrust = peaks(config, table, filled=False)
        hull_lift, hull_thrust = peaks(config, table, filled=True)
        print(f"| {leg} | {loaded} | {shadowed} | {lift:.3f} / {thrust:.3f} | {hull_lift:.3f} / {hull_thrust:.3f} |",
              flush=True)


if __name__ == "__main__":
    main()
