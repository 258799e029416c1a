"""Stage 2, the measure: from a grey image to the corner measure Upsilon (eqs. 22-25).

In: a grey image on the 0-255 scale (:mod:`sogdd.image`) and a
:class:`MeasureSpec` (sigma^2, K, window, kernel support, measure variant).
Out: Upsilon = det(Lambda) / (tr(Lambda) + varsigma) as a float64 map, or a
stream of bands that :mod:`sogdd.select` pulls (:mod:`.bands`); exact wherever a peak can be, ``-inf`` where a
bound proves it below the threshold.

Vocabulary: the *response* is Upsilon, the measure's value; a *strength* is a
response put in grey levels of corner contrast (:mod:`.units`); a *kernel* is a
SOGDD filter psi (the paper's word), never compiled code, which lives in the
``*_tiles``, ``window_sums``, ``det_unrolled`` and ``bound`` modules.

=========================  ==============================================================
module                     what it does
=========================  ==============================================================
:mod:`.filters`            the SOGDD kernels psi_{sigma,theta} (eq. 22), their steerable
                           basis (g_xx, g_xy, g_yy) and the fused separable basis filter
:mod:`.window`             window shapes (square, disk), offsets, half-sample reflection
:mod:`.gaussian_window`    the Gaussian-weighted window (``hr``)
:mod:`.soddc`              the SODDC matrix and Upsilon, tiled and threaded; the authors'
                           variant; per-point and from-responses forms
:mod:`.units`              grey-level units: Upsilon as the contrast of a right-angle
                           corner, and back
:mod:`.oracle`             the direct float64 definition, the exactness oracle
:mod:`.square_tiles`       compiled tile code for square windows (steering, window sums,
                           det/trace)
:mod:`.general_tiles`      compiled tile code for disk and other windows
:mod:`.window_sums`        compiled weighted window sums (Gaussian window)
:mod:`.det_unrolled`       det/trace unrolled for K = 4, 6, 8 (generated, tools/)
:mod:`.bound`              the Fischer bound that proves pixels below the threshold
:mod:`.relative_floor`     a pruning floor under a relative threshold, from a few exact
                           values
:mod:`.bands`              the measure handed on band by band (crops with their margins),
                           as the selection stage reads it
=========================  ==============================================================
"""

from .filters import kernel_radius, orientations, sogdd_kernel, steerable_basis
from .oracle import reference_lambda, reference_measure
from .soddc import VARSIGMA, MeasureSpec, authors_measure, soddc_at, soddc_from_responses, soddc_measure
from .units import CALIBRATION_CONTRAST, corner_unit, grey_strength, measure_threshold
from .window import window_halfwidths, window_offsets

__all__ = [
    "CALIBRATION_CONTRAST",
    "VARSIGMA",
    "MeasureSpec",
    "authors_measure",
    "corner_unit",
    "grey_strength",
    "kernel_radius",
    "measure_threshold",
    "orientations",
    "reference_lambda",
    "reference_measure",
    "soddc_at",
    "soddc_from_responses",
    "soddc_measure",
    "sogdd_kernel",
    "steerable_basis",
    "window_halfwidths",
    "window_offsets",
]
