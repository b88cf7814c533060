"""terrasph: SPH simulation of robots and robot legs on granular terrain, and LSTM surrogates.

Units are SI throughout; 2D scenes are plane strain in the x–z plane with z up.

Threads: unless the user set them, idle OpenMP threads sleep instead of spinning
(``OMP_WAIT_POLICY=passive``; a spinning team loses badly to any other busy process), and the SPH
core uses the cores that are idle when terrasph is imported (:func:`terrasph.threads.default_threads`)
unless ``OMP_NUM_THREADS`` is set. Both must be decided before the OpenMP runtime starts.
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "passive")

from terrasph import _core  # noqa: E402  (after the wait policy: the runtime reads it once)
from terrasph._core import InstabilityError  # noqa: E402

if "OMP_NUM_THREADS" not in os.environ:
    from terrasph.threads import default_threads

    _core.set_num_threads(default_threads())

__all__ = ["InstabilityError", "__version__"]
__version__ = "0.1.0"
