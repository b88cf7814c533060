"""Error against run time of the column collapse (wet and Drucker–Prager columns).

Runs the collapse at several resolutions, each until at rest, and prints a table of interior
particles, Δx, steps, wall time, CPU time of this process, L*, H* and their change against the
finest (last) run; writes the table as JSON, with the date, commit, CPU, thread count and command
that measured it (``provenance``; the manual's tables are rendered from it), and a plot of the
changes against CPU time.

    python benchmarks/validation/bench_column_convergence.py [--levels coarse fit fine finer] [--threads 2]
    python benchmarks/validation/bench_column_convergence.py --water-content 0.005 --levels 0.005 coarse fit fine \\
        --threads 1 --name column_wet
    python benchmarks/validation/bench_column_convergence.py --model drucker_prager --levels 0.005 coarse fit fine \\
        --threads 1 --name column_drucker_prager

A level is a key of ``ColumnCollapse``'s RESOLUTIONS or a spacing Δx in m. CPU time is the cost
figure on a shared machine (run with OMP_WAIT_POLICY=passive and one thread: it moves much less
with other processes' load than wall time).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import terrasph
from terrasph import _core
from terrasph.plotting import plot_convergence
from terrasph.scenes import RESOLUTIONS, ColumnCollapse, run_column_collapse


def column_config(level: str, args: argparse.Namespace) -> ColumnCollapse:
    """The collapse of one level: a resolution key or a spacing in m."""
    size = {"resolution": level} if level in RESOLUTIONS else {"spacing": float(level)}
    return ColumnCollapse(t_end=args.t_end, water_content=args.water_content, model=args.model, **size)


def provenance(threads: int) -> dict[str, str | int]:
    """When, on what and by which command the results were measured (no host name)."""
    root = Path(__file__).resolve().parents[2]
    git = ["git", "-C", str(root)]
    commit = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run([*git, "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                           text=True).stdout.strip()
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() \
        else platform.processor()
    return {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d"),
            "commit": commit + ("+changes" if dirty else ""), "terrasph": terrasph.__version__,
            "cpu": cpu, "cores": os.cpu_count() or 0, "threads": threads,
            "command": " ".join(["python", "benchmarks/validation/bench_column_convergence.py", *_arguments()])}


def _arguments() -> list[str]:
    """This run's arguments without ``--out DIR`` (where the file went is no property of the result)."""
    args, kept = sys.argv[1:], []
    skip = False
    for arg in args:
        if skip or arg.startswith("--out="):
            skip = False
            continue
        if arg == "--out":
            skip = True
            continue
        kept.append(arg)
    return kept


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--levels", nargs="+", default=["coarse", "fit", "fine", "finer"],
                        help="resolution keys or spacings (m), coarsest first; the last is the reference")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--water-content", type=float, default=0.0, help="w of the wet material (0 = dry)")
    parser.add_argument("--model", default=ColumnCollapse().model, help="material.model of the column")
    parser.add_argument("--name", default="column", help="prefix of the result files")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "results")
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for level in args.levels:
        cpu = time.process_time()
        result = run_column_collapse(column_config(level, args), output=None, progress=False, plot=False)
        row = {"level": level, **result.summary(), "cpu_time": time.process_time() - cpu}
        rows.append(row)
        np.save(args.out / f"{args.name}_final_{level}.npy", result.final_position)
        print(json.dumps(row), flush=True)
    finest = rows[-1]
    for row in rows:
        row["runout_change"] = abs(row["runout_normalised"] - finest["runout_normalised"]) / finest["runout_normalised"]
        row["height_change"] = abs(row["final_height_normalised"] - finest["final_height_normalised"]) / finest["final_height_normalised"]
    print(f"\n{args.name}: water content {args.water_content}, model {args.model}, {args.threads} thread(s)")
    print("| level | particles | Δx (mm) | steps | run until (s) | wall time (s) | CPU time (s) | L* | H* "
          "| ΔL* vs finest | ΔH* vs finest | status |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['level']} | {r['granular_particles']} | {1e3 * r['spacing']:.2f} | {r['steps']} | {r['time']:.2f} | "
              f"{r['wall_time']:.1f} | {r['cpu_time']:.1f} | {r['runout_normalised']:.3f} | "
              f"{r['final_height_normalised']:.3f} | {100 * r['runout_change']:.1f}% | {100 * r['height_change']:.1f}% | "
              f"{r['status']} |")
    result = {"provenance": provenance(args.threads), "rows": rows}
    (args.out / f"{args.name}_convergence.json").write_text(json.dumps(result, indent=2) + "\n")
    if len(rows) < 2:
        return  # nothing to plot against the finest
    plot_rows = [{"CPU time (s)": r["cpu_time"], "relative change of L* vs finest": r["runout_change"],
                  "relative change of H* vs finest": r["height_change"]} for r in rows[:-1]]
    plot_convergence(plot_rows, "CPU time (s)",
                     ["relative change of L* vs finest", "relative change of H* vs finest"],
                     path=args.out / f"{args.name}_convergence.png")


if __name__ == "__main__":
    main()
