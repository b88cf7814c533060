"""terrasph: SPH simulation of robots and robot legs on granular terrain, and LSTM surrogates.

Units are SI throughout; 2D scenes are plane strain in the x–z plane with z up.

Importing terrasph does no work beyond loading its modules: the SPH core's thread count is chosen
when a run starts, from the cores idle then, unless ``OMP_NUM_THREADS`` or ``--threads`` chose it,
and while a run goes on :class:`terrasph.threads.LoadWatch` lowers that count when other processes
take cores and raises it back when they leave. The one decision that must come before the OpenMP
runtime starts, how long an idle OpenMP thread spins before it sleeps, is passed to it while the
core loads (``GOMP_SPINCOUNT``, unless ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is set) and the
environment is put back (:mod:`terrasph.threads`; docs/benchmarks.md, "Threads on a shared machine").
"""

from terrasph import threads as _threads

with _threads.runtime_spin():
    from terrasph import _core  # noqa: F401  (the OpenMP runtime reads its spin once, as it loads)
from terrasph._core import InstabilityError
from terrasph._version import __version__

__all__ = ["InstabilityError", "__version__"]
