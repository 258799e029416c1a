"""3D reconstruction with COLMAP, the protocol of the paper's Table 2 (needs pycolmap).

:mod:`.pipeline` runs the stages (import, features, matching, mapping), :mod:`.seeds`
repeats matching and mapping over seeds, :mod:`.batch` runs every detector,
:mod:`.cameras` measures poses against ground-truth cameras, :mod:`.dense`
counts dense points where COLMAP has CUDA. The database conventions live in
:mod:`sogdd.formats.colmap`.
"""

from .batch import evaluate_sfm
from .cameras import GTCamera, align_similarity, camera_errors, read_strecha_cameras
from .dense import DENSE_NA, dense_points, undistort_for_mvs
from .pipeline import run_sfm
from .seeds import run_sfm_seeds, seed_summary

__all__ = ["DENSE_NA", "GTCamera", "align_similarity", "camera_errors", "dense_points", "evaluate_sfm",
           "read_strecha_cameras", "run_sfm", "run_sfm_seeds", "seed_summary", "undistort_for_mvs"]
