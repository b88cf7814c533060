"""Thread defaults that do not collapse on a shared machine.

The speed itself is measured in benchmarks/performance/bench_threads.py (figures in docs/benchmarks.md); here:
terrasph bounds how long idle OpenMP threads spin, by the load, unless the user chose, picks a thread count
within the cores it may use when a run starts (not at import), and leaves an explicit OMP_NUM_THREADS or
--threads alone.
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


def test_import_leaves_the_environment_and_thread_count_alone() -> None:
    """No work at import: the process's environment and OpenMP thread count are as before."""
    code = "print(os.environ.get('OMP_WAIT_POLICY'), os.environ.get('GOMP_SPINCOUNT'), _core.get_max_threads())"
    out = fresh_import({"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": None, "OMP_NUM_THREADS": None}, code)
    assert out == f"None None {os.cpu_count()}"  # libgomp's own default: every CPU
    assert fresh_import({"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": "5"}, code).startswith("None 5 ")


def test_the_spin_is_set_only_while_the_runtime_loads_unless_the_user_chose(monkeypatch) -> None:
    from terrasph.threads import LONG_SPIN, SHORT_SPIN, runtime_spin

    for name in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "OMP_NUM_THREADS"):
        monkeypatch.delenv(name, raising=False)
    with runtime_spin():
        assert os.environ["GOMP_SPINCOUNT"] in (str(SHORT_SPIN), str(LONG_SPIN))
    assert "GOMP_SPINCOUNT" not in os.environ
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    with runtime_spin():  # a count the load watch leaves alone: never the long spin
        assert os.environ["GOMP_SPINCOUNT"] == str(SHORT_SPIN)
    monkeypatch.setenv("OMP_WAIT_POLICY", "passive")
    with runtime_spin():
        assert "GOMP_SPINCOUNT" not in os.environ


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
    """At run start terrasph picks a count within the cores, unless the user chose one first."""
    from terrasph.threads import available_cores

    def count_at_run_start(before: str) -> str:
        code = (f"from terrasph import threads\n{before}\n"
                "threads.start_run(_core.set_num_threads, _core.get_max_threads)\nprint(_core.get_max_threads())")
        return fresh_import({"OMP_NUM_THREADS": None}, code)

    assert 1 <= int(count_at_run_start("")) <= available_cores()
    assert count_at_run_start("threads.use_threads(1)") == "1"  # --threads
    assert count_at_run_start("_core.set_num_threads(1)") == "1"  # the core's own call


def test_omp_num_threads_is_respected() -> None:
    assert fresh_import({"OMP_NUM_THREADS": "1"}, "print(_core.get_max_threads())") == "1"


def test_idle_cores_is_a_fraction_of_the_machine() -> None:
    from terrasph.threads import default_threads, idle_cores

    idle = idle_cores(0.02)
    if idle is None:
        pytest.skip("no /proc/stat on this system")
    assert 0.0 <= idle <= (os.cpu_count() or 1) + 1e-9
    assert default_threads() >= 1


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


def test_the_load_average_gives_idle_cores_within_the_machine() -> None:
    from terrasph.threads import idle_cores_by_load_average

    idle = idle_cores_by_load_average()
    if idle is None:
        pytest.skip("no /proc/loadavg on this system")
    assert 0.0 <= idle <= (os.cpu_count() or 1)
