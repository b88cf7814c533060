"""The state digests of benchmarks/performance/state_digest.py against the committed tests/data/state_digests.txt.

Each line hashes the whole state of one scene variant after a fixed number of steps (every optional
term on and off, the gather and each-pair-once passes, the active domain), so a change to the core
that should leave every result alone (a refactoring, a faster loop) is caught to the bit, with one
thread and with two (the core's determinism: the same sums for any thread count). The last lines are
a 3D plate pushed into a 3D bed (docs/sph3d.md).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXPECTED = ROOT / "tests" / "data" / "state_digests.txt"
UPDATE = ("a change that is meant to change results (a physics fix, a new default) updates the file, and says "
          "why in its commit: python benchmarks/performance/state_digest.py --threads 1 > tests/data/state_digests.txt")


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
def test_state_digests_unchanged(threads: int) -> None:
    out = subprocess.run([sys.executable, "state_digest.py", "--threads", str(threads)], cwd=ROOT / "benchmarks" / "performance",
                         check=True, capture_output=True, text=True).stdout
    expected = EXPECTED.read_text().splitlines()
    changed = [f"{e!r} is now {g!r}" for e, g in zip(expected, out.splitlines()) if e != g]
    assert len(out.splitlines()) == len(expected), f"the variants differ from {EXPECTED.name}; {UPDATE}"
    assert not changed, f"state digests changed with {threads} thread(s): {'; '.join(changed)}; {UPDATE}"
