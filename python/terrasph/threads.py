"""The OpenMP thread count and wait terrasph uses by default, chosen so a run never collapses
when the machine's cores are shared and its threads keep pace when they are not.

Two things make a team of OpenMP threads slow on a busy machine: threads that spin while they
wait for long (each spin takes a core another process needs) and more threads than free cores
(each parallel region then waits for a thread the OS has descheduled). On an idle machine the
opposite costs: a thread that sleeps between two of a step's loops starts the next one 25–40 µs
late on a virtual machine (benchmarks/performance/omp_wake.cpp), as much as a small loop's work.
:func:`idle_cores` counts the cores idle right now; :func:`threads_for` and :func:`spin_count`
turn that into a thread count and libgomp's spin (``GOMP_SPINCOUNT``).

When each is decided: libgomp reads its spin once, when it loads, so :func:`runtime_spin` sets
``GOMP_SPINCOUNT`` only while ``terrasph/__init__.py`` loads the core (from the 1-minute load
average, read at once, no sampling) and puts the environment back afterwards, unless the user set
``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT``. The thread count is chosen when a run starts
(:func:`start_run`, called by :class:`LoadWatch`), unless the user chose one (``OMP_NUM_THREADS``,
``--threads``, :func:`use_threads`); :class:`LoadWatch` then follows the load while the run goes on.
Importing terrasph changes neither the process's environment nor its thread count.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator

__all__ = ["LONG_SPIN", "SHORT_SPIN", "LoadWatch", "available_cores", "default_threads", "idle_cores",
           "idle_cores_by_load_average", "runtime_spin", "spin_count", "start_run", "threads_for", "threads_left",
           "use_threads"]

SAMPLE_SECONDS = 0.05
#: polls an idle thread spins before it sleeps beside other work: about 50 µs, too short to matter
#: to another busy process
SHORT_SPIN = 1000
#: polls on an idle machine: about 1.5 ms, which carries a thread across the serial parts of a step
#: (the wall passes, the body loads) to the next loop awake
LONG_SPIN = 30000


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


def _idle_cores_between(first: tuple[int, int] | None, second: tuple[int, int] | None) -> float | None:
    """Idle cores of the whole machine between two readings of :func:`_cpu_ticks`, else None."""
    if first is None or second is None or second[1] <= first[1]:
        return None
    idle_fraction = (second[0] - first[0]) / (second[1] - first[1])
    return idle_fraction * (os.cpu_count() or 1)


def idle_cores(sample_seconds: float = SAMPLE_SECONDS) -> float | None:
    """Idle cores of the whole machine over `sample_seconds` (Linux /proc/stat), else None."""
    first = _cpu_ticks()
    time.sleep(sample_seconds)
    return _idle_cores_between(first, _cpu_ticks())


def idle_cores_by_load_average() -> float | None:
    """Idle cores of the whole machine by its 1-minute load average (/proc/loadavg: read at once,
    no sampling; it lags the load by up to a minute), else None."""
    try:
        with open("/proc/loadavg", encoding="ascii") as loadavg:
            load = float(loadavg.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None
    return max(0.0, (os.cpu_count() or 1) - load)


@contextlib.contextmanager
def runtime_spin() -> Iterator[None]:
    """Sets libgomp's spin (:func:`spin_count`) while the OpenMP runtime loads inside the block,
    unless ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is set; the environment is restored after."""
    if "OMP_WAIT_POLICY" in os.environ or "GOMP_SPINCOUNT" in os.environ:
        yield
        return
    follows_load = "OMP_NUM_THREADS" not in os.environ
    os.environ["GOMP_SPINCOUNT"] = str(spin_count(idle_cores_by_load_average(), follows_load))
    try:
        yield
    finally:
        del os.environ["GOMP_SPINCOUNT"]


def threads_for(idle: float | None) -> int:
    """Threads for the SPH core with `idle` cores idle (None: unknown, every available core)."""
    cores = available_cores()
    if idle is None:
        return cores
    return max(1, min(cores, int(idle + 0.5)))


def spin_count(idle: float | None, follows_load: bool) -> int:
    """libgomp's spin for `idle` idle cores: LONG_SPIN when every available core is idle (the team
    has the machine to itself) and the thread count `follows_load` (terrasph's own, which
    :class:`LoadWatch` lowers when another process comes: a long spin beside one is 2.8× slower
    than one thread), SHORT_SPIN otherwise or when the load is unknown."""
    if follows_load and idle is not None and idle >= available_cores() - 0.5:
        return LONG_SPIN
    return SHORT_SPIN


def default_threads() -> int:
    """Threads for the SPH core: the cores that are idle now (rounded), within [1, available].

    On an idle machine that is every available core; with another CPU-bound job on one of two
    cores it is 1. Results do not depend on the thread count (docs/design.md §7), only speed does; set
    ``OMP_NUM_THREADS``, ``--threads`` or ``terrasph._core.set_num_threads`` to choose.
    """
    return threads_for(idle_cores())


#: The thread count terrasph chose when the first run started (None: not chosen, or the user's) and
#: the one it set last (LoadWatch). Process-wide, like the OpenMP thread count they stand beside:
#: while that count is `auto_threads`, it is terrasph's to change.
chosen_threads: int | None = None
auto_threads: int | None = None
#: whether the user chose the thread count (``--threads`` or :func:`use_threads`)
user_chose: bool = False


def use_threads(threads: int | None) -> None:
    """The user's thread count for the SPH core (None: leave terrasph's choice at run start)."""
    global user_chose, chosen_threads, auto_threads
    if threads is None:
        return
    from terrasph import _core

    _core.set_num_threads(threads)
    user_chose, chosen_threads, auto_threads = True, None, None


def start_run(set_threads: Callable[[int], None], get_threads: Callable[[], int]) -> None:
    """At the start of a run: the thread count from the cores idle now (:func:`default_threads`,
    a 50 ms look), once per process, unless the user chose one (``OMP_NUM_THREADS``,
    :func:`use_threads`, or ``_core.set_num_threads`` with a count other than the OpenMP default of
    every available core)."""
    global chosen_threads
    if user_chose or chosen_threads is not None or "OMP_NUM_THREADS" in os.environ:
        return
    if get_threads() != available_cores():  # set by the user through the core itself
        return
    chosen_threads = default_threads()
    set_threads(chosen_threads)
    _record_auto(chosen_threads)


def threads_left(others_busy: float, chosen: int) -> int:
    """Threads for a run whose machine has `others_busy` cores kept busy by other processes: the
    whole cores left, within [1, chosen]; less than 0.3 of a core taken counts as none (a machine's
    own daemons), more gives the core up (a competitor beside a spinning team gets only a fair
    share of the cores, 2/3 of one on two, so it never shows as a whole core)."""
    return max(1, min(chosen, int(available_cores() - others_busy + 0.3)))


class LoadWatch:
    """Keeps the thread count terrasph chose in step with the load while a run goes on.

    The count is chosen when the first run starts (:func:`start_run`, which the watch calls) and the
    spin when the core loads, from the cores idle then; a process that starts
    later would find a team of two spinning threads on its core (LONG_SPIN), and both would lose.
    Every `interval` seconds of wall time, :meth:`follow` counts the cores other processes kept
    busy since its last look (the machine's busy time from /proc/stat less this process's own CPU
    time) and sets the thread count to the cores they leave (:func:`threads_left`), back up to the
    chosen count when they go. Only while the count is terrasph's: not after ``OMP_NUM_THREADS``
    or a call of ``set_num_threads`` with another count. Results do not depend on the thread count.
    """

    def __init__(self, set_threads: Callable[[int], None], get_threads: Callable[[], int], *,
                 interval: float = 2.0, read_ticks: Callable[[], tuple[int, int] | None] | None = None,
                 own_cpu: Callable[[], float] = time.process_time,
                 clock: Callable[[], float] = time.perf_counter) -> None:
        self._set, self._get = set_threads, get_threads
        start_run(set_threads, get_threads)
        self._interval = interval
        self._read_ticks = read_ticks or _cpu_ticks
        self._own_cpu, self._clock = own_cpu, clock
        self._last = self._look()

    def _look(self) -> tuple[float, tuple[int, int] | None, float]:
        return self._clock(), self._read_ticks(), self._own_cpu()

    def follow(self) -> None:
        """Looks at the load if `interval` has passed since the last look, and sets the threads."""
        if chosen_threads is None or self._get() != auto_threads:
            return  # the user's count (auto_threads is set whenever chosen_threads is)
        if self._clock() - self._last[0] < self._interval:
            return
        now = self._look()
        (t0, ticks0, cpu0), (t1, ticks1, cpu1) = self._last, now
        self._last = now
        idle = _idle_cores_between(ticks0, ticks1)
        if idle is None or t1 <= t0:
            return
        busy_cores = (os.cpu_count() or 1) - idle
        others = max(0.0, busy_cores - (cpu1 - cpu0) / (t1 - t0))
        threads = threads_left(others, chosen_threads)
        if threads != auto_threads:
            self._set(threads)
            _record_auto(threads)


def _record_auto(threads: int) -> None:
    global auto_threads
    auto_threads = threads
