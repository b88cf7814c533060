"""Throughput, thread scaling, memory per particle and feature cost of the SPH core.

    python benchmarks/performance/bench_sph.py throughput [--sizes 20000 80000 320000] [--threads 1 2] [--steps 200]
        [--numerics NAME=VALUE ...] [--particles-per-thread N]
    python benchmarks/performance/bench_sph.py features [--size 20000]
    python benchmarks/performance/bench_sph.py phases [--size 80000] [--threads 1] [--numerics NAME=VALUE ...]
    python benchmarks/performance/bench_sph.py scaling [--sizes 10000 30000 100000 300000] [--steps 50] [--repeats 3]
        [--numerics NAME=VALUE ...]

A scene is a bed of the dry glass beads at rest in a rough box (Δx = 2 mm, gravity on); it is
stepped a fixed number of steps after a short warm-up. "particle-steps" count granular
particles. Compare figures within one run (ratios): absolute times on a shared machine are noisy.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Callable

from terrasph import _core
from terrasph.cli_common import setting_value
from terrasph.config import Material, Numerics
from terrasph.geometry import wall_layers_needed
from terrasph.scene import Scene
from terrasph.simulation import Simulation

SPACING = 0.002


def resident_bytes() -> int:
    """Resident set size of this process (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def bed(size: int, material: Material, numerics: Numerics) -> Simulation:
    """A box 2:1 wide:tall holding about `size` granular particles."""
    width = math.sqrt(2 * size) * SPACING
    height = width / 2
    scene = Scene(spacing=SPACING)
    scene.add_block(0.0, 0.0, width, height)
    scene.add_wall("box", [(0.0, 1.5 * height), (0.0, 0.0), (width, 0.0), (width, 1.5 * height)],
                   layers=wall_layers_needed(numerics.h_factor))
    return Simulation(scene, material, numerics)


def time_steps(sim: Simulation, steps: int, clock: Callable[[], float] = time.perf_counter) -> float:
    """Seconds per step over `steps` steps after a warm-up of 10 (wall clock, or `clock`)."""
    sim.advance(1e9, max_steps=10)
    start = clock()
    sim.advance(1e9, max_steps=steps)
    return (clock() - start) / steps


def parse_numerics(pairs: list[str]) -> dict[str, bool | int | float]:
    """{"cell_order": True, "cfl": 0.4} from ["cell_order=true", "cfl=0.4"]. Names are not checked
    against this build's Numerics: an A/B passes them on to other builds."""
    return {name: setting_value(text) for name, _, text in (pair.partition("=") for pair in pairs)}


def throughput(sizes: list[int], threads: list[int], steps: int, numerics: dict[str, bool | int | float]) -> None:
    print("| granular particles | wall particles | threads | M particle-steps/s | per thread | speed-up | bytes/particle |")
    print("|---|---|---|---|---|---|---|")
    for size in sizes:
        base = None
        for n_threads in threads:
            _core.set_num_threads(n_threads)
            before = resident_bytes()
            sim = bed(size, Material(), Numerics(spacing=SPACING, **numerics))
            sim.advance(1e9, max_steps=1)
            memory = (resident_bytes() - before) / len(sim.mass)
            per_step = time_steps(sim, steps)
            rate = len(sim.mass) / per_step / 1e6
            base = base or rate
            print(f"| {len(sim.mass)} | {len(sim.core.wall_position)} | {n_threads} | {rate:.2f} | "
                  f"{rate / n_threads:.2f} | {rate / base:.2f} | {memory:.0f} |", flush=True)
            del sim


FEATURES: dict[str, tuple[dict, dict]] = {
    "plain (rate μ(I), no δ, no XSPH)": ({"model": "mu_i_rate"}, {"delta_sph": 0.0, "xsph": 0.0}),
    "+ δ-SPH (δ = 0.1)": ({"model": "mu_i_rate"}, {"delta_sph": 0.1, "xsph": 0.0}),
    "+ XSPH (χ = 0.2)": ({"model": "mu_i_rate"}, {"delta_sph": 0.0, "xsph": 0.2}),
    "+ Shepard every 10 steps": ({"model": "mu_i_rate"}, {"delta_sph": 0.0, "xsph": 0.0, "shepard_interval": 10}),
    "+ kernel gradient correction": ({"model": "mu_i_rate"}, {"delta_sph": 0.0, "xsph": 0.0,
                                                               "kernel_gradient_correction": True}),
    "+ hypoelastic μ(I) (mu_i_hypoelastic)": ({"model": "mu_i_hypoelastic"}, {"delta_sph": 0.0, "xsph": 0.0}),
    "Drucker–Prager instead of μ(I) (drucker_prager)": ({"model": "drucker_prager"}, {"delta_sph": 0.0, "xsph": 0.0}),
    "+ hypoelastic μ(I), wet (w = 0.5 %, c = 115 Pa)": ({"model": "mu_i_hypoelastic", "water_content": 0.005},
                                                          {"delta_sph": 0.0, "xsph": 0.0}),
    "+ hypoelastic μ(I), MLS every 10 steps": ({"model": "mu_i_hypoelastic"},
                                                {"delta_sph": 0.0, "xsph": 0.0, "mls_interval": 10}),
    "Drucker–Prager, MLS every 10 steps": ({"model": "drucker_prager"},
                                            {"delta_sph": 0.0, "xsph": 0.0, "mls_interval": 10}),
    "strain-based quasi-static branch of Eq. 3.6 (mu_i_strain)": ({"model": "mu_i_strain"},
                                                                   {"delta_sph": 0.0, "xsph": 0.0}),
    "default (hypoelastic, δ, XSPH)": ({}, {}),
    "default + Coulomb wall friction (μ_w = 0.384)": ({}, {"wall_friction_coefficient": 0.384}),
}


def features(size: int, steps: int, repeats: int, only: list[str], cpu: bool = False) -> None:
    """The plain bed and every configuration whose name contains one of `only` (all if empty);
    wall time per step, or CPU time of this process with `cpu`."""
    clock = time.process_time if cpu else time.perf_counter
    print(f"| configuration | {'CPU ' if cpu else ''}ms/step | ratio to plain |")
    print("|---|---|---|")
    plain_name = next(iter(FEATURES))
    chosen = {name: config for name, config in FEATURES.items()
              if name == plain_name or not only or any(word in name for word in only)}
    results = {name: [] for name in chosen}
    for _ in range(repeats):  # interleaved so load changes hit every variant alike
        for name, (material, numerics) in chosen.items():
            sim = bed(size, Material(**material), Numerics(spacing=SPACING, **numerics))
            results[name].append(time_steps(sim, steps, clock))
    plain = min(results[plain_name])
    for name, times in results.items():
        best = min(times)
        print(f"| {name} | {1e3 * best:.2f} | {best / plain:.2f} |", flush=True)


def scaling(sizes: list[int], steps: int, repeats: int, numerics: dict[str, bool | int | float]) -> None:
    """CPU time per particle-step on one thread against the particle count (flat within
    15 %), and the core's own storage per particle (`sim.core.memory_bytes`). CPU time of this process, the best of `repeats` rounds interleaved over the sizes, so
    that other processes' load (which wall time feels in full) moves every size alike."""
    _core.set_num_threads(1)
    sims = {size: bed(size, Material(), Numerics(spacing=SPACING, **numerics)) for size in sizes}
    best = dict.fromkeys(sizes, math.inf)
    for sim in sims.values():
        sim.advance(1e9, max_steps=10)
    for _ in range(repeats):
        for size, sim in sims.items():
            start = time.process_time()
            sim.advance(1e9, max_steps=steps)
            best[size] = min(best[size], (time.process_time() - start) / steps / len(sim.mass))
    smallest = best[sizes[0]]
    print("| granular particles | CPU ns per particle-step (1 thread) | ratio to the smallest | core bytes per particle |")
    print("|---|---|---|---|")
    for size, sim in sims.items():
        print(f"| {len(sim.mass)} | {1e9 * best[size]:.0f} | {best[size] / smallest:.2f} "
              f"| {sim.core.memory_bytes / len(sim.mass):.0f} |", flush=True)


def phases(size: int, threads: int, steps: int, numerics: dict[str, bool | int | float]) -> None:
    """Wall time of each phase of a step (the core's phase timers), per particle-step."""
    _core.set_num_threads(threads)
    sim = bed(size, Material(), Numerics(spacing=SPACING, **numerics))
    sim.advance(1e9, max_steps=10)
    before = dict(sim.core.phase_seconds)
    sim.advance(1e9, max_steps=steps)
    after = sim.core.phase_seconds
    per_step = {name: (after[name] - before[name]) / steps / len(sim.mass) * 1e9 for name in after}
    print(f"{len(sim.mass)} granular particles, {threads} thread(s), {steps} steps; ns per particle-step:")
    for name, ns in per_step.items():
        print(f"  {name:32s} {ns:7.1f}")
    print(f"  {'total':32s} {sum(per_step.values()):7.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="what", required=True)
    p = sub.add_parser("throughput")
    p.add_argument("--sizes", type=int, nargs="+", default=[20000, 80000, 320000])
    p.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--numerics", nargs="*", default=[], metavar="NAME=VALUE",
                   help="numerics options of the bed, e.g. cell_order=true")
    p.add_argument("--particles-per-thread", type=int, default=None,
                   help="fewest particles a loop gives each thread (default: the core's)")
    f = sub.add_parser("features")
    f.add_argument("--size", type=int, default=20000)
    f.add_argument("--steps", type=int, default=200)
    f.add_argument("--repeats", type=int, default=3)
    f.add_argument("--only", nargs="*", default=[], metavar="WORD",
                   help="only the configurations whose name contains one of these (and the plain one)")
    f.add_argument("--threads", type=int, default=None, help="OpenMP threads (default: the core's choice)")
    f.add_argument("--cpu", action="store_true",
                   help="CPU time of this process instead of wall time (use with --threads 1 on a busy machine)")
    ph = sub.add_parser("phases")
    ph.add_argument("--size", type=int, default=80000)
    ph.add_argument("--threads", type=int, default=1)
    ph.add_argument("--steps", type=int, default=100)
    ph.add_argument("--numerics", nargs="*", default=[], metavar="NAME=VALUE")
    sc = sub.add_parser("scaling")
    sc.add_argument("--sizes", type=int, nargs="+", default=[10000, 30000, 100000, 300000])
    sc.add_argument("--steps", type=int, default=50)
    sc.add_argument("--repeats", type=int, default=3)
    sc.add_argument("--numerics", nargs="*", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    if args.what == "scaling":
        scaling(args.sizes, args.steps, args.repeats, parse_numerics(args.numerics))
    elif args.what == "throughput":
        if args.particles_per_thread is not None:
            _core.set_particles_per_thread(args.particles_per_thread)
        throughput(args.sizes, args.threads, args.steps, parse_numerics(args.numerics))
    elif args.what == "features":
        if args.threads is not None:
            _core.set_num_threads(args.threads)
        features(args.size, args.steps, args.repeats, args.only, args.cpu)
    else:
        phases(args.size, args.threads, args.steps, parse_numerics(args.numerics))


if __name__ == "__main__":
    main()
