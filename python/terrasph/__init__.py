"""terrasph: SPH simulation of robots and robot legs on granular terrain, and LSTM surrogates.

Units are SI throughout; 2D scenes are plane strain in the x–z plane with z up.
"""

from terrasph._core import InstabilityError

__all__ = ["InstabilityError", "__version__"]
__version__ = "0.1.0"
