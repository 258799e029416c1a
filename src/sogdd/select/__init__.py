"""Stage 3, selection: from the measure to corners.

In: the measure (a map, or bands of it from :mod:`sogdd.measure`) and the grey
image. Out: :class:`~sogdd.corners.Corners`, strongest first, at sub-pixel
positions, with X-junctions on their saddle points for ``hr``.

The order of the steps: thresholds and non-maximum suppression, band by band
or on a map; sub-pixel refinement; X-junctions; assembly into corners (grey
units, merging); the image pyramid around all of them.

=========================  ==============================================================
module                     what it does
=========================  ==============================================================
:mod:`.peaks`              thresholds (absolute, relative, quantile), NMS, border, mask,
                           ties, top-k on a map
:mod:`.nms_scan`           compiled scan of the pixels above a threshold
:mod:`.banded`             peaks under an absolute threshold, band by band (no H x W map)
:mod:`.banded_relative`    peaks under a relative or quantile threshold in one pass
:mod:`.relative_floor`     a lower bound of a relative threshold, so that bands can prune
:mod:`.stream_quantile`    numpy's quantile of a map seen band by band
:mod:`.subpixel`           quadratic, gradient and adaptive refinement; merging
:mod:`.x_junctions`        X-junctions as saddle points (``hr``)
:mod:`.saddle_steps`       compiled saddle candidates and Newton steps
:mod:`.assemble`           peaks to corners: refinement, units, X-junctions, merge
:mod:`.pyramid`            the levels of the image pyramid and their merge
:mod:`.budget`             ANMS and bucketing under a point budget (the evaluations' specs)
=========================  ==============================================================
"""

from .peaks import local_maxima, resolve_threshold, select_peaks, valid_area
from .pyramid import merge_levels, pyramid_levels
from .subpixel import refine_gradient, refine_gradient_adaptive, refine_quadratic
from .x_junctions import add_x_junctions, find_saddles

__all__ = [
    "add_x_junctions",
    "find_saddles",
    "local_maxima",
    "merge_levels",
    "pyramid_levels",
    "refine_gradient",
    "refine_gradient_adaptive",
    "refine_quadratic",
    "resolve_threshold",
    "select_peaks",
    "valid_area",
]
