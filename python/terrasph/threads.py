"""The OpenMP thread count terrasph uses by default, chosen so a run never collapses when the
machine's cores are shared (issue 15, item 1).

Two things make a team of OpenMP threads slow on a busy machine: threads that spin while they
wait without bound (``terrasph/__init__.py`` bounds the spin to ``SPIN_COUNT`` polls unless the user
chose a policy) and more threads than free cores (each parallel region then waits for a thread the OS has
descheduled). :func:`default_threads` counts the cores that are idle right now.
"""

from __future__ import annotations

import os
import time

__all__ = ["available_cores", "default_threads", "idle_cores"]

SAMPLE_SECONDS = 0.05


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity), at least 1."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def _cpu_ticks() -> tuple[int, int] | None:
    """(idle, total) jiffies of all CPUs from /proc/stat, or None where there is none."""
    try:
        with open("/proc/stat", encoding="ascii") as stat:
            fields = [int(v) for v in stat.readline().split()[1:]]
    except (OSError, ValueError):
        return None
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)  # idle + iowait
    return idle, sum(fields[:8])


def idle_cores(sample_seconds: float = SAMPLE_SECONDS) -> float | None:
    """Idle cores of the whole machine over `sample_seconds` (Linux /proc/stat), else None."""
    first = _cpu_ticks()
    time.sleep(sample_seconds)
    second = _cpu_ticks()
    if first is None or second is None or second[1] <= first[1]:
        return None
    idle_fraction = (second[0] - first[0]) / (second[1] - first[1])
    return idle_fraction * (os.cpu_count() or 1)


def default_threads() -> int:
    """Threads for the SPH core: the cores that are idle now (rounded), within [1, available].

    On an idle machine that is every available core; with another CPU-bound job on one of two
    cores it is 1. Results do not depend on the thread count (DESIGN §7), only speed does; set
    ``OMP_NUM_THREADS``, ``--threads`` or ``terrasph._core.set_num_threads`` to choose.
    """
    cores = available_cores()
    idle = idle_cores()
    if idle is None:
        return cores
    return max(1, min(cores, int(idle + 0.5)))
