"""Image matching on homography sequences: the D2-Net HPatches protocol (the paper's Fig. 10).

:mod:`.data` loads HPatches, Oxford and HOMOGR sequences (and published
curves), :mod:`.protocol` matches features by mutual nearest neighbours and
scores the mean matching accuracy.
"""

from .data import D2NET_EXCLUDED, LAYOUTS, HomographySequence, detect_layout, load_published, load_sequences
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
    "D2NET_EXCLUDED", "LAYOUTS", "SPLITS", "THRESHOLDS", "HomographySequence", "MatchingResult",
    "benchmark_info", "detect_layout", "evaluate_features", "evaluate_specs", "load_published",
    "load_sequences", "mma_of_errors", "mutual_nn",
]
