"""terrasph: SPH simulation of robots and robot legs on granular terrain, and LSTM surrogates.

Units are SI throughout; 2D scenes are plane strain in the x–z plane with z up.

Threads: unless the user set ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT``, an idle OpenMP thread
spins for at most ``SPIN_COUNT`` polls (a few µs) before it sleeps: enough to carry it from one
particle loop of a step to the next, where waking a sleeping thread costs as much as a small loop's
work, and too short to matter to another busy process (a team that spins without bound loses badly
to one; docs/benchmarks.md, "Threads on a shared machine"). The SPH core uses the cores that are
idle when terrasph is imported (:func:`terrasph.threads.default_threads`) unless
``OMP_NUM_THREADS`` is set. Both must be decided before the OpenMP runtime starts.
"""

import os

#: polls an idle thread of libgomp (the OpenMP runtime of terrasph's builds) spins before it sleeps
SPIN_COUNT = 1000
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["GOMP_SPINCOUNT"] = str(SPIN_COUNT)

from terrasph import _core  # noqa: E402  (after the wait policy: the runtime reads it once)
from terrasph._core import InstabilityError  # noqa: E402

if "OMP_NUM_THREADS" not in os.environ:
    from terrasph.threads import default_threads

    _core.set_num_threads(default_threads())

__all__ = ["InstabilityError", "__version__"]
__version__ = "0.1.0"
