"""sogdd: high-resolution image corner detection with SOGDD filters.

Implements the detector of "high-resolution corner detection" with isotropic
second-order Gaussian directional derivative (SOGDD) filters: responses at K
orientations (eq. 23), the SODDC matrix of their absolute values over a window
(eq. 24), and the measure det / (trace + varsigma) (eq. 25).

The core is a pipeline of stages, each a folder, called in this order by
:mod:`sogdd.detector`:

1. :mod:`sogdd.image`: files and arrays to validated grey levels on 0-255;
2. :mod:`sogdd.measure`: SOGDD filters, the SODDC matrix and Upsilon, grey-level units;
3. :mod:`sogdd.select`: thresholds, non-maximum suppression, sub-pixel refinement,
   X-junctions, assembly into :class:`Corners` (one entry point,
   :func:`sogdd.select.stage.select_corners`);
4. :mod:`sogdd.detector`: :func:`corner_response` and :func:`detect_corners`
   (:mod:`sogdd.params` resolves the presets; :mod:`sogdd.gpu` mirrors the stages
   on a CUDA device).

Around them: :mod:`sogdd.descriptors` (SIFT descriptors at corners),
:mod:`sogdd.feature2d` (OpenCV's vocabulary), :mod:`sogdd.formats` (feature
files, COLMAP). Everything else (theory, baselines, evaluation, report, cli,
:mod:`sogdd.collection` for batches over many images, :mod:`sogdd.calib` for
calibration boards and camera calibration) is a client of the core and is never
imported by it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._version import __version__

# Public names and the module that holds each. They load on first use (PEP 562),
# so that `sogdd --help` and `import sogdd.cli` do not pay for numba, OpenCV and
# scipy, which the core's modules import.
_EXPORTS = {
    "Corners": "corners",
    "describe": "descriptors",
    "corner_response": "detector",
    "detect_corners": "detector",
    "SOGDD": "feature2d",
    "load_features": "formats.features",
    "read_image": "image.files",
    "PRESETS": "params",
    "Params": "params",
    "resolve_params": "params",
}

__all__ = [
    "__version__",
    "PRESETS",
    "SOGDD",
    "Params",
    "Corners",
    "corner_response",
    "describe",
    "detect_corners",
    "load_features",
    "read_image",
    "resolve_params",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from .corners import Corners
    from .descriptors import describe
    from .detector import corner_response, detect_corners
    from .feature2d import SOGDD
    from .formats.features import load_features
    from .image.files import read_image
    from .params import PRESETS, Params, resolve_params


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sogdd' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
