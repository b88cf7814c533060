"""Interleaved A/B of one ``terrasph run`` command line between two terrasph packages, in one run on
one machine: wall time of the whole command and the summary it prints.

    python benchmarks/performance/bench_cli_ab.py --a-path DIR_A --b-path DIR_B [--rounds 2] \\
        [--a-args "..."] [--b-args "..."] -- run leg-wheel --spacing 0.002 ... --t-end 1.2

DIR_A and DIR_B are folders that each hold an importable ``terrasph`` package (put first on
PYTHONPATH; an empty string means the installed one). The command after ``--`` runs on both sides,
each with its own extra arguments (e.g. ``--b-args "--fidelity reference"``), A B B A within each
pair of rounds, each in its own process writing a scratch file. Prints every run's wall seconds
and summary figures, the median wall time of each side and the ratio A/B; ``--json PATH`` writes
them too, with the machine, the date, the commit and the OpenMP environment both sides ran with
(set ``OMP_WAIT_POLICY=passive`` for both: a side whose threads spin idles the other's).
``--fresh-cache`` gives each run an empty settled-state cache (``TERRASPH_CACHE_DIR`` in the scratch
directory), so that every run settles its bed itself: else the first run of each side fills the
cache and the later ones start from it, and the rounds time different work. Absolute times move
with the machine's load: compare only the ratio, measured side by side.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run_side(path: str, command: list[str], extra: list[str], out: Path, fresh_cache: bool) -> tuple[float, dict]:
    """Wall seconds and the printed summary (the last JSON object on stdout) of one run."""
    env = dict(os.environ)
    if fresh_cache:
        env["TERRASPH_CACHE_DIR"] = str(out.with_suffix(".cache"))
    if path:
        env["PYTHONPATH"] = path
    else:
        env.pop("PYTHONPATH", None)
    argv = [sys.executable, "-c", "import sys; from terrasph.cli import main; sys.exit(main())",
            *command, *extra, "--out", str(out), "--no-progress"]
    started = time.perf_counter()
    done = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"run failed ({done.returncode}): {' '.join(argv)}\n{done.stderr[-2000:]}")
    text = done.stdout
    start = text.find("{")
    summary = json.loads(text[start:text.rfind("}") + 1]) if start >= 0 else {}
    return wall, summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--a-path", default="")
    parser.add_argument("--b-path", default="")
    parser.add_argument("--a-args", default="")
    parser.add_argument("--b-args", default="")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--keys", nargs="*", default=["travel", "mean_slip", "mean_sinkage", "peak_lift", "peak_thrust",
                                                      "runout", "L_star", "H_star"])
    parser.add_argument("--json", type=Path, help="also write the runs and the ratio to this file")
    parser.add_argument("--fresh-cache", action="store_true", help="an empty settled-state cache for every run")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    sides = {"A": (args.a_path, shlex.split(args.a_args)), "B": (args.b_path, shlex.split(args.b_args))}
    walls: dict[str, list[float]] = {"A": [], "B": []}
    runs = []
    with tempfile.TemporaryDirectory() as scratch:
        for index in range(args.rounds):
            order = ("A", "B") if index % 2 == 0 else ("B", "A")
            for side in order:
                path, extra = sides[side]
                wall, summary = run_side(path, command, extra, Path(scratch) / f"{side}{index}.h5", args.fresh_cache)
                walls[side].append(wall)
                runs.append({"round": index + 1, "side": side, "wall": wall, "summary": summary})
                figures = {key: summary[key] for key in args.keys if key in summary}
                print(f"round {index + 1} {side}: {wall:.1f} s  {json.dumps(figures)}", flush=True)
    a, b = statistics.median(walls["A"]), statistics.median(walls["B"])
    print(f"median wall A {a:.1f} s, B {b:.1f} s: A/B = {a / b:.2f}")
    if args.json:
        args.json.write_text(json.dumps({
            "command": command, "a_path": args.a_path, "b_path": args.b_path, "a_args": args.a_args,
            "b_args": args.b_args, "fresh_cache": args.fresh_cache, "runs": runs, "median_wall_a": a, "median_wall_b": b, "ratio_a_over_b": a / b,
            "environment": {k: os.environ.get(k) for k in ("OMP_WAIT_POLICY", "OMP_NUM_THREADS", "OMP_PROC_BIND")},
            "machine": {"host": platform.node(), "cpus": os.cpu_count(), "load_average": os.getloadavg()},
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                                     cwd=Path(__file__).parent, check=False).stdout.strip()}, indent=1) + "\n")


if __name__ == "__main__":
    main()
