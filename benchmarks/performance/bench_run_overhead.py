"""What a ``terrasph run`` costs besides its steps: stepping against the run's total wall, for one or
two terrasph packages (A/B, interleaved), in one run on one machine.

    python benchmarks/performance/bench_run_overhead.py [--a-path DIR_A --a-label NAME] [--b-path DIR_B \\
        --b-label NAME] [--rounds 6] [--json benchmarks/results/run_overhead.json] \\
        [-- run leg-wheel --terrain rft --t-end 22]

Each run is its own process (the command after ``--``, default the leg-wheel on RFT of issue 46, with
``--out`` a scratch file and ``--no-progress``) that times, inside the package it imports:

* ``stepping``: the wall inside the stepper's ``advance`` calls (the physics, the coupling and the
  controller), summed over the run;
* the parts of the loop that are output: ``samples`` (the recorders' rows of the series),
  ``frames_write`` and ``series_write`` (their writes into the file), ``checkpoint`` and
  ``sidecars`` (the XDMF files, :func:`terrasph.io.write_xdmf`, and the wait for the child that
  makes their views while the run steps, :mod:`terrasph.sidecar_views`, where the package has one);
* ``loop``: the run loop (:meth:`terrasph.run_loop.RunLoop.run`), from its first frame to its file
  closed and its XDMF sidecars written: the stepping plus the frames, the series' samples and their
  writes, the checkpoint and the sidecars;
* ``build``: from the command's start (``terrasph.cli.main``) to the loop's: the arguments, the
  checks and the scene's build; ``after``: from the loop's end to the command's, the scene's results
  into the file and its figure (``figure``: the figure's ``savefig``, the drawing, within it);
* ``total``: what the user waits for once Python and the package are imported, the command from its
  start to its end: ``build`` + ``loop`` + ``after``;
* ``imports``: the package and what its command line imports before any work (``matplotlib``, which
  the figure needs, within it), and ``command``: the process's whole wall as the parent sees it
  (the interpreter's start is the rest);
* the same in CPU time, which other processes on a busy machine do not stretch: ``stepping_cpu`` and
  ``total_cpu``, the run's own thread's, and ``helpers_cpu``, its child processes' (the sidecars'
  helper), with the ratios ``cpu_total_over_stepping`` (the run's thread alone) and
  ``work_over_stepping`` (its helpers' CPU added: the work the run costs, whatever runs alongside).

It prints each run and, per side, the medians and the ratios ``loop / stepping`` and
``total / stepping`` (issue 46: a run's total within 2x its stepping); with two sides A B B A …
alternate. ``--json`` writes them, ``total_over_stepping`` of each side on top, with the machine, the
date and the commit. Absolute times move with the machine's load; the ratios, measured within one
process, and the A/B comparison, interleaved, are what to compare.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DEFAULT_COMMAND = ["run", "leg-wheel", "--terrain", "rft", "--t-end", "22"]

#: the child: wraps the run loop and its stepper's advance with wall clocks, runs the CLI, writes the times
_CHILD = r"""
import json, sys, time
started = time.perf_counter()
import matplotlib.figure, matplotlib.backends.backend_agg
matplotlib_import = time.perf_counter() - started
import terrasph.io as io
import terrasph.run_loop as run_loop
from terrasph.cli import build_parser, main
build_parser()  # the modules the command line imports (its scenes), as main's own call would

times = {"stepping": 0.0, "stepping_cpu": 0.0, "loop": 0.0, "loop_start": None, "loop_end": None, "frames_write": 0.0,
         "series_write": 0.0, "samples": 0.0, "checkpoint": 0.0, "sidecars": 0.0, "figure": 0.0,
         "matplotlib_import": matplotlib_import}


def timed(function, key):
    def call(*args, **kwargs):
        started, cpu = time.perf_counter(), time.thread_time()
        try:
            return function(*args, **kwargs)
        finally:
            times[key] += time.perf_counter() - started
            if key == "stepping":
                times["stepping_cpu"] += time.thread_time() - cpu
    return call


class Timed:
    def __init__(self, inner, **keys):
        self._inner = inner
        for name, key in keys.items():
            setattr(self, name, timed(getattr(inner, name), key))

    def __getattr__(self, name):
        return getattr(self._inner, name)


original_run = run_loop.RunLoop.run


def timed_run(self, *args, **kwargs):
    stepper, recorders = self.stepper, self.recorders
    self.stepper = Timed(stepper, advance="stepping", checkpoint="checkpoint")
    self.recorders = [Timed(recorder, rows="samples") for recorder in recorders]
    started = time.perf_counter()
    if times["loop_start"] is None:
        times["loop_start"] = started
    try:
        return original_run(self, *args, **kwargs)
    finally:
        times["loop_end"] = time.perf_counter()
        times["loop"] += times["loop_end"] - started
        self.stepper, self.recorders = stepper, recorders


run_loop.RunLoop.run = timed_run
# the frames' writes: write_frames where the package has it (write_frame calls it), else write_frame
frames_method = "write_frames" if hasattr(io.RunWriter, "write_frames") else "write_frame"
setattr(io.RunWriter, frames_method, timed(getattr(io.RunWriter, frames_method), "frames_write"))
io.RunWriter.append_series_rows = timed(io.RunWriter.append_series_rows, "series_write")
io.write_xdmf = timed(io.write_xdmf, "sidecars")
try:  # the wait for the helper that makes the sidecars' views while the run steps, where the package has one
    import terrasph.sidecar_views as sidecar_views
    sidecar_views.SidecarViews.finish = timed(sidecar_views.SidecarViews.finish, "sidecars")
except ImportError:
    pass
matplotlib.figure.Figure.savefig = timed(matplotlib.figure.Figure.savefig, "figure")
times["imports"] = time.perf_counter() - started
import resource
children = resource.getrusage(resource.RUSAGE_CHILDREN)
command_start, command_cpu = time.perf_counter(), time.thread_time()
status = main(sys.argv[2:])
command_end = time.perf_counter()
times["total"] = command_end - command_start
times["total_cpu"] = time.thread_time() - command_cpu
ended = resource.getrusage(resource.RUSAGE_CHILDREN)
times["helpers_cpu"] = (ended.ru_utime + ended.ru_stime) - (children.ru_utime + children.ru_stime)
times["build"] = times.pop("loop_start") - command_start
times["after"] = command_end - times.pop("loop_end")
with open(sys.argv[1], "w") as out:
    json.dump(times, out)
sys.exit(status)
"""

#: the parts of a run each run reports, in seconds
PARTS = ("stepping", "samples", "frames_write", "series_write", "checkpoint", "sidecars", "loop", "build", "after",
         "figure", "total", "matplotlib_import", "imports", "command", "stepping_cpu", "total_cpu", "helpers_cpu")


def run_side(path: str, command: list[str], out: Path) -> dict[str, float]:
    """The times of one run of `command` with the terrasph package in `path` ("" the installed one)."""
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = path
    else:
        env.pop("PYTHONPATH", None)
    times_file = out.with_suffix(".times.json")
    argv = [sys.executable, "-c", _CHILD, str(times_file), *command, "--out", str(out), "--force", "--no-progress"]
    started = time.perf_counter()
    done = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    command_wall = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"run failed ({done.returncode}): {' '.join(argv[3:])}\n{done.stderr[-2000:]}")
    times = json.loads(times_file.read_text())
    return {**times, "command": command_wall,
            "loop_over_stepping": times["loop"] / times["stepping"],
            "total_over_stepping": times["total"] / times["stepping"],
            "cpu_total_over_stepping": times["total_cpu"] / times["stepping_cpu"],
            "work_over_stepping": (times["total_cpu"] + times["helpers_cpu"]) / times["stepping_cpu"]}


def commit() -> str:
    """The commit of the repository this file is in (with ``-dirty`` if it has changes)."""
    here = Path(__file__).parent
    head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=here, check=False)
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True,
                           cwd=here, check=False)
    return head.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--a-path", default=None, help="folder holding the terrasph package of side A "
                        "(default: PYTHONPATH's)")
    parser.add_argument("--b-path", default=None, help="folder holding side B's (default: no side B)")
    parser.add_argument("--a-label", default="A", help="what side A is, for the result file (not its path)")
    parser.add_argument("--b-label", default="B", help="what side B is")
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--json", type=Path, help="also write the runs and their medians to this file")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args()
    command = (args.command[1:] if args.command[:1] == ["--"] else args.command) or DEFAULT_COMMAND
    a_path = os.environ.get("PYTHONPATH", "") if args.a_path is None else args.a_path
    sides = {"A": a_path, **({"B": args.b_path} if args.b_path is not None else {})}
    runs: list[dict] = []
    with tempfile.TemporaryDirectory() as scratch:
        for index in range(args.rounds):
            order = list(sides) if index % 2 == 0 else list(reversed(sides))
            for side in order:
                times = run_side(sides[side], command, Path(scratch) / f"{side}{index}.h5")
                runs.append({"round": index + 1, "side": side, **times})
                print(f"round {index + 1} {side}: stepping {times['stepping']:.3f} s, loop {times['loop']:.3f} s, "
                      f"total {times['total']:.3f} s, command {times['command']:.2f} s: "
                      f"loop/stepping {times['loop_over_stepping']:.2f}, "
                      f"total/stepping {times['total_over_stepping']:.2f} (CPU {times['cpu_total_over_stepping']:.2f}, "
                      f"with helpers {times['work_over_stepping']:.2f})", flush=True)
    medians = {side: {key: statistics.median(run[key] for run in runs if run["side"] == side)
                      for key in (*PARTS, "loop_over_stepping", "total_over_stepping", "cpu_total_over_stepping",
                                  "work_over_stepping")} for side in sides}
    for side, values in medians.items():
        print(f"median {side}: " + ", ".join(f"{key} {value:.3f}" for key, value in values.items()))
    if "B" in medians:
        print(f"A/B command wall {medians['A']['command'] / medians['B']['command']:.2f}, "
              f"loop {medians['A']['loop'] / medians['B']['loop']:.2f}")
    if args.json:
        args.json.write_text(json.dumps({
            "command": ["terrasph", *command], "sides": {"A": args.a_label, **({"B": args.b_label} if "B" in sides else {})},
            "total_over_stepping": {side: values["total_over_stepping"] for side, values in medians.items()},
            "runs": runs, "medians": medians,
            "provenance": {
                "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                "commit": commit(), "cpu": platform.processor() or platform.machine(), "host": platform.node(),
                "cpus": os.cpu_count(), "load_average": os.getloadavg(),
                "threads": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OMP_WAIT_POLICY")},
                "benchmark": "benchmarks/performance/bench_run_overhead.py --a-path A --b-path B --rounds "
                             f"{args.rounds} --json {args.json.name}"}},
            indent=1) + "\n")


if __name__ == "__main__":
    main()
