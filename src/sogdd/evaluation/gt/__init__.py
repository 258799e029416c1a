"""Ground-truth accuracy, the protocol of the paper's Table 1.

:mod:`.data` reads GT sets (``image.<ext>`` + ``corners.csv``), :mod:`.metrics`
holds the metrics (missed, false, Le of eq. 26, F1), :mod:`.tuning` the fair
threshold sweep, and :mod:`.protocol` runs detectors on the sets.
"""

from .data import GTSet, find_gt_sets, load_gt_set, read_corners_csv, write_corners_csv
from .metrics import GTMetrics, gt_metrics
from .protocol import GTEntry, GTReport, evaluate_gt, rank_by
from .tuning import SweepCurve, best_point, joint_tuning, sweep_curve

__all__ = [
    "GTEntry", "GTMetrics", "GTReport", "GTSet", "SweepCurve", "best_point", "evaluate_gt", "find_gt_sets",
    "gt_metrics", "joint_tuning", "load_gt_set", "rank_by", "read_corners_csv", "sweep_curve",
    "write_corners_csv",
]
