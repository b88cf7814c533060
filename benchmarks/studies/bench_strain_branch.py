"""The strain-based quasi-static branch of Eq. 3.6 (``mu_i_strain``) against the hypoelastic μ(I)
(``mu_i_hypoelastic``, the default) and the rate form (``mu_i_rate``).

Two scenes per model, each printed as a table row and drawn into figures:

* settled bed: the 0.12 × 0.05 m bed of tests/test_settling.py in a rough box (Δx = 5 mm, 240
  grains), 0.2 s from a hydrostatic start: mean |v| at the end, the lithostatic slope error of −σ_zz
  against depth, the scatter of σ_zz at fixed depth (mean over lattice rows of its standard
  deviation in the central 70 % of the width, over ρgH), and the earth-pressure ratio
  K = σ_xx/σ_zz in the central 70 % below the top two rows (Jaky's K0 = 1 − sin φ = 0.64 for
  φ = 21°; a bed at yield in the active state has (1 − sin φ)/(1 + sin φ) = 0.47);
* column collapse (7 × 8 cm, ``--column-spacing``, until at rest): L*, H*, steps, CPU time, and
  the final profiles in one figure (``strain_branch_profiles.png``); the beds' −σ_zz against depth
  in another (``strain_branch_bed_stress.png``).

    python benchmarks/studies/bench_strain_branch.py [--column-spacing 0.005] [--threads 1] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from terrasph import _core, analysis
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.plotting import plot_profiles
from terrasph.scene import Scene
from terrasph.scenes import ColumnCollapse, run_column_collapse
from terrasph.simulation import Simulation

MODELS = ("mu_i_hypoelastic", "mu_i_strain", "mu_i_rate")
DX, WIDTH, HEIGHT, G = 0.005, 0.12, 0.05, 9.81


def settled_bed(model: str, t_end: float) -> tuple[dict[str, float], tuple[np.ndarray, np.ndarray]]:
    """Settles the bed with `model`; its rest and stress figures and CPU time, and (depth/H, −σ_zz/ρgH)
    of every grain."""
    scene = Scene(spacing=DX)
    scene.add_block(0.0, 0.0, WIDTH, HEIGHT)
    scene.add_wall("box", [(0.0, HEIGHT + 6 * DX), (0.0, 0.0), (WIDTH, 0.0), (WIDTH, HEIGHT + 6 * DX)],
                   layers=wall_layers_needed(1.3))
    cpu = time.process_time()
    sim = Simulation(scene, Material(model=model), Numerics(spacing=DX))
    steps = sim.advance(t_end)
    cpu = time.process_time() - cpu
    x, stress = np.array(sim.position), np.array(sim.stress)
    top = x[:, 1].max() + 0.5 * DX
    centre = (x[:, 0] > 0.15 * WIDTH) & (x[:, 0] < 0.85 * WIDTH)
    rho = float(np.mean(sim.density))
    scatter = analysis.vertical_stress_scatter(x, stress, DX, (0.15 * WIDTH, 0.85 * WIDTH)) / (rho * G * HEIGHT)
    z, sigma_v = analysis.vertical_stress_profile(x, stress, DX, (0.15 * WIDTH, 0.85 * WIDTH))
    slope, _, _ = analysis.fit_line(top - z, sigma_v)
    deep = centre & (x[:, 1] < top - 2 * DX)
    ratio = float(np.sum(stress[deep, 0, 0]) / np.sum(stress[deep, 1, 1]))
    return {"steps": steps, "cpu_time": cpu, "mean_speed": float(np.linalg.norm(sim.velocity, axis=1).mean()),
            "slope_error": slope / (rho * G) - 1.0, "scatter": float(scatter), "k_ratio": ratio}, \
        ((top - x[:, 1]) / HEIGHT, -stress[:, 1, 1] / (rho * G * HEIGHT))


def plot_bed_stress(scatter: dict[str, tuple[np.ndarray, np.ndarray]], path: Path) -> None:
    """−σ_zz/(ρgH) of every grain against depth/H, one panel per model, with the lithostatic line."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(3.2 * len(scatter), 3.4), layout="constrained")
    axes = figure.subplots(1, len(scatter), sharey=True, squeeze=False)[0]
    for ax, (model, (depth, sigma)) in zip(axes, scatter.items()):
        ax.plot(depth, sigma, ".", markersize=3, label="grains")
        ax.plot([0, 1], [0, 1], "k--", label="ρgz")
        ax.set_title(model)
        ax.set_xlabel("depth / H")
    axes[0].set_ylabel("−σ_zz / (ρgH)")
    axes[0].legend()
    figure.savefig(path, dpi=120)


def column(model: str, spacing: float) -> tuple[dict[str, float], tuple[np.ndarray, np.ndarray]]:
    """The collapse with `model` until at rest; its outcome and final surface profile."""
    cpu = time.process_time()
    result = run_column_collapse(ColumnCollapse(spacing=spacing, model=model), output=None, progress=False, plot=False)
    summary = {**result.summary(), "cpu_time": time.process_time() - cpu}
    return summary, analysis.surface_profile(result.final_position, spacing)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--column-spacing", type=float, default=0.005)
    parser.add_argument("--bed-time", type=float, default=0.2)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--models", nargs="+", default=list(MODELS))
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "results")
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    beds, columns, profiles, bed_stress = {}, {}, [], {}
    for model in args.models:
        beds[model], bed_stress[model] = settled_bed(model, args.bed_time)
        print(json.dumps({"bed": model, **beds[model]}), flush=True)
        columns[model], profile = column(model, args.column_spacing)
        profiles.append((*profile, f"{model}: L* = {columns[model]['runout_normalised']:.2f}, "
                                   f"H* = {columns[model]['final_height_normalised']:.2f}"))
        print(json.dumps({"column": model, **columns[model]}), flush=True)
    print(f"\nSettled bed, {WIDTH} x {HEIGHT} m, dx = {DX} m, {args.bed_time} s")
    print("| model | steps | CPU (s) | mean speed (m/s) | slope error | σ_zz scatter | σ_xx/σ_zz |")
    print("|---|---|---|---|---|---|---|")
    for model, b in beds.items():
        print(f"| {model} | {b['steps']} | {b['cpu_time']:.1f} | {b['mean_speed']:.1e} | {100 * b['slope_error']:+.1f} % "
              f"| {b['scatter']:.5f} | {b['k_ratio']:.2f} |")
    print(f"\nColumn collapse, dx = {args.column_spacing} m, until at rest")
    print("| model | steps | run until (s) | CPU (s) | L* | H* | status |")
    print("|---|---|---|---|---|---|---|")
    for model, c in columns.items():
        print(f"| {model} | {c['steps']} | {c['time']:.2f} | {c['cpu_time']:.1f} | {c['runout_normalised']:.3f} | "
              f"{c['final_height_normalised']:.3f} | {c['status']} |")
    (args.out / "strain_branch.json").write_text(json.dumps({"bed": beds, "column": columns}, indent=2))
    plot_profiles(profiles, path=args.out / "strain_branch_profiles.png")
    plot_bed_stress(bed_stress, args.out / "strain_branch_bed_stress.png")


if __name__ == "__main__":
    main()
