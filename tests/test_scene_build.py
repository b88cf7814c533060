"""Building a large scene: it says so while it takes time, stops at once on Ctrl-C or SIGTERM and
leaves no output file behind; the size guard judges the memory the process may actually use.

The slow build is a leg-wheel at a fine spacing on a shallow bed (a few seconds of shape and bed
building on a loaded machine, while its run would take hours: ``--yes``). SIGINT is sent to a
process started with SIGINT ignored, as a shell starts a background job (``terrasph run ... &``),
where Python's own Ctrl-C handler is never installed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import pytest

#: the build's arguments: about 120 000 grains and a wheel of 20 000 particles, ~5-10 s to build
SLOW_BUILD = ["run", "leg-wheel", "--spacing", "2.5e-4", "--bed-depth", "0.03", "--threads", "1", "--yes"]
#: allowed time from the signal to the exit (the handler runs between two numpy calls of the build)
EXIT_WITHIN = 10.0


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["OMP_NUM_THREADS"] = "1"
    return env


#: runs ``terrasph ARGS`` with SIGINT ignored (kept across exec), as a shell starts a background job
_WITH_SIGINT_IGNORED = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                        "os.execv(sys.executable, [sys.executable, '-m', 'terrasph.cli', *sys.argv[1:]])")


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_during_a_slow_build_stops_it_and_leaves_no_file(tmp_path, signum) -> None:
    out = tmp_path / "big.h5"
    process = subprocess.Popen([sys.executable, "-c", _WITH_SIGINT_IGNORED, *SLOW_BUILD, "--out", str(out)],
                               env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    killer = threading.Timer(240, process.kill)  # a hung child fails the test instead of hanging it
    killer.start()
    try:
        seen = []
        for line in process.stderr:  # the build's status line, shown after its quiet seconds
            seen.append(line)
            if "building the leg-wheel scene" in line:
                break
        assert process.poll() is None, "".join(seen)
        assert out.is_file()  # claimed while it builds
        process.send_signal(signum)
        sent = time.monotonic()
        _, rest = process.communicate(timeout=EXIT_WITHIN + 30)
        seconds = time.monotonic() - sent
    finally:
        killer.cancel()
    err = "".join(seen) + rest
    assert process.returncode == 130, err
    assert seconds < EXIT_WITHIN, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == "terrasph: interrupted"
    assert not out.exists()  # no empty claim left to block the next run
    assert not out.with_name("big.checkpoint.h5").exists()


_GUARD = """
import resource, sys
from terrasph.config import ConfigError
from terrasph.scenes.leg_wheel import LegWheel
from terrasph.size_guard import check_size
if sys.argv[1] == "limited":
    with open("/proc/self/status") as status:
        mapped = next(int(l.split()[1]) * 1024 for l in status if l.startswith("VmSize:"))
    resource.setrlimit(resource.RLIMIT_AS, (mapped + 300 * 2**20, resource.getrlimit(resource.RLIMIT_AS)[1]))
try:
    print("accepted", check_size(LegWheel(spacing=2.5e-4), confirmed=True, threads=1).memory_bytes)
except ConfigError as error:
    print("refused", error)
"""


def test_size_guard_respects_the_address_space_limit() -> None:
    """A run of ~0.7 GiB (estimate) fits the machine but not a process limited to 300 MiB more than
    it maps (ulimit -v): refused before any work, naming the limit."""
    def guard(mode: str) -> str:
        return subprocess.run([sys.executable, "-c", _GUARD, mode], env=_env(), capture_output=True, text=True,
                              timeout=120, check=True).stdout.strip()

    free = guard("free")
    assert free.startswith("accepted"), free
    assert float(free.split()[1]) > 400 * 2**20  # the estimate is above the limit's headroom
    limited = guard("limited")
    assert limited.startswith("refused"), limited
    assert "address-space limit" in limited and "spacing 0.00025 m" in limited
