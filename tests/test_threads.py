"""Thread defaults that do not collapse on a shared machine (issue 15, item 1).

The speed itself is measured in benchmarks/bench_threads.py (figures in docs/benchmarks.md); here:
terrasph bounds how long idle OpenMP threads spin, by the load, unless the user chose, picks a thread count
within the cores it may use, and leaves an explicit OMP_NUM_THREADS alone.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest


def fresh_import(env_overrides: dict[str, str | None], code: str) -> str:
    """stdout of `code` run after `import terrasph` in a new interpreter with the given environment."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    for key, value in env_overrides.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    result = subprocess.run([sys.executable, "-c", f"import os, terrasph\nfrom terrasph import _core\n{code}"],
                            env=env, capture_output=True, text=True, check=True, timeout=120)
    return result.stdout.strip()


def test_idle_threads_spin_as_the_load_allows_unless_the_user_chose() -> None:
    from terrasph.threads import LONG_SPIN, SHORT_SPIN

    code = "print(os.environ.get('OMP_WAIT_POLICY'), os.environ.get('GOMP_SPINCOUNT'))"
    chosen = fresh_import({"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": None}, code)
    assert chosen in (f"None {SHORT_SPIN}", f"None {LONG_SPIN}")
    assert fresh_import({"OMP_WAIT_POLICY": "passive", "GOMP_SPINCOUNT": None}, code) == "passive None"
    assert fresh_import({"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": "5"}, code) == "None 5"
    pinned = {"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": None, "OMP_NUM_THREADS": "2"}
    assert fresh_import(pinned, code) == f"None {SHORT_SPIN}"  # a count the load watch leaves alone


def test_a_long_spin_only_when_every_core_is_idle() -> None:
    from terrasph.threads import LONG_SPIN, SHORT_SPIN, available_cores, spin_count, threads_for

    cores = available_cores()
    assert spin_count(float(cores), follows_load=True) == LONG_SPIN
    assert spin_count(float(cores), follows_load=False) == SHORT_SPIN  # the user's count: no watch
    assert spin_count(cores - 1.0, follows_load=True) == SHORT_SPIN  # another process holds a core
    assert spin_count(None, follows_load=True) == SHORT_SPIN  # load unknown
    assert SHORT_SPIN < LONG_SPIN
    assert threads_for(float(cores)) == cores and threads_for(0.2) == 1 and threads_for(None) == cores


def test_default_thread_count_is_within_the_available_cores() -> None:
    from terrasph.threads import available_cores

    picked = int(fresh_import({"OMP_NUM_THREADS": None}, "print(_core.get_max_threads())"))
    assert 1 <= picked <= available_cores()


def test_omp_num_threads_is_respected() -> None:
    assert fresh_import({"OMP_NUM_THREADS": "1"}, "print(_core.get_max_threads())") == "1"


def test_idle_cores_is_a_fraction_of_the_machine() -> None:
    from terrasph.threads import default_threads, idle_cores

    idle = idle_cores(0.02)
    if idle is None:
        pytest.skip("no /proc/stat on this system")
    assert 0.0 <= idle <= (os.cpu_count() or 1) + 1e-9
    assert 1 <= default_threads()


class FakeMachine:
    """/proc/stat's (idle, total) ticks, this process's CPU time and a clock, advanced by hand:
    `cores` cores at 100 ticks per second, of which `others` busy with other processes and `own`
    with this one."""

    def __init__(self, cores: int) -> None:
        self.cores, self.idle, self.total, self.cpu, self.time = cores, 0, 0, 0.0, 0.0

    def run(self, seconds: float, others: float, own: float) -> None:
        ticks = int(100 * seconds * self.cores)
        self.total += ticks
        self.idle += int(ticks * (1 - (others + own) / self.cores))
        self.cpu += own * seconds
        self.time += seconds


def test_the_load_watch_gives_a_core_back_to_a_process_that_needs_it(monkeypatch) -> None:
    from terrasph import threads

    cores = threads.available_cores()
    if cores < 2 or (os.cpu_count() or 1) != cores:
        pytest.skip("needs every core of the machine available (the watch counts the machine's load)")
    machine = FakeMachine(cores)
    count = {"threads": cores}
    monkeypatch.setattr(threads, "chosen_threads", cores)
    monkeypatch.setattr(threads, "auto_threads", cores)
    watch = threads.LoadWatch(lambda n: count.update(threads=n), lambda: count["threads"], interval=2.0,
                              read_ticks=lambda: (machine.idle, machine.total),
                              own_cpu=lambda: machine.cpu, clock=lambda: machine.time)
    machine.run(3.0, others=0.0, own=cores)  # alone: the team keeps every core
    watch.follow()
    assert count["threads"] == cores
    machine.run(3.0, others=1.0, own=cores - 1.0)  # another process takes a core
    watch.follow()
    assert count["threads"] == cores - 1
    machine.run(1.0, others=0.0, own=cores - 1.0)  # within the interval: no look yet
    watch.follow()
    assert count["threads"] == cores - 1
    machine.run(3.0, others=0.0, own=cores - 1.0)  # it has gone: the core comes back
    watch.follow()
    assert count["threads"] == cores
    count["threads"] = 1  # the user's own choice is left alone, whatever the load
    machine.run(3.0, others=0.0, own=1.0)
    watch.follow()
    assert count["threads"] == 1
