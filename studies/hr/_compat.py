"""The evaluation functions the study calls, from the per-experiment packages (or their older flat modules).

The study ran against the flat modules of commit 0926ca8 (``sogdd.evaluation.gt_accuracy`` ...); the
evaluation package has since been split into one package per experiment with the same functions.
"""

from __future__ import annotations

try:  # one package per experiment
    from sogdd.evaluation.features import extract_features
    from sogdd.evaluation.gt import find_gt_sets, joint_tuning, sweep_curve
    from sogdd.evaluation.matching import load_sequences
    from sogdd.evaluation.matching.protocol import match_errors, mma_of_errors, mutual_nn
    from sogdd.evaluation.repeatability import load_images, pair_repeatability
    from sogdd.evaluation.repeatability.transforms import FAMILIES, apply_transform, family_grid
    from sogdd.evaluation.resolution import configurations, render_configuration, score_configuration
    from sogdd.evaluation.specs import DetectorSpec, build_detector, parse_value

    def feature_spec():
        return DetectorSpec("proto", desc="sift")
except ImportError:  # the flat modules
    from sogdd.evaluation.detectors import DetectorSpec, build_detector, parse_value  # type: ignore
    from sogdd.evaluation.gt_data import find_gt_sets  # type: ignore
    from sogdd.evaluation.homography_data import load_sequences  # type: ignore
    from sogdd.evaluation.matching_common import FeatureSpec, extract_features  # type: ignore
    from sogdd.evaluation.matching_mma import match_errors, mma_of_errors, mutual_nn  # type: ignore
    from sogdd.evaluation.transforms import FAMILIES, apply_transform, family_grid  # type: ignore
    from sogdd.evaluation.tuning import joint_tuning, sweep_curve  # type: ignore

    from sogdd.evaluation.repeatability import load_images, pair_repeatability  # type: ignore
    from sogdd.evaluation.resolution import (  # type: ignore
        configurations,
        render_configuration,
        score_configuration,
    )

    def feature_spec():
        return FeatureSpec("proto", desc="sift")

__all__ = ["FAMILIES", "DetectorSpec", "apply_transform", "build_detector", "configurations",
           "extract_features", "family_grid", "feature_spec", "find_gt_sets", "joint_tuning",
           "load_images", "load_sequences", "match_errors", "mma_of_errors", "mutual_nn",
           "pair_repeatability", "parse_value", "render_configuration", "score_configuration",
           "sweep_curve"]
