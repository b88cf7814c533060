"""Steady granular flow down a rough inclined plane against the analytic μ(I) (Bagnold) profile.

    python benchmarks/validation/inclined_plane.py [--angles 24 27] [--spacing 0.001] [--depth 0.02]
        [--length 1.0] [--t-end 2.0] [--threads 2] [--model mu_i_rate] [--numerics NAME=VALUE ...]

A layer of depth h on a rough plane at angle θ with μ1 < tan θ < μ2 flows steadily with μ(I) = tan θ
everywhere, so I is uniform: I = I0 (tan θ − μ1)/(μ2 − tan θ) (Eq. 2.31 inverted; GDR MiDi 2004,
Jop, Forterre & Pouliquen 2005). With P = ρ g cos θ (h − y) and I = γ̇ d/√(P/ρ_s) (γ̇ = du/dy, the
definition I0 was fitted with), the velocity is Bagnold's

    u(y) = (2/3) (I/d) √(ρ g cos θ/ρ_s) [h^{3/2} − (h − y)^{3/2}],

no slip at the base. The SPH has no periodic boundaries, so the layer lies on a plane of `length`
between two end walls and flows; the profile is read in a window at mid-length while the
disturbances from the ends have not reached it. Each angle's run prints the steady window's
profile beside Bagnold's and the largest difference as a share of the analytic surface speed.
The geometry is tilted (gravity stays (0, −g)); the grains start at the density of the lithostatic
pressure normal to the plane.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import numpy as np
from terrasph.config import Material, Numerics
from terrasph.geometry import lattice_block, wall_layers_needed
from terrasph.scene import Scene, hydrostatic_density
from terrasph.simulation import Simulation
from terrasph import _core
from terrasph.cli_common import numerics_setting


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
    top = 3.0 * depth
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


def run_angle(angle_deg: float, args: argparse.Namespace) -> dict[str, float]:
    """Runs one angle; the steady window starts at the first sample whose second-highest layer's
    speed changed by less than `steady_change` since the sample before and takes every following
    sample within twice that share of the window's mean speed (it closes at the first outside:
    the end walls' disturbances); its time-averaged profile is compared with Bagnold's: `error` is the largest
    difference over the layer (the top row, the kernel-truncated free surface, left out) as a share
    of the analytic surface speed."""
    angle = math.radians(angle_deg)
    sim, material = build(angle, args.spacing, args.depth, args.length, args.model, args.threads,
                          dict(args.numerics))
    analytic_surface = float(bagnold_velocity(np.array([args.depth]), args.depth, angle, material, sim.scene.gravity)[0])
    started = time.perf_counter()
    previous, window, closed = None, [], False
    t = 0.0
    while t < args.t_end - 1e-12 and not closed:
        t = min(args.t_end, t + args.sample_interval)
        sim.advance(t)
        y, u = window_profile(sim, angle, args.length, args.spacing, (0.45, 0.55))
        interior = y < args.depth - args.spacing  # the top layer is the kernel-truncated free surface
        near_surface = float(u[interior][-1])
        change = math.inf if previous is None else abs(near_surface - previous) / max(abs(near_surface), 1e-12)
        previous = near_surface
        analytic = bagnold_velocity(y, args.depth, angle, material, sim.scene.gravity)
        error = float(np.max(np.abs(u[interior] - analytic[interior])) / analytic_surface)
        print(f"  theta {angle_deg:g} deg  t {t:5.2f} s  speed below the top row {near_surface:.4f} m/s "
              f"(Bagnold surface {analytic_surface:.4f})  max |du|/u_s {error:.3f}  change {change:.3%}", flush=True)
        if window:
            mean_speed = float(np.mean([w[2][-1] for w in window]))
            if abs(near_surface - mean_speed) < 2 * args.steady_change * mean_speed:
                window.append((t, y, u[interior], analytic[interior]))
            else:
                closed = True  # the flow changes again: the end walls' disturbances have arrived
        elif change < args.steady_change:
            window.append((t, y, u[interior], analytic[interior]))
    result: dict[str, Any] = {"angle_deg": angle_deg, "wall_s": time.perf_counter() - started,
                              "particles": len(sim.position), "analytic_surface": analytic_surface}
    if window:
        rows = min(len(w[2]) for w in window)
        mean = np.mean([w[2][:rows] for w in window], axis=0)
        analytic = window[0][3][:rows]
        result.update({"t": (window[0][0], window[-1][0]), "samples": len(window),
                       "error": float(np.max(np.abs(mean - analytic)) / analytic_surface),
                       "profile": (window[0][1][:rows].tolist(), mean.tolist(), analytic.tolist())})
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--angles", type=float, nargs="+", default=[24.0, 27.0], help="plane angles in degrees")
    parser.add_argument("--spacing", type=float, default=0.001)
    parser.add_argument("--depth", type=float, default=0.02, help="flow depth h (m)")
    parser.add_argument("--length", type=float, default=1.0, help="plane length between the end walls (m)")
    parser.add_argument("--t-end", type=float, default=2.0)
    parser.add_argument("--sample-interval", type=float, default=0.1)
    parser.add_argument("--steady-change", type=float, default=0.01,
                        help="a sample counts as steady when the surface speed changed less than this share")
    parser.add_argument("--model", default="mu_i_rate")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--numerics", type=numerics_setting, nargs="*", default=[], metavar="NAME=VALUE",
                        help="numerics over the defaults, e.g. artificial_viscosity=0.02")
    args = parser.parse_args()
    for angle in args.angles:
        result = run_angle(angle, args)
        if "profile" not in result:
            print(f"theta {angle:g} deg: no steady sample within t_end")
            continue
        y, u, analytic = (np.array(v) for v in result["profile"])
        print(f"theta {angle:g} deg: steady from t = {result['t'][0]:.2f} to {result['t'][1]:.2f} s "
              f"({result['samples']} samples), max |u - u_Bagnold| of the mean profile = {result['error']:.1%} "
              f"of the surface speed {result['analytic_surface']:.4f} m/s; {result['particles']} grains, "
              f"{result['wall_s']:.0f} s wall")
        print("  y (mm)  u SPH (m/s)  u Bagnold (m/s)")
        for yy, uu, aa in zip(y, u, analytic):
            print(f"  {yy * 1e3:6.2f}  {uu:10.4f}  {aa:10.4f}")


if __name__ == "__main__":
    main()
