"""Steady granular flow down a rough inclined plane against the analytic μ(I) (Bagnold) profile.

    python benchmarks/validation/inclined_plane.py [--angles 24 27] [--spacing 0.001] [--depth 0.02]
        [--length 1.0] [--t-end 2.0] [--threads 2] [--model mu_i_rate] [--numerics NAME=VALUE ...]

A layer of depth h on a rough plane at angle θ with μ1 < tan θ < μ2 flows steadily with μ(I) = tan θ
everywhere, so I is uniform: I = I0 (tan θ − μ1)/(μ2 − tan θ) (Eq. 2.31 inverted; GDR MiDi 2004,
Jop, Forterre & Pouliquen 2005). With P = ρ g cos θ (h − y) and I = γ̇ d/√(P/ρ_s) (γ̇ = du/dy, the
definition I0 was fitted with), the velocity is Bagnold's

    u(y) = (2/3) (I/d) √(ρ g cos θ/ρ_s) [h^{3/2} − (h − y)^{3/2}],

no slip at the base. The SPH has no periodic boundaries, so the layer lies on a plane of `length`
between two end walls and flows; the profile is read at mid-length, averaged over the run's last
`window` seconds, which must end before the disturbances from the ends reach mid-length (the
rarefaction from the upper end travels at the kinematic wave speed dq/dh = (5/2)ū = 1.5 u_s of a
Bagnold layer, q ∝ h^{5/2}). The window's steadiness (the spread of the speed below the top row over
it, as a share of its mean) is reported beside the largest difference of its mean profile from
Bagnold's as a share of the analytic surface speed.
The geometry is tilted (gravity stays (0, −g)); the grains start at the density of the lithostatic
pressure normal to the plane.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import numpy as np
from terrasph import _core
from terrasph.cli_common import numerics_setting
from terrasph.config import Material, Numerics
from terrasph.geometry import lattice_block, wall_layers_needed
from terrasph.scene import Scene, hydrostatic_density
from terrasph.simulation import Simulation


def bagnold_velocity(y: np.ndarray, depth: float, angle: float, material: Material, gravity: float) -> np.ndarray:
    """u(y) of the steady μ(I) flow (module docstring), with ρ the bulk density ρ0."""
    tan = math.tan(angle)
    inertial = material.inertial_number_i0 * (tan - material.mu1) / (material.mu2 - tan)
    scale = (inertial / material.grain_diameter) * math.sqrt(
        material.reference_density * gravity * math.cos(angle) / material.grain_density)
    return scale * (2.0 / 3.0) * (depth**1.5 - np.clip(depth - y, 0.0, None) ** 1.5)


def to_plane(points: np.ndarray, angle: float) -> np.ndarray:
    """x–z positions (or velocities) in plane coordinates (x' downhill, y' normal)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.column_stack([c * points[:, 0] - s * points[:, 1], s * points[:, 0] + c * points[:, 1]])


def build(angle: float, spacing: float, depth: float, length: float, model: str,
          threads: int, numerics_overrides: dict[str, float | bool]) -> tuple[Simulation, Material]:
    material = Material(model=model)
    numerics = Numerics(spacing=spacing, **numerics_overrides)
    scene = Scene(spacing=spacing)
    c, s = math.cos(angle), math.sin(angle)
    plane = lattice_block(0.0, 0.0, length, depth, spacing)  # x' along, y' up from the plane
    scene.granular.append(np.column_stack([c * plane[:, 0] + s * plane[:, 1], -s * plane[:, 0] + c * plane[:, 1]]))
    top = 6.0 * depth  # the end walls hold the heap the flow builds against the lower one
    corners = np.array([[0.0, top], [0.0, 0.0], [length, 0.0], [length, top]])
    walls = np.column_stack([c * corners[:, 0] + s * corners[:, 1], -s * corners[:, 0] + c * corners[:, 1]])
    scene.add_wall("chute", walls, layers=wall_layers_needed(numerics.h_factor), no_slip=True)
    margin = 0.05
    scene.domain_lower = (float(walls[:, 0].min()) - margin, float(walls[:, 1].min()) - margin)
    scene.domain_upper = (float(walls[:, 0].max()) + margin, float(walls[:, 1].max()) + margin)
    normal_depth = depth - plane[:, 1]
    density = hydrostatic_density(normal_depth * math.cos(angle), material, scene.gravity)
    _core.set_num_threads(threads)
    return Simulation(scene, material, numerics, initial_density=density, geostatic=False), material


def window_profile(sim: Simulation, angle: float, length: float, spacing: float,
                   window: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Mean downhill speed per layer (y' bins of Δx) of the grains with x' in `window` (fractions of
    the length)."""
    plane = to_plane(np.array(sim.position), angle)
    speed = to_plane(np.array(sim.velocity), angle)[:, 0]
    inside = (plane[:, 0] > window[0] * length) & (plane[:, 0] < window[1] * length)
    layer = np.floor(plane[inside, 1] / spacing).astype(int)
    counts = np.bincount(layer, minlength=layer.max() + 1)
    sums = np.bincount(layer, weights=speed[inside], minlength=layer.max() + 1)
    used = counts > 0
    return (np.arange(len(counts))[used] + 0.5) * spacing, sums[used] / counts[used]


def run_angle(angle_deg: float, args: argparse.Namespace) -> dict[str, Any]:
    """Runs one angle to `t_end`, sampling every `sample_interval`; the samples of the last `window`
    seconds form the steady window. Returns its `steadiness` (max − min of the speed below the top row
    over the window, as a share of its mean) and `error`: the largest difference of the window's
    mean profile from Bagnold's over the layer (the top row, the kernel-truncated free surface, left
    out) as a share of the analytic surface speed."""
    angle = math.radians(angle_deg)
    sim, material = build(angle, args.spacing, args.depth, args.length, args.model, args.threads,
                          dict(args.numerics))
    analytic_surface = float(bagnold_velocity(np.array([args.depth]), args.depth, angle, material, sim.scene.gravity)[0])
    started = time.perf_counter()
    samples = []
    steps = int(round(args.t_end / args.sample_interval))
    for k in range(1, steps + 1):
        t = k * args.sample_interval
        sim.advance(t)
        y, u = window_profile(sim, angle, args.length, args.spacing, (0.45, 0.55))
        interior = y < args.depth - args.spacing  # the top layer is the kernel-truncated free surface
        analytic = bagnold_velocity(y[interior], args.depth, angle, material, sim.scene.gravity)
        error = float(np.max(np.abs(u[interior] - analytic)) / analytic_surface)
        samples.append((t, y[interior], u[interior], analytic))
        print(f"  theta {angle_deg:g} deg  t {t:5.2f} s  speed below the top row {u[interior][-1]:.4f} m/s "
              f"(Bagnold there {analytic[-1]:.4f}, surface {analytic_surface:.4f})  max |du|/u_s {error:.3f}",
              flush=True)
    window = [w for w in samples if w[0] > args.t_end - args.window - 1e-9]
    rows = min(len(w[2]) for w in window)
    below_top = np.array([w[2][rows - 1] for w in window])
    mean = np.mean([w[2][:rows] for w in window], axis=0)
    analytic = window[0][3][:rows]
    return {"angle_deg": angle_deg, "wall_s": time.perf_counter() - started, "particles": len(sim.position),
            "analytic_surface": analytic_surface, "t": (window[0][0], window[-1][0]), "samples": len(window),
            "steadiness": float((below_top.max() - below_top.min()) / below_top.mean()),
            "error": float(np.max(np.abs(mean - analytic)) / analytic_surface),
            "profile": (window[0][1][:rows].tolist(), mean.tolist(), analytic.tolist())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--angles", type=float, nargs="+", default=[24.0, 27.0], help="plane angles in degrees")
    parser.add_argument("--spacing", type=float, default=0.001)
    parser.add_argument("--depth", type=float, default=0.02, help="flow depth h (m)")
    parser.add_argument("--length", type=float, default=1.0, help="plane length between the end walls (m)")
    parser.add_argument("--t-end", type=float, default=2.0)
    parser.add_argument("--sample-interval", type=float, default=0.1)
    parser.add_argument("--window", type=float, default=0.5,
                        help="the steady window: the run's last WINDOW seconds (s)")
    parser.add_argument("--model", default="mu_i_rate")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--numerics", type=numerics_setting, nargs="*", default=[], metavar="NAME=VALUE",
                        help="numerics over the defaults, e.g. artificial_viscosity=0.02")
    args = parser.parse_args()
    for angle in args.angles:
        result = run_angle(angle, args)
        y, u, analytic = (np.array(v) for v in result["profile"])
        print(f"theta {angle:g} deg: window {result['t'][0]:.2f}-{result['t'][1]:.2f} s ({result['samples']} samples, "
              f"speed below the top row within {result['steadiness']:.1%}), max |u - u_Bagnold| of the mean profile "
              f"= {result['error']:.1%} of the surface speed {result['analytic_surface']:.4f} m/s; "
              f"{result['particles']} grains, {result['wall_s']:.0f} s wall")
        print("  y (mm)  u SPH (m/s)  u Bagnold (m/s)")
        for yy, uu, aa in zip(y, u, analytic):
            print(f"  {yy * 1e3:6.2f}  {uu:10.4f}  {aa:10.4f}")


if __name__ == "__main__":
    main()
