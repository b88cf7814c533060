"""Thread defaults that do not collapse on a shared machine (issue 15, item 1).

The speed itself is measured in benchmarks/bench_threads.py (figures in docs/benchmarks.md); here:
terrasph makes idle OpenMP threads sleep unless the user chose otherwise, picks a thread count
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


def test_idle_threads_spin_briefly_unless_the_user_chose() -> None:
    from terrasph import SPIN_COUNT

    code = "print(os.environ.get('OMP_WAIT_POLICY'), os.environ.get('GOMP_SPINCOUNT'))"
    assert fresh_import({"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": None}, code) == f"None {SPIN_COUNT}"
    assert fresh_import({"OMP_WAIT_POLICY": "passive", "GOMP_SPINCOUNT": None}, code) == "passive None"
    assert fresh_import({"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": "5"}, code) == "None 5"


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
