"""How far the bed's stiffness can come down: the EOS's κ (``material.bulk_stiffness``) scaled by a
factor f, with it c0 (Eq. 2.44, ∝ √κ), the bulk modulus K = κγ and the shear modulus G (derived
from K) — every wave ∝ √f, the step ∝ 1/√f — against the outcomes users read, each compared with
the ``reference`` tier at f = 1.

    OMP_NUM_THREADS=1 python benchmarks/studies/stiffness_scan.py [--factors 1 0.5 0.25 0.125 0.0625] \
        [--cases leg-wheel column bed] [--out benchmarks/results/stiffness_scan.json]

Cases (each at f = 1 and the reference tier, then at each factor at the standard tier; with
``--c0-at-wave`` also at f = 1 with c0 alone lowered to the elastic P-wave speed, which then sets the
step):

* ``leg-wheel``: the README's main command (reversed C-leg, ω = 1.5 rad/s, 4.9 N, Δx = 2 mm, 30 ×
  7 cm bed, 0.2 s pause) to 2.5 s: mean slip, mean sinkage, mean forward speed, final sinkage and the
  wheel's peak loads (the largest sampled |F_x| and F_z after the pause);
* ``column``: the column collapse at the ``fine`` resolution (2 310 grains; the coarse column's front
  jumps by a cell) with aspect 8/7 on the flat rough floor, to rest: runout L*, height H*;
* ``bed``: the 12 × 5 cm geostatic bed of tests/test_geostatic.py after 0.2 s: K = σxx/σzz, the
  largest |−σzz/weight − 1| over the rows, the mean speed.

Every run is written into the JSON as it finishes (a rerun skips the runs there, so the scan can be
stopped and continued); each row holds the outcomes, the steps, the CPU time and the relative
difference of every outcome from the case's reference run. The file carries the machine, the date
and the commit.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import math
import os
import platform
import subprocess
import time
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.scenes.column_collapse import ColumnCollapse, run_column_collapse
from terrasph.scenes.leg_wheel import LegWheel, run_leg_wheel
from terrasph.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "benchmarks" / "results" / "stiffness_scan.json"
#: the README's main command, to 2.5 s (docs/fidelity.md (b))
README_LEG_WHEEL = {"wheel": "reversed-c-leg", "omega": 1.5, "load": 4.9, "spacing": 0.002, "thickness": 0.006,
                    "leg_length": 0.04, "bed_width": 0.3, "bed_depth": 0.07, "start_x": 0.08, "settle_time": 0.2,
                    "t_end": 2.5}


def scaled(material: Material, factor: float) -> Material:
    """`material` with κ × `factor` (c0, K and G follow it: Eq. 2.44, K = κγ, G from K and ν)."""
    return dataclasses.replace(material, bulk_stiffness=material.bulk_stiffness * factor)


@dataclasses.dataclass(frozen=True)
class ScaledLegWheel(LegWheel):
    """The leg-wheel with its bed's κ scaled by `stiffness_factor`."""

    SCENE: ClassVar[str] = "leg-wheel"
    stiffness_factor: float = 1.0

    def material(self) -> Material:
        return scaled(super().material(), self.stiffness_factor)


@dataclasses.dataclass(frozen=True)
class ScaledColumn(ColumnCollapse):
    """The column collapse with its material's κ scaled by `stiffness_factor`."""

    stiffness_factor: float = 1.0

    def material(self) -> Material:
        return scaled(super().material(), self.stiffness_factor)


def leg_wheel(tier: str, factor: float, c0_at_wave: bool) -> dict[str, Any]:
    config = ScaledLegWheel(**README_LEG_WHEEL, fidelity=tier, stiffness_factor=factor)
    if c0_at_wave:
        config = dataclasses.replace(config, numerics={"sound_speed": wave_speed(config.material())})
    result = run_leg_wheel(config, plot=False)
    wheel = result.series["robot/wheel"]
    driven = wheel["time"] > config.settle_time
    values = {key: result.values[key] for key in ("mean_slip", "mean_sinkage", "mean_forward_speed", "final_sinkage")}
    values["peak_force_x"] = float(np.max(np.abs(wheel["force"][driven, 0])))
    values["peak_force_z"] = float(np.max(wheel["force"][driven, 1]))
    values["leaked_particles"] = result.values["leaked_particles"]
    return {"values": values, "steps": result.values["steps"]}


def column(tier: str, factor: float, c0_at_wave: bool) -> dict[str, Any]:
    config = ScaledColumn(resolution="fine", fidelity=tier, stiffness_factor=factor)
    if c0_at_wave:
        config = dataclasses.replace(config, numerics={"sound_speed": wave_speed(config.material())})
    result = run_column_collapse(config, progress=False, plot=False)
    return {"values": {"runout_normalised": result.runout_normalised,
                       "final_height_normalised": result.final_height_normalised}, "steps": result.run.steps}


BED_DX, BED_WIDTH, BED_HEIGHT, G = 0.005, 0.12, 0.05, 9.81


def bed(tier: str, factor: float, c0_at_wave: bool) -> dict[str, Any]:
    """The geostatic bed of tests/test_geostatic.py (its C at the tier's: reference 0.25, else 0.5)."""
    scene = Scene(spacing=BED_DX)
    scene.add_block(0.0, 0.0, BED_WIDTH, BED_HEIGHT)
    scene.add_wall("box", [(0.0, 0.08), (0.0, 0.0), (BED_WIDTH, 0.0), (BED_WIDTH, 0.08)],
                   layers=wall_layers_needed(1.3))
    material = scaled(Material(), factor)
    numerics = Numerics(spacing=BED_DX, cfl=0.25 if tier == "reference" else 0.5,
                        sound_speed=wave_speed(material) if c0_at_wave else 0.0)
    sim = Simulation(scene, material, numerics)
    sim.advance(0.2)
    x, stress, density = sim.position, sim.stress, sim.density
    central = (x[:, 0] > 0.15 * BED_WIDTH) & (x[:, 0] < 0.85 * BED_WIDTH)
    inside = central & (x[:, 1] < BED_HEIGHT - 2 * BED_DX)
    k = float(stress[inside, 0, 0].sum() / stress[inside, 1, 1].sum())
    rows = np.round(x[:, 1] / BED_DX - 0.5).astype(int)
    ratios = []
    for row in range(rows.max()):
        weight = (density[rows > row].sum() + 0.5 * density[rows == row].sum()) * BED_DX * BED_DX * G / BED_WIDTH
        ratios.append(-stress[central & (rows == row), 1, 1].mean() / weight)
    return {"values": {"k_ratio": k, "weight_error": float(np.max(np.abs(np.array(ratios) - 1.0))),
                       "mean_speed": float(np.linalg.norm(sim.velocity, axis=1).mean())}, "steps": sim.step_count}


CASES = {"leg-wheel": leg_wheel, "column": column, "bed": bed}


def wave_speed(material: Material) -> float:
    """The hypoelastic bed's P-wave speed √((K + 4G/3)/ρ0) (m/s; cpp/include/terrasph/constitutive.hpp),
    K = κγ(1 + w), G = 3K(1 − 2ν)/(2(1 + ν)) with ν = 0.3 unless the material gives G."""
    bulk = material.bulk_stiffness * material.eos_exponent * (1.0 + material.water_content)
    shear = material.shear_modulus or 3.0 * bulk * (1.0 - 2.0 * 0.3) / (2.0 * (1.0 + 0.3))
    return math.sqrt((bulk + 4.0 / 3.0 * shear) / material.reference_density)


def machine() -> dict[str, Any]:
    git = ["git", "-C", str(ROOT)]
    commit = subprocess.run([*git, "rev-parse", "HEAD"], capture_output=True, text=True, check=False).stdout.strip()
    dirty = bool(subprocess.run([*git, "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True,
                                check=False).stdout.strip())
    return {"host": platform.node(), "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(), "threads": os.environ.get("OMP_NUM_THREADS", "default"),
            "python": platform.python_version(), "commit": commit + ("+dirty" if dirty else "")}


def relative(values: dict[str, float], reference: dict[str, float]) -> dict[str, float]:
    """Each outcome's relative difference from the reference's (absolute for a count or a zero reference)."""
    out = {}
    for key, value in values.items():
        ref = reference.get(key)
        if ref is None or key == "leaked_particles":
            continue
        out[key] = float(value / ref - 1.0) if ref != 0 and math.isfinite(ref) else float(value - ref)
    return out


#: what the table shows of each case: (outcome, label)
SHOWN = {"leg-wheel": [("mean_slip", "slip"), ("mean_sinkage", "sinkage"), ("mean_forward_speed", "v_x"),
                       ("peak_force_x", "peak F_x"), ("peak_force_z", "peak F_z")],
         "column": [("runout_normalised", "L*"), ("final_height_normalised", "H*")],
         "bed": [("k_ratio", "K")]}


def case_material(case: str, factor: float) -> Material:
    """The material of `case` with κ × `factor`."""
    if case == "leg-wheel":
        return ScaledLegWheel(**README_LEG_WHEEL, stiffness_factor=factor).material()
    if case == "column":
        return ScaledColumn(stiffness_factor=factor).material()
    return scaled(Material(), factor)


def signal_speed(material: Material, c0_at_wave: bool) -> float:
    """The step's signal speed c = max(c0, the P-wave) (m/s): c0 by Eq. 2.44, or the wave itself."""
    wave = wave_speed(material)
    if c0_at_wave:
        return wave
    rho_s, rho_0 = material.grain_density, material.reference_density
    c0 = math.sqrt(material.bulk_stiffness * material.eos_exponent * rho_s / (rho_0 * (rho_s - rho_0)))
    return max(c0, wave)


def table(data: dict[str, Any]) -> str:
    """Markdown: one row per run, each outcome's difference from the case's reference (%) and the steps
    against the reference's; the bed's largest −σzz/weight − 1 over its rows as a value."""
    lines = ["| case | run | c = max(c0, wave) (m/s) | steps / reference's | differences from reference |",
             "|---|---|---|---|---|"]
    for name, run in sorted(data["runs"].items(), key=lambda item: (item[1]["case"], item[1]["tier"] != "reference",
                                                                    item[1].get("c0_at_wave", False),
                                                                    -item[1]["factor"])):
        shown = [f"{label} {100 * run.get('relative_to_reference', {}).get(key, math.nan):+.1f} %"
                 for key, label in SHOWN[run["case"]]]
        if run["case"] == "bed":
            shown.append(f"−σzz/weight off by up to {100 * run['values']['weight_error']:.1f} %")
        c = signal_speed(case_material(run["case"], run["factor"]), run.get("c0_at_wave", False))
        lines.append(f"| {run['case']} | {name.split(' ', 1)[1]} | {c:.1f} | "
                     f"1/{1 / run.get('steps_over_reference', math.nan):.2f} | {', '.join(shown)} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--factors", type=float, nargs="+", default=[1.0, 0.5, 0.25, 0.125, 0.0625])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--c0-at-wave", action="store_true",
                        help="also each case at f = 1 with c0 (numerics.sound_speed) lowered to the elastic wave speed")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--table", action="store_true", help="only print the table of the runs in --out")
    args = parser.parse_args()
    if args.table:
        print(table(json.loads(args.out.read_text())))
        return
    data = json.loads(args.out.read_text()) if args.out.is_file() else {}
    data.setdefault("runs", {})
    for case in args.cases:
        runs = [("reference", 1.0, False)] + [("standard", f, False) for f in args.factors]
        for tier, factor, c0_at_wave in runs + ([("standard", 1.0, True)] if args.c0_at_wave else []):
            name = f"{case} {tier} f={factor:g}" + (" c0=wave" if c0_at_wave else "")
            if name in data["runs"]:
                continue
            cpu = time.process_time()
            row = CASES[case](tier, factor, c0_at_wave)
            row.update(case=case, tier=tier, factor=factor, c0_at_wave=c0_at_wave, cpu_time=time.process_time() - cpu)
            data["runs"][name] = row
            reference = data["runs"].get(f"{case} reference f=1")
            for run in data["runs"].values():
                if reference and run["case"] == case:
                    run["relative_to_reference"] = relative(run["values"], reference["values"])
                    run["steps_over_reference"] = run["steps"] / reference["steps"]
            now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
            data.update(machine=machine(), date=now,
                        command="OMP_NUM_THREADS=1 python benchmarks/studies/stiffness_scan.py "
                                f"--factors {' '.join(f'{f:g}' for f in args.factors)} --cases {' '.join(args.cases)}"
                        + (" --c0-at-wave" if args.c0_at_wave else ""))
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
            print(f"{name}: {row['steps']} steps, {row['cpu_time']:.0f} s CPU, {row['values']} "
                  f"{row.get('relative_to_reference', {})}", flush=True)


if __name__ == "__main__":
    main()
