"""Where RFT and the SPH disagree on a rotating leg, face by face (docs/rft.md, "RFT against the SPH").

For each frame of an SPH leg-rotation run (``terrasph run leg-rotation ... --frame-interval 0.25``)
the traction of the grains on each RFT surface element is estimated as σ·n ℓ w, σ the grains' stress
(Wendland-weighted mean over the grains within 2h of a point 1.5 Δx outside the element), n the
element's outward normal; RFT's load on the same element at the same pose is taken with the chosen
map. The elements are grouped as RFT groups them: leading (n·v > 0) and trailing faces below the
undisturbed surface, and faces above it; the trailing faces' traction is also compared with the
overburden ρ0 g d pressing on them. Prints one row per `--every` frames:

    OMP_NUM_THREADS=1 python benchmarks/studies/rft_leg_faces.py RUN.h5 [--rft-table generic|TABLE.json] \\
        [--every 2]
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.spatial import cKDTree
from terrasph import bodies
from terrasph.config import glass_beads
from terrasph.io import read_run
from terrasph.scenes.leg_rotation import LegRotation
from terrasph.terrain import rft

#: the grains' stress is read this many Δx outside each element, over the grains within 2h of it
PROBE_OFFSET = 1.5
SMOOTHING_RATIO = 1.3  # h / Δx, the core's default


def _wendland(q: np.ndarray) -> np.ndarray:
    """The Wendland C2 kernel's shape in q = r/h (support 2h), unnormalised."""
    return np.clip(1 - q / 2, 0, None) ** 4 * (2 * q + 1)


def face_tractions(grains: np.ndarray, stress: np.ndarray, centre: np.ndarray, normal: np.ndarray,
                   area: np.ndarray, spacing: float) -> np.ndarray:
    """σ·n A (N) of the grains on each element (world frame), 0 where no grain is near."""
    h = SMOOTHING_RATIO * spacing
    tree = cKDTree(grains)
    out = np.zeros_like(centre)
    for i, point in enumerate(centre + PROBE_OFFSET * spacing * normal):
        near = tree.query_ball_point(point, 2 * h)
        if not near:
            continue
        weight = _wendland(np.linalg.norm(grains[near] - point, axis=1) / h)
        if weight.sum() > 0:
            sigma = np.einsum("k,kij->ij", weight, stress[near]) / weight.sum()
            out[i] = sigma @ normal[i] * area[i]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="an SPH leg-rotation run file with frames")
    parser.add_argument("--rft-table", default="generic")
    parser.add_argument("--every", type=int, default=2, help="print every this many frames")
    args = parser.parse_args()
    run = read_run(args.run)
    fields = run.config["leg_rotation"]
    config = LegRotation(**{k: v for k, v in fields.items() if k in LegRotation.__dataclass_fields__})
    table = rft.coefficient_table(args.rft_table)
    shape = config.shape()
    elements = rft.SurfaceElements.from_shape(shape, width=config.width)
    area = elements.length * elements.width
    weight = glass_beads().reference_density * 9.81  # ρ0 g (N/m³)
    series = run.series["bodies/leg"]
    print(f"{args.run}: {config.leg}, ω = {config.omega:g} rad/s, Δx = {1e3 * config.grid_spacing:.2f} mm, "
          f"RFT map {table.source or args.rft_table} (ζ = {table.zeta:.3g} N/m³); loads F_x, F_z in N")
    print("θ (rad) | SPH body | Σ traction | SPH leading | SPH trailing | ρ0 g d on trailing | SPH above surface "
          "| RFT (leading)")
    frames = [k for k in range(run.n_frames) if run.times[k] > config.settle_time + 1e-9]
    for k in frames[::args.every]:
        frame, time = run.frame(k), float(run.times[k])
        angle = min(config.end_angle, config.start_angle + config.omega * (time - config.settle_time))
        turn = bodies.rotation_matrix(angle)
        hip = frame["body_position"].mean(axis=0) - turn @ shape.position.mean(axis=0)  # order-free
        surface = hip[1] - config.hip_height
        centre, normal = elements.centre @ turn.T + hip, elements.normal @ turn.T
        depth = surface - centre[:, 1]
        arm = centre - hip
        leads = np.sum(normal * config.omega * np.column_stack([arm[:, 1], -arm[:, 0]]), axis=1) > 0  # clockwise
        below = depth > 0
        traction = face_tractions(frame["position"], frame["stress"], centre, normal, area, config.grid_spacing)
        overburden = -(weight * np.clip(depth, 0, None) * area)[:, None] * normal
        load = rft.body_load(elements, angle, hip - np.array([0.0, surface]), np.zeros(2), config.omega, 0.0, table)
        sample = int(np.argmin(np.abs(series["time"] - time)))

        def pair(values: np.ndarray, mask: np.ndarray) -> str:
            return f"{values[mask, 0].sum():+.2f}, {values[mask, 1].sum():+.2f}"

        every = np.ones(len(depth), bool)
        print(f"{angle:+.3f} | {series['force'][sample][0]:+.2f}, {series['force'][sample][1]:+.2f} | "
              f"{pair(traction, every)} | {pair(traction, leads & below)} | {pair(traction, ~leads & below)} | "
              f"{pair(overburden, ~leads & below)} | {pair(traction, ~below)} | {load.force[0]:+.2f}, {load.force[1]:+.2f}")


if __name__ == "__main__":
    main()
