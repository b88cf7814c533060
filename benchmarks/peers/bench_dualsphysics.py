"""Side by side with DualSPHysics: particle-steps per wall second and per CPU second.

    python benchmarks/peers/bench_dualsphysics.py --source DUALSPHYSICS_DIR [--sizes 20000 80000]
        [--threads 1 2] [--rounds 2] [--tmax 0.05] [--steps 200] [--work DIR] [--no-build]
        [--make-options COMPILE_CHRONO=NO ...] [--case-writer auto|gencase|own] [--numerics NAME=VALUE ...]

DUALSPHYSICS_DIR is a checkout of DualSPHysics' public source that the user fetched
(https://github.com/DualSPHysics/DualSPHysics); this script never downloads, copies or commits
it. It builds the CPU solver there (``make -f Makefile_cpu`` in src/source, unless --no-build),
then, for each size, generates the 2D dam break ``examples/main/01_DamBreak/CaseDambreakVal2D``
with only ``dp`` changed (the fluid column is 1 m × 2 m, so N ≈ 2/dp² fluid particles) with the
shipped GenCase, in a work folder outside the checkout. Where the checkout lacks GenCase (a
closed-source binary; a snapshot without large files has no GenCase, nor the Chrono library the
default build links), ``--case-writer own`` (the default when GenCase is absent) compiles
``benchmarks/peers/dsph_case.cpp`` against the checkout's own sources and writes the same case in the
solver's formats (see that file for what it reproduces of GenCase), and ``--make-options
COMPILE_CHRONO=NO COMPILE_WAVEGEN=NO COMPILE_MOORDYNPLUS=NO`` builds the solver without the
libraries the dam break does not use. Rounds alternate the order of the two
codes; each run is its own process:

* DualSPHysics: ``-cpu -ompthreads:N -sv:none -tmax:T``. Wall time is its own "Simulation
  Runtime" (the time loop); CPU time is the process's CPU time (getrusage of the child) less that
  of the same run with -tmax at one step's worth (setup and file loading), so it is the loop's.
* terrasph: ``bench_sph.py``'s bed (glass beads at rest in a box, Δx = 2 mm) of the same number
  of granular particles, stepped --steps steps after a warm-up; wall and CPU (process_time) of the
  stepping loop. ``--numerics`` sets terrasph options for the bed, e.g. ``cell_order=true
  symmetric_pairs=true`` (storage in cell order and each pair evaluated once, which change the
  results only by the order of the sums; DualSPHysics sorts its particles by cell every step).

Particle-steps count fluid (DualSPHysics) and granular (terrasph) particles, not walls. The
table gives the medians over rounds and the ratio terrasph / DualSPHysics of each figure. The two
codes solve different equations (weakly compressible water with one neighbour pass per step; μ(I)
granular flow with two): the ratio is throughput per particle-step, not time to an answer.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PERFORMANCE = HERE.parent / "performance"  # bench_sph: the bed and the NAME=VALUE parser
CASE = "CaseDambreakVal2D"
CASE_DIR = Path("examples/main/01_DamBreak")
FLUID_AREA = 2.0  # m², the 1 m × 2 m column of the case


def build_solver(source: Path, make_options: list[str]) -> Path:
    """Builds DualSPHysics' CPU solver in the user's checkout; returns the executable."""
    make_dir = source / "src" / "source"
    if not (make_dir / "Makefile_cpu").is_file():
        raise SystemExit(f"parameter '--source' = {source}: no src/source/Makefile_cpu (not a DualSPHysics checkout)")
    subprocess.run(["make", "-f", "Makefile_cpu", f"-j{os.cpu_count() or 1}", *make_options], cwd=make_dir,
                   check=True)
    return find_solver(source)


# The checkout's sources that dsph_case.cpp uses (its XML, case and particle-file classes).
CASE_WRITER_SOURCES = ("JXml", "tinystr", "tinyxml", "tinyxmlerror", "tinyxmlparser", "JCaseCtes", "JCaseParts",
                       "JCaseProperties", "JPartDataBi4", "JPartDataHead", "JBinaryData", "Functions", "JObject",
                       "JException", "JLinearValue", "JRangeFilter", "JReadDatafile", "FunGeo3d")


def build_case_writer(source: Path, work: Path) -> Path:
    """Compiles benchmarks/peers/dsph_case.cpp against the checkout's sources, in the work folder."""
    sources = source / "src" / "source"
    writer = work / "dsph_case"
    subprocess.run(["g++", "-std=c++11", "-O1", "-w", f"-I{sources}", str(HERE / "dsph_case.cpp"),
                    *(str(sources / f"{name}.cpp") for name in CASE_WRITER_SOURCES), "-o", str(writer)], check=True)
    return writer


def find_solver(source: Path) -> Path:
    found = sorted(glob.glob(str(source / "bin" / "linux" / "DualSPHysics*CPU_linux64")))
    if not found:
        raise SystemExit(f"no DualSPHysics*CPU_linux64 in {source / 'bin' / 'linux'}: build it (drop --no-build)")
    return Path(found[-1])


def spacing_for(particles: int) -> float:
    """dp giving about `particles` fluid particles in the 1 m × 2 m column (N ≈ 2/dp²)."""
    return math.sqrt(FLUID_AREA / particles)


def generate_case(source: Path, work: Path, dp: float, writer: Path | None) -> Path:
    """The case definition with only dp changed, run through GenCase (or `writer`, dsph_case.cpp);
    returns the case path stem."""
    text = (source / CASE_DIR / f"{CASE}_Def.xml").read_text()
    changed, count = re.subn(r'(<definition dp=")[^"]*(")', rf"\g<1>{dp:.8g}\g<2>", text, count=1)
    if count != 1:
        raise SystemExit(f"{CASE}_Def.xml: no <definition dp=...> to change")
    folder = work / f"dp{dp:.6g}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{CASE}_Def.xml").write_text(changed)
    if writer is not None:
        written = subprocess.run([str(writer), f"{CASE}_Def.xml", "out", CASE], cwd=folder, check=True,
                                 capture_output=True, text=True).stdout
        print(f"dsph_case: {written.strip()}", flush=True)
        return folder / "out" / CASE
    binaries = source / "bin" / "linux"
    subprocess.run([str(binaries / "GenCase_linux64"), f"{CASE}_Def", f"out/{CASE}", "-save:all"], cwd=folder,
                   env=library_env(binaries), check=True, capture_output=True)
    return folder / "out" / CASE


def library_env(binaries: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, [env.get("LD_LIBRARY_PATH"), str(binaries)]))
    return env


def child_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_dualsphysics(solver: Path, case: Path, threads: int, tmax: float) -> dict[str, float]:
    """Runs the solver once; returns fluid particles, steps, loop wall seconds and process CPU seconds."""
    out = case.parent / f"run_{threads}_{tmax:g}"
    shutil.rmtree(out, ignore_errors=True)
    before = child_cpu_seconds()
    log = subprocess.run([str(solver), "-cpu", f"-ompthreads:{threads}", str(case), str(out), "-sv:none",
                          f"-tmax:{tmax:g}"], env=library_env(solver.parent), check=True, capture_output=True,
                         text=True).stdout
    cpu = child_cpu_seconds() - before

    def number(pattern: str) -> float:
        match = re.search(pattern, log)
        if not match:
            raise SystemExit(f"DualSPHysics output lacks {pattern!r}; its log ends:\n{log[-2000:]}")
        return float(match.group(1).replace(",", ""))

    return {"particles": number(r"CaseNfluid=([\d,]+)"), "steps": number(r"Steps of simulation\.*: ([\d,]+)"),
            "wall": number(r"Simulation Runtime\.*: ([\d.eE+-]+) sec"), "cpu": cpu}


def dualsphysics_rates(solver: Path, case: Path, threads: int, tmax: float) -> dict[str, float]:
    """Particle-steps per wall and per CPU second of the time loop (setup CPU subtracted)."""
    full = run_dualsphysics(solver, case, threads, tmax)
    setup = run_dualsphysics(solver, case, threads, 1e-6)
    steps = full["steps"] - setup["steps"]
    return {"particles": full["particles"], "per_wall": full["particles"] * full["steps"] / full["wall"],
            "per_cpu": full["particles"] * steps / max(full["cpu"] - setup["cpu"], 1e-9)}


def terrasph_worker(particles: int, threads: int, steps: int, numerics: dict[str, bool | int | float]) -> None:
    """(In a child process) steps bench_sph's bed and prints its figures as JSON."""
    sys.path.insert(0, str(PERFORMANCE))
    from bench_sph import SPACING, bed
    from terrasph import _core
    from terrasph.config import Material, Numerics

    _core.set_num_threads(threads)
    sim = bed(particles, Material(), Numerics(spacing=SPACING, **numerics))
    sim.advance(1e9, max_steps=10)
    wall, cpu = time.perf_counter(), time.process_time()
    sim.advance(1e9, max_steps=steps)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    n = len(sim.mass)
    print(json.dumps({"particles": n, "per_wall": n * steps / wall, "per_cpu": n * steps / cpu}))


def terrasph_rates(particles: int, threads: int, steps: int, numerics: dict[str, bool | int | float]) -> dict[str, float]:
    out = subprocess.run([sys.executable, __file__, "--terrasph-worker", str(particles), str(threads), str(steps),
                          "--terrasph-numerics", json.dumps(numerics)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--source", type=Path, help="a DualSPHysics checkout fetched by the user")
    parser.add_argument("--sizes", type=int, nargs="+", default=[20000, 80000])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--tmax", type=float, default=0.05, help="simulated seconds of each dam-break run")
    parser.add_argument("--steps", type=int, default=200, help="steps of each terrasph run")
    parser.add_argument("--work", type=Path, default=None, help="folder for the generated cases (default: a temp dir)")
    parser.add_argument("--no-build", action="store_true", help="use the solver already built in the checkout")
    parser.add_argument("--make-options", nargs="*", default=[],
                        help="options for DualSPHysics' make, e.g. COMPILE_CHRONO=NO COMPILE_WAVEGEN=NO")
    parser.add_argument("--case-writer", choices=("auto", "gencase", "own"), default="auto",
                        help="GenCase, or benchmarks/peers/dsph_case.cpp (auto: GenCase where the checkout has it)")
    parser.add_argument("--numerics", nargs="*", default=[], metavar="NAME=VALUE",
                        help="terrasph options of the bed, e.g. cell_order=true symmetric_pairs=true")
    parser.add_argument("--terrasph-worker", nargs=3, type=int, help=argparse.SUPPRESS)
    parser.add_argument("--terrasph-numerics", default="{}", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.terrasph_worker:
        terrasph_worker(*args.terrasph_worker, json.loads(args.terrasph_numerics))
        return
    sys.path.insert(0, str(PERFORMANCE))
    from bench_sph import parse_numerics

    numerics = parse_numerics(args.numerics)
    if args.source is None or not args.source.is_dir():
        parser.error("parameter '--source' must name a DualSPHysics checkout (fetched by the user)")
    for name in ("sizes", "threads"):
        if min(getattr(args, name)) < 1:
            parser.error(f"parameter '--{name}' must be positive integers")
    if not (args.tmax > 0 and args.rounds >= 1 and args.steps >= 1):
        parser.error("parameters '--tmax' > 0, '--rounds' >= 1 and '--steps' >= 1 are required")
    source = args.source.resolve()
    has_gencase = os.access(source / "bin" / "linux" / "GenCase_linux64", os.X_OK)
    if args.case_writer == "gencase" and not has_gencase:
        parser.error(f"parameter '--case-writer' = gencase: no executable GenCase_linux64 in {source / 'bin' / 'linux'}")
    solver = find_solver(source) if args.no_build else build_solver(source, args.make_options)
    work = (args.work or Path(tempfile.mkdtemp(prefix="bench_dsph_"))).resolve()
    work.mkdir(parents=True, exist_ok=True)
    writer = None if (args.case_writer == "gencase" or (args.case_writer == "auto" and has_gencase)) \
        else build_case_writer(source, work)
    cases = {size: generate_case(source, work, spacing_for(size), writer) for size in args.sizes}
    results: dict[tuple[str, int, int], list[dict[str, float]]] = {}
    for round_index in range(args.rounds):
        for size in args.sizes:
            for threads in args.threads:
                codes = ["dsph", "terrasph"] if round_index % 2 == 0 else ["terrasph", "dsph"]
                for code in codes:
                    figures = (dualsphysics_rates(solver, cases[size], threads, args.tmax) if code == "dsph"
                               else terrasph_rates(size, threads, args.steps, numerics))
                    results.setdefault((code, size, threads), []).append(figures)
                    print(json.dumps({"round": round_index, "code": code, "size": size, "threads": threads,
                                      **figures}), flush=True)
    print("\n| N (DSPH / terrasph) | threads | DSPH M p-steps/wall s | terrasph M p-steps/wall s | ratio wall "
          "| DSPH M p-steps/CPU s | terrasph M p-steps/CPU s | ratio CPU |")
    print("|---|---|---|---|---|---|---|---|")
    for size in args.sizes:
        for threads in args.threads:
            d, t = results[("dsph", size, threads)], results[("terrasph", size, threads)]
            med = {key: (statistics.median(r[key] for r in d) / 1e6, statistics.median(r[key] for r in t) / 1e6)
                   for key in ("per_wall", "per_cpu")}
            print(f"| {d[0]['particles']:.0f} / {t[0]['particles']:.0f} | {threads} | {med['per_wall'][0]:.2f} | "
                  f"{med['per_wall'][1]:.2f} | {med['per_wall'][1] / med['per_wall'][0]:.2f} | "
                  f"{med['per_cpu'][0]:.2f} | {med['per_cpu'][1]:.2f} | {med['per_cpu'][1] / med['per_cpu'][0]:.2f} |")


if __name__ == "__main__":
    main()
