"""sogdd: high-resolution image corner detection with SOGDD filters.

Implements the detector of "high-resolution corner detection" with isotropic
second-order Gaussian directional derivative (SOGDD) filters: responses at K
orientations (eq. 23), the SODDC matrix of their absolute values over a window
(eq. 24), and the measure det / (trace + varsigma) (eq. 25).

The core is a straight pipeline, io -> filters -> response -> peaks ->
detector; everything else (theory, baselines, evaluation, report, cli,
collection) is its client.
"""

from .corners import Corners
from .describe import describe
from .detector import corner_response, detect_corners
from .feature2d import SOGDD
from .features import load_features
from .io import read_image
from .params import PRESETS, resolve_params

__all__ = [
    "PRESETS",
    "SOGDD",
    "Corners",
    "corner_response",
    "describe",
    "detect_corners",
    "load_features",
    "read_image",
    "resolve_params",
]
__version__ = "0.1.0"
