"""Average repeatability under image transforms, the protocol of the paper's Fig. 9.

:mod:`.data` loads the images, :mod:`.transforms` holds the six transform
families and their grids, :mod:`.protocol` the score (eq. 27), the common
region and the parallel run over (image, family) tasks.
"""

from .data import load_images
from .protocol import RepeatabilityReport, evaluate_repeatability, pair_repeatability, repeatability_score
from .transforms import FAMILIES, Transform, affine_for, apply_transform, family_grid, map_points

__all__ = [
    "FAMILIES", "RepeatabilityReport", "Transform", "affine_for", "apply_transform", "evaluate_repeatability",
    "family_grid", "load_images", "map_points", "pair_repeatability", "repeatability_score",
]
