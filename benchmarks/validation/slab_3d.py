"""3D against the planar scenes (issue 49, part 4; docs/sph3d.md#the-slab-against-the-planar-scenes).

    python benchmarks/validation/slab_3d.py leg [--omega 0.8 --settle 0.3 --bed-depth 0.08]
                                                [--run-dir DIR [--resume]]
    python benchmarks/validation/slab_3d.py plate [--spacing 0.005]
    python benchmarks/validation/slab_3d.py side-flow [--spacing 0.005 --bed-breadth 0.0508
                                                      --breadths 0.0508 0.0254 0.015 --max-depth 0.02]
    python benchmarks/validation/slab_3d.py bed [--spacing 0.004 --t-end 0.2]

``leg``: the rotating C-leg of the leg-rotation scene, planar and in a 3D slab as wide as the leg
between smooth walls (terrasph.scenes.plane_strain_3d), same Δx and tier: peak lift and thrust.
``--run-dir`` keeps the slab's run file
(``DIR/leg_slab.h5``) and its checkpoint; ``--resume`` continues a stopped slab run from them,
bitwise the run that never stopped (the planar run, ~20 s, is run again). ``plate``: the plate-intrusion scene's down stroke, planar and in its slab: ζ = k/(L W), k the slope
of F_z against depth from 1 cm. ``side-flow``: the same plate, each breadth in one bed of
``--bed-breadth`` between smooth walls (the full breadth is the slab): ζ and F_z per unit breadth
at the deepest point. ``bed``: a 3D bed at rest, −σ_zz against the weight above per row and K =
σ_xx/σ_zz, σ_yy/σ_zz away from the walls against Jáky's K0. Each writes
``benchmarks/results/slab_3d_<check>.json`` (provenance inside) and ``docs/img/slab_3d_<check>.png``.
One thread each (OMP_NUM_THREADS as run); CPU seconds in the file.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import terrasph
from terrasph.scene import GRAVITY, earth_pressure_at_rest
from terrasph.scenes.leg_rotation import LegResult, LegRotation, run_leg_rotation
from terrasph.scenes.plane_strain_3d import LegSlab, PlateSlab, run_leg_slab, run_plate_slab
from terrasph.scenes.plate_intrusion import PlateIntrusion, PlateResult, run_plate_intrusion

ROOT = Path(__file__).resolve().parents[2]


def provenance() -> dict[str, Any]:
    """When, on what and by which command the results were measured (no host name)."""
    git = ["git", "-C", str(ROOT)]
    commit = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run([*git, "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                           text=True).stdout.strip()
    cpuinfo = Path("/proc/cpuinfo")
    cpu = next((line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if cpuinfo.exists() else platform.processor()
    return {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": commit + ("+changes" if dirty else ""), "terrasph": terrasph.__version__, "cpu": cpu,
            "cores": os.cpu_count() or 0, "threads": os.environ.get("OMP_NUM_THREADS", "all"),
            "command": " ".join(["python", "benchmarks/validation/slab_3d.py", *sys.argv[1:]])}


def timed(run, *args: Any, **kwargs: Any) -> tuple[Any, float]:
    """The result of run(*args, **kwargs) and the CPU seconds it took (all threads)."""
    start = time.process_time()
    result = run(*args, **kwargs)
    return result, time.process_time() - start


def leg_row(result: LegResult, cpu: float) -> dict[str, Any]:
    """The figures of one leg run."""
    return {"peak_lift": result.peak_lift, "peak_thrust": result.peak_thrust, "grains": result.granular_particles,
            "leaked": result.leaked_particles, "steps": result.run.steps, "status": result.run.status,
            "cpu_seconds": cpu}


def plate_row(result: PlateResult, cpu: float, breadth: float) -> dict[str, Any]:
    """The figures of one plate run: ζ = k/(L W) (N/m³), α = ζ/(ρ0 g), F_z at the deepest sample
    per unit breadth (N/m)."""
    slope, _, r_squared = result.fit()
    depth, force = result.stroke("down")
    area = result.config.plate_length * result.config.width
    return {"plate_breadth": result.config.width, "bed_breadth": breadth, "zeta": slope / area,
            "alpha": result.alpha(), "r_squared": r_squared, "deepest": float(depth.max()),
            "force_per_breadth_deepest": float(force[np.argmax(depth)] / result.config.width),
            "grains": result.granular_particles, "leaked": result.leaked_particles, "steps": result.run.steps,
            "status": result.run.status, "cpu_seconds": cpu}


def numerics_pair(text: str) -> tuple[str, float]:
    """argparse type of ``--slab-numerics``: ``NAME=VALUE`` with a number."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name, float(value)


def write(name: str, data: dict[str, Any]) -> Path:
    """benchmarks/results/slab_3d_<name>.json with the provenance."""
    path = ROOT / "benchmarks" / "results" / f"slab_3d_{name}.json"
    path.write_text(json.dumps({"provenance": provenance(), **data}, indent=1) + "\n")
    return path


def figure(name: str):
    """A matplotlib Figure (no pyplot) and the path of its PNG under docs/img."""
    from matplotlib.figure import Figure

    return Figure(figsize=(7.0, 4.0), layout="constrained"), ROOT / "docs" / "img" / f"slab_3d_{name}.png"


def leg(args: argparse.Namespace) -> None:
    """The rotating leg, planar and in its slab."""
    config = LegRotation(leg=args.leg, omega=args.omega, settle_time=args.settle, bed_depth=args.bed_depth,
                         resolution=args.resolution, fidelity=args.fidelity)
    planar, planar_cpu = timed(run_leg_rotation, config, progress=False, plot=False)
    print("planar", leg_row(planar, planar_cpu), flush=True)
    run_file = None if args.run_dir is None else str(args.run_dir / "leg_slab.h5")  # keeps a stopped run's series
    overrides = dict(args.slab_numerics)  # the slab's numerics only: a 3D tier against the planar defaults
    slab_config = dataclasses.replace(config, numerics=overrides) if overrides else config
    slab, slab_cpu = timed(run_leg_slab, LegSlab(slab_config), output=run_file, progress=args.progress,
                           resume=args.resume)  # resumed: the CPU seconds of the resumed part only
    print("slab", leg_row(slab, slab_cpu), flush=True)
    rows = {"planar": leg_row(planar, planar_cpu), "slab": leg_row(slab, slab_cpu)}
    ratios = {key: rows["slab"][key] / rows["planar"][key] - 1.0 for key in ("peak_lift", "peak_thrust")}
    curves = {name: {"theta": r.theta.tolist(), "lift": r.lift.tolist(), "thrust": r.thrust.tolist()}
              for name, r in (("planar", planar), ("slab", slab))}
    print(json.dumps(ratios), flush=True)
    tag = "leg" + "".join(f"_{key}_{value:g}" for key, value in overrides.items())
    path = write(tag, {"config": dataclasses.asdict(config), "slab_numerics": overrides,
                       "spacing": config.grid_spacing, "runs": rows, "slab_minus_planar": ratios, "curves": curves})
    fig, png = figure(tag)
    axes = fig.add_subplot()
    for name, r, style in (("planar", planar, "-"), ("3D slab", slab, "--")):
        axes.plot(r.theta, r.lift, "C0" + style, label=f"lift, {name}")
        axes.plot(r.theta, r.thrust, "C1" + style, label=f"thrust, {name}")
    axes.set_xlabel("leg angle θ (rad, clockwise from down)")
    axes.set_ylabel("load on the leg (N)")
    axes.set_title(f"{config.leg}, ω = {config.omega:g} rad/s, Δx = {1e3 * config.grid_spacing:.2f} mm: "
                   f"slab − planar: lift {100 * ratios['peak_lift']:+.1f} %, thrust {100 * ratios['peak_thrust']:+.1f} %")
    axes.legend()
    fig.savefig(png, dpi=120)
    print(path, png)


def plate_config(args: argparse.Namespace, width: float | None = None) -> PlateIntrusion:
    """The plate-intrusion scene at this spacing, down stroke only (to the turn)."""
    base = PlateIntrusion(spacing=args.spacing, fidelity=args.fidelity, max_depth=args.max_depth)
    config = dataclasses.replace(base, width=base.width if width is None else width)
    return dataclasses.replace(config, t_end=config.settle_time + config.stroke_time)


def plate(args: argparse.Namespace) -> None:
    """The plate's ζ, planar and in its slab."""
    config = plate_config(args)
    planar, planar_cpu = timed(run_plate_intrusion, config, progress=False, plot=False)
    slab, slab_cpu = timed(run_plate_slab, PlateSlab(config), progress=args.progress)
    rows = {"planar": plate_row(planar, planar_cpu, config.width), "slab": plate_row(slab, slab_cpu, config.width)}
    for spacing in args.planar_spacings:  # the planar scene's own resolution error at this spacing
        finer = dataclasses.replace(config, spacing=spacing)
        rows[f"planar at {spacing:g} m"] = plate_row(*timed(run_plate_intrusion, finer, progress=False, plot=False),
                                                     config.width)
    change = rows["slab"]["zeta"] / rows["planar"]["zeta"] - 1.0
    print(json.dumps(rows), change, flush=True)
    path = write("plate", {"config": dataclasses.asdict(config), "runs": rows, "zeta_slab_minus_planar": change,
                           "curves": {n: {"depth": r.stroke("down")[0].tolist(), "force": r.stroke("down")[1].tolist()}
                                      for n, r in (("planar", planar), ("slab", slab))}})
    fig, png = figure("plate")
    axes = fig.add_subplot()
    for name, r in (("planar", planar), ("3D slab", slab)):
        depth, force = r.stroke("down")
        axes.plot(1e3 * depth, force, "o-", ms=3, label=f"{name}: ζ = {rows['planar' if r is planar else 'slab']['zeta']:.3g} N/m³")
    axes.set_xlabel("depth of the plate's underside (mm)")
    axes.set_ylabel("$F_z$ (N)")
    axes.set_title(f"plate {1e3 * config.plate_length:g} × {1e3 * config.width:g} mm, Δx = {1e3 * config.spacing:g} mm: "
                   f"ζ slab − planar {100 * change:+.1f} %")
    axes.legend()
    fig.savefig(png, dpi=120)
    print(path, png)


def side_flow(args: argparse.Namespace) -> None:
    """The plate's ζ and load per unit breadth for each breadth in one wider bed."""
    rows, curves = [], {}
    for breadth in args.breadths:
        config = plate_config(args, breadth)
        result, cpu = timed(run_plate_slab, PlateSlab(config, args.bed_breadth), progress=args.progress)
        rows.append(plate_row(result, cpu, args.bed_breadth))
        depth, force = result.stroke("down")  # the breadth as built: result.config.width
        curves[f"{result.config.width:g}"] = {"depth": depth.tolist(),
                                              "force_per_breadth": (force / result.config.width).tolist()}
        print(json.dumps(rows[-1]), flush=True)
    planar = {f"{spacing:g}": plate_row(*timed(run_plate_intrusion, dataclasses.replace(plate_config(args),
                                                                                      spacing=spacing),
                                               progress=False, plot=False), args.bed_breadth)
              for spacing in (args.spacing, *args.planar_spacings)}  # the planar scene, the same stroke
    print(json.dumps(planar), flush=True)
    path = write("side_flow", {"config": dataclasses.asdict(plate_config(args)), "bed_breadth": args.bed_breadth,
                               "rows": rows, "planar": planar, "curves": curves})
    fig, png = figure("side_flow")
    axes = fig.add_subplot()
    for row in rows:
        curve = curves[f"{row['plate_breadth']:g}"]
        axes.plot(1e3 * np.asarray(curve["depth"]), curve["force_per_breadth"], "o-", ms=3,
                  label=f"B = {1e3 * row['plate_breadth']:.1f} mm (B/bed = {row['plate_breadth'] / args.bed_breadth:.2f}): "
                        f"ζ = {row['zeta']:.3g} N/m³")
    axes.set_xlabel("depth of the plate's underside (mm)")
    axes.set_ylabel("$F_z$ per unit breadth (N/m)")
    axes.set_title(f"plate 40 mm long in a {1e3 * args.bed_breadth:.1f} mm broad bed, smooth sides, "
                   f"Δx = {1e3 * args.spacing:g} mm")
    axes.legend()
    fig.savefig(png, dpi=120)
    print(path, png)


def bed(args: argparse.Namespace) -> None:
    """A 3D bed at rest: per row, −σ_zz over the weight above, and K along x and y."""
    from terrasph.config import Material, Numerics
    from terrasph.scenes.leg_rotation import glass_beads
    from terrasph.sph3d import bed_simulation, geostatic_bed

    results = []
    fig, png = figure("bed")
    axes = fig.subplots(1, 2)
    for name, material, smooth in (("default material", Material(), False),
                                   ("glass beads (chapter 3)", glass_beads(), False),
                                   ("glass beads, smooth ±y walls", glass_beads(), True)):
        dx = args.spacing
        bed3 = geostatic_bed(tuple(args.size), material, dx, rim=2 * dx, smooth_y_walls=smooth)
        size = bed3.size
        margin = 0.05
        sim = bed_simulation(bed3, material, Numerics(spacing=dx), np.array([-margin] * 3),
                             np.array([size[0] + margin, size[1] + margin, size[2] + margin]))
        _, cpu = timed(sim.advance, args.t_end, 10**7)
        x, stress, rho = np.asarray(sim.position), np.asarray(sim.stress), np.asarray(sim.density)
        away = args.away  # share of the bed's length and breadth left out at each wall
        central = np.all((x[:, :2] > away * np.array(size[:2])) & (x[:, :2] < (1 - away) * np.array(size[:2])), axis=1)
        rows = np.round(x[:, 2] / dx - 0.5).astype(int)
        profile = []
        for row in range(rows.max() + 1):  # the weight above each row's centre per unit area, from the masses
            layer, above = central & (rows == row), central & (rows > row)
            weight = (rho[above].sum() + 0.5 * rho[layer].sum()) * dx**3 * GRAVITY / (layer.sum() * dx**2)
            profile.append({"depth": size[2] - (row + 0.5) * dx, "sigma_zz_over_weight": float(-stress[layer, 2, 2].mean() / weight),
                            "k_x": float(stress[layer, 0, 0].mean() / stress[layer, 2, 2].mean()),
                            "k_y": float(stress[layer, 1, 1].mean() / stress[layer, 2, 2].mean())})
        inside = central & (x[:, 2] < size[2] - 2 * dx)
        k = [float(stress[inside, a, a].sum() / stress[inside, 2, 2].sum()) for a in (0, 1)]
        below_top = [p for p in profile if p["depth"] > dx]  # all rows but the surface row
        worst = max(abs(p["sigma_zz_over_weight"] - 1.0) for p in below_top)  # the surface row: half a spacing above it
        result = {"material": name, "k0": earth_pressure_at_rest(material), "k_x": k[0], "k_y": k[1],
                  "largest_weight_error": worst,
                  "surface_row_weight_error": profile[-1]["sigma_zz_over_weight"] - 1.0, "grains": len(rho), "mean_speed": float(np.linalg.norm(sim.velocity, axis=1).mean()),
                  "leaked": sim.penetrated_particles, "cpu_seconds": cpu, "rows": profile}
        results.append(result)
        print(json.dumps({k_: v for k_, v in result.items() if k_ != "rows"}), flush=True)
        depth = 1e3 * np.array([p["depth"] for p in profile])
        axes[0].plot([p["sigma_zz_over_weight"] for p in profile], depth, "o-", label=name)
        axes[1].plot([p["k_x"] for p in below_top], 1e3 * np.array([p["depth"] for p in below_top]), "o-",
                     label=f"{name}, x")
        axes[1].plot([p["k_y"] for p in below_top], 1e3 * np.array([p["depth"] for p in below_top]), "s--",
                     label=f"{name}, y")
        axes[1].axvline(earth_pressure_at_rest(material), color="0.5", lw=0.8)
    for limit in (0.97, 1.03):
        axes[0].axvline(limit, color="0.5", lw=0.8, ls=":")
    axes[0].set_xlabel("−σ_zz / weight above")
    axes[1].set_xlabel("K = σ_xx/σ_zz, σ_yy/σ_zz (Jáky's K0 grey)")
    for a in axes:
        a.set_ylabel("depth (mm)")
        a.invert_yaxis()
        a.legend(fontsize=7)
    path = write("bed", {"size": list(args.size), "spacing": args.spacing, "t_end": args.t_end, "away": args.away,
                         "rows": results})
    fig.savefig(png, dpi=120)
    print(path, png)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("check", choices=("leg", "plate", "side-flow", "bed"))
    parser.add_argument("--leg", default="c-leg")
    parser.add_argument("--omega", type=float, default=0.8)
    parser.add_argument("--settle", type=float, default=0.3)
    parser.add_argument("--bed-depth", type=float, default=0.08)
    parser.add_argument("--resolution", default="coarse")
    parser.add_argument("--fidelity", default="standard")
    parser.add_argument("--spacing", type=float, default=None, help="plate: 0.005 m, bed: 0.004 m")
    parser.add_argument("--bed-breadth", type=float, default=0.0508)
    parser.add_argument("--breadths", type=float, nargs="+", default=[0.0508, 0.0254, 0.015])
    parser.add_argument("--size", type=float, nargs=3, default=[0.064, 0.064, 0.048])
    parser.add_argument("--t-end", type=float, default=0.2)
    parser.add_argument("--away", type=float, default=0.2)
    parser.add_argument("--planar-spacings", type=float, nargs="*", default=[0.004, 0.0025],
                        help="plate: the planar scene also at these spacings (its resolution error)")
    parser.add_argument("--max-depth", type=float, default=0.04, help="plate, side-flow: the stroke's depth (m)")
    parser.add_argument("--run-dir", type=Path, default=None, help="leg: write the slab's run file here")
    parser.add_argument("--resume", action="store_true",
                        help="leg: continue the slab run in --run-dir from its checkpoint (bitwise)")
    parser.add_argument("--slab-numerics", type=numerics_pair, nargs="*", default=[], metavar="NAME=VALUE",
                        help="leg: numerics overrides of the 3D slab only (e.g. h_factor=1.2 neighbour_skin=0.02), "
                             "written to slab_3d_leg_<NAME>_<VALUE>....json")
    parser.add_argument("--progress", action="store_true")
    args = parser.parse_args()
    if args.resume and (args.check != "leg" or args.run_dir is None):
        parser.error("argument --resume: allowed only with 'leg' and --run-dir (the run to continue)")
    if args.spacing is None:
        args.spacing = 0.004 if args.check == "bed" else 0.005
    {"leg": leg, "plate": plate, "side-flow": side_flow, "bed": bed}[args.check](args)


if __name__ == "__main__":
    main()
