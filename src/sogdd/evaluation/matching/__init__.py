"""Image matching on homography sequences: the D2-Net HPatches protocol (the paper's Fig. 10).

:mod:`.data` loads HPatches, Oxford and HOMOGR sequences (and published
curves), :mod:`.protocol` matches features by mutual nearest neighbours and
scores the mean matching accuracy; :mod:`.homography` scores the homography
estimated from the matches (corner error, AUC at 1/3/5 px).
"""

from .data import D2NET_EXCLUDED, LAYOUTS, HomographySequence, detect_layout, load_published, load_sequences
from .homography import AUC_THRESHOLDS, auc_of_errors, corner_error, estimate_homography
from .protocol import (
    SPLITS,
    THRESHOLDS,
    MatchingResult,
    benchmark_info,
    evaluate_features,
    evaluate_specs,
    mma_of_errors,
    mutual_nn,
)

__all__ = [
    "AUC_THRESHOLDS", "D2NET_EXCLUDED", "LAYOUTS", "SPLITS", "THRESHOLDS", "HomographySequence",
    "MatchingResult", "auc_of_errors", "benchmark_info", "corner_error", "detect_layout", "estimate_homography",
    "evaluate_features", "evaluate_specs", "load_published", "load_sequences", "mma_of_errors", "mutual_nn",
]
