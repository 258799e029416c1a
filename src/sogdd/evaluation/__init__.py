"""Evaluations of the paper's claims, runnable on any detector of :mod:`sogdd.baselines`.

* :mod:`.gt_accuracy`: ground-truth accuracy, the protocol of Table 1
  (data format in :mod:`.gt_data`, matching in :mod:`.matching`, fair
  threshold tuning in :mod:`.tuning`, figures in :mod:`.overlays`).
* :mod:`.repeatability`: average repeatability under the transforms of
  Fig. 9 (:mod:`.transforms`).
* :mod:`.resolution`: adjacent-corner resolution on rendered END- and
  L-type pairs with exact ground truth.

Detectors are named by specs such as ``sogdd`` or ``sogdd:subpixel=false``
(:mod:`.detectors`).
"""

from .detectors import DetectorSpec, build_detector, parse_spec, parse_specs, registry_names
from .gt_accuracy import GTReport, evaluate_gt
from .gt_data import GTSet, find_gt_sets, load_gt_set, read_corners_csv
from .matching import GTMetrics, gt_metrics, match_points
from .repeatability import RepeatabilityReport, evaluate_repeatability, repeatability_score
from .resolution import ResolutionReport, evaluate_resolution
from .transforms import FAMILIES, Transform, apply_transform, family_grid

__all__ = [
    "DetectorSpec", "build_detector", "parse_spec", "parse_specs", "registry_names",
    "GTReport", "evaluate_gt", "GTSet", "find_gt_sets", "load_gt_set", "read_corners_csv",
    "GTMetrics", "gt_metrics", "match_points",
    "RepeatabilityReport", "evaluate_repeatability", "repeatability_score",
    "ResolutionReport", "evaluate_resolution",
    "FAMILIES", "Transform", "apply_transform", "family_grid",
]
