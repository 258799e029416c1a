"""Stage 3, selection: from the measure to corners.

In: the measure of the grey image, read band by band or whole from
:mod:`sogdd.measure` (or the maxima a device found), and the grey image. Out:
:class:`~sogdd.corners.Corners`, strongest first, at sub-pixel positions, with
X-junctions on their saddle points for ``hr``.

One entry point, :func:`~sogdd.select.stage.select_corners`, chooses how the
measure is read (bands under an absolute or a relative threshold, or the full
map) for the CPU and the GPU paths alike; then thresholds and non-maximum
suppression, sub-pixel refinement, X-junctions, and the assembly into corners
(grey units, merging, the pyramid's levels).

=========================  ==============================================================
module                     what it does
=========================  ==============================================================
:mod:`.stage`              the entry point: how the measure is read, and the corners
:mod:`.peaks`              thresholds (absolute, relative, quantile), non-maximum
                           suppression (a compiled scan where few pixels pass), border,
                           mask, ties, top-k on a map
:mod:`.bands`              the same peaks from the measure's bands, in one pass (no
                           H x W map)
:mod:`.stream_quantile`    numpy's quantile of values seen band by band
:mod:`.refine`             sub-pixel refinement: quadratic, gradient (Foerstner's point,
                           iterated, compiled) and adaptive; merging coincident points
:mod:`.x_junctions`        X-junctions as saddle points (``hr``), with their compiled
                           candidates and Newton steps
:mod:`.assemble`           peaks to corners: refinement, units, X-junctions, merge; the
                           pyramid's levels merged at full resolution
=========================  ==============================================================
"""

from .assemble import merge_levels
from .peaks import local_maxima, resolve_threshold, select_peaks, valid_area
from .refine import refine_gradient, refine_gradient_adaptive, refine_quadratic
from .stage import select_corners
from .x_junctions import add_x_junctions, find_saddles

__all__ = [
    "add_x_junctions",
    "find_saddles",
    "local_maxima",
    "merge_levels",
    "refine_gradient",
    "refine_gradient_adaptive",
    "refine_quadratic",
    "resolve_threshold",
    "select_corners",
    "select_peaks",
    "valid_area",
]
