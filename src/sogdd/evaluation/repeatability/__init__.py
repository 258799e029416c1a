"""Average repeatability under image transforms, the protocol of the paper's Fig. 9.

:mod:`.data` loads the images, :mod:`.transforms` holds the six transform
families and their grids (plus ``blur``, beyond the paper, from :mod:`.blur`),
:mod:`.protocol` the score (eq. 27), the common region, the fixed-count mode
(``top_n``) and the parallel run over (image, family) tasks.
"""

from .blur import apply_blur, gaussian_kernel, motion_angle, motion_kernel
from .data import load_images
from .protocol import (
    RUN_FILE,
    RepeatabilityReport,
    evaluate_repeatability,
    image_digest,
    pair_repeatability,
    repeatability_score,
    top_n_label,
    transforms_digest,
)
from .transforms import (
    ALL_FAMILIES,
    BEYOND_PAPER,
    FAMILIES,
    Transform,
    affine_for,
    apply_transform,
    family_grid,
    map_points,
)

__all__ = [
    "ALL_FAMILIES", "BEYOND_PAPER", "FAMILIES", "RUN_FILE", "RepeatabilityReport", "Transform", "affine_for",
    "apply_blur", "apply_transform", "evaluate_repeatability", "family_grid", "gaussian_kernel", "image_digest",
    "load_images", "map_points", "motion_angle", "motion_kernel", "pair_repeatability", "repeatability_score",
    "top_n_label", "transforms_digest",
]
