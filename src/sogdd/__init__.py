"""sogdd: high-resolution image corner detection with SOGDD filters.

Implements the detector of "high-resolution corner detection" with isotropic
second-order Gaussian directional derivative (SOGDD) filters: responses at K
orientations (eq. 23), the SODDC matrix of their absolute values over a window
(eq. 24), and the measure det / (trace + varsigma) (eq. 25).
"""

from .corners import Corners
from .describe import describe
from .detector import PRESETS, SOGDD, corner_response, detect_corners, resolve_params
from .io import read_image

__all__ = [
    "PRESETS",
    "SOGDD",
    "Corners",
    "corner_response",
    "describe",
    "detect_corners",
    "read_image",
    "resolve_params",
]
__version__ = "0.1.0"
