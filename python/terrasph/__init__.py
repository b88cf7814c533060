"""terrasph: SPH simulation of robots and robot legs on granular terrain, and LSTM surrogates.

Units are SI throughout; 2D scenes are plane strain in the x–z plane with z up.

Threads: unless ``OMP_NUM_THREADS`` is set, the SPH core uses the cores that are idle when
terrasph is imported, and while a run goes on :class:`terrasph.threads.LoadWatch` lowers that
count when other processes take cores and raises it back when they leave. Unless
``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is set, an idle OpenMP thread spins for
``threads.LONG_SPIN`` polls (about 1.5 ms) before it sleeps when every core is idle and the count is
terrasph's, which keeps it awake from one loop of a step to the next, and for
``threads.SHORT_SPIN`` (about 50 µs) otherwise, so as not to take another process's core
(:mod:`terrasph.threads`; docs/benchmarks.md, "Threads on a shared machine"). Both must be
decided before the OpenMP runtime starts.
"""

import os

from terrasph import threads as _threads

_choose_wait = "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ
_choose_threads = "OMP_NUM_THREADS" not in os.environ
_idle = _threads.idle_cores() if _choose_wait or _choose_threads else None
if _choose_wait:
    os.environ["GOMP_SPINCOUNT"] = str(_threads.spin_count(_idle, follows_load=_choose_threads))

from terrasph import _core  # noqa: E402  (after the wait policy: the runtime reads it once)
from terrasph._core import InstabilityError  # noqa: E402

if _choose_threads:
    _threads.chosen_threads = _threads.auto_threads = _threads.threads_for(_idle)
    _core.set_num_threads(_threads.chosen_threads)

__all__ = ["InstabilityError", "__version__"]
__version__ = "0.1.0"
