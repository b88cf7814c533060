"""Error against run time for the dry column collapse (issue 2).

Runs the collapse at several resolutions, each until at rest, and prints a table of interior
particles, steps, wall time, L*, H* and their change against the finest run; writes the table as
JSON and a plot.

    python benchmarks/bench_column_convergence.py [--levels coarse fit fine finer] [--threads 2]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from terrasph import _core
from terrasph.plotting import plot_convergence
from terrasph.scenes import ColumnCollapse, run_column_collapse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--levels", nargs="+", default=["coarse", "fit", "fine", "finer"])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    _core.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for level in args.levels:
        result = run_column_collapse(ColumnCollapse(resolution=level, t_end=args.t_end), output=None,
                                     progress=False, plot=False)
        row = {"level": level, **result.summary()}
        rows.append(row)
        np.save(args.out / f"column_final_{level}.npy", result.final_position)
        print(json.dumps(row), flush=True)
    finest = rows[-1]
    for row in rows:
        row["runout_change"] = abs(row["runout_normalised"] - finest["runout_normalised"]) / finest["runout_normalised"]
        row["height_change"] = abs(row["final_height_normalised"] - finest["final_height_normalised"]) / finest["final_height_normalised"]
    print("\n| level | particles | steps | wall time (s) | L* | H* | ΔL* vs finest | ΔH* vs finest | status |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['level']} | {r['granular_particles']} | {r['steps']} | {r['wall_time']:.1f} | "
              f"{r['runout_normalised']:.3f} | {r['final_height_normalised']:.3f} | {100 * r['runout_change']:.1f}% | "
              f"{100 * r['height_change']:.1f}% | {r['status']} |")
    (args.out / "column_convergence.json").write_text(json.dumps(rows, indent=2))
    plot_rows = [{"wall time (s)": r["wall_time"], "relative change of L* vs finest": r["runout_change"],
                  "relative change of H* vs finest": r["height_change"]} for r in rows[:-1]]
    plot_convergence(plot_rows, "wall time (s)",
                     ["relative change of L* vs finest", "relative change of H* vs finest"],
                     path=args.out / "column_convergence.png")


if __name__ == "__main__":
    main()
