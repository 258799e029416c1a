"""3D reconstruction with COLMAP (through pycolmap): the paper's Table 2 protocol.

Pipeline, per detector (:func:`run_sfm`), one function per stage:

1. :func:`import_stage`: the images into a fresh database with one shared
   camera (seeded from ``K.txt`` or a YAML next to the images, see
   :func:`sogdd.formats.colmap.find_camera_prior`);
2. :func:`feature_stage`: detect with the detector spec, describe every point
   with OpenCV's SIFT descriptor (:func:`sogdd.describe`), write keypoints
   (+0.5: COLMAP's pixel centres) and ``uint8`` descriptors;
3. :func:`match_stage`: match every pair, either with COLMAP's exhaustive CPU
   matcher (``matcher="colmap"``: mutual nearest neighbours, no ratio test, as
   the paper does) or with our own mutual-NN matcher (``matcher="mnn"``), then
   COLMAP's geometric verification;
4. :func:`map_stage`: incremental mapping; the largest model is reported
   (:func:`model_stats`), with pose errors against GT cameras where given
   (:mod:`.cameras`) and dense points where COLMAP has CUDA (:mod:`.dense`).

Reported, as in Table 2: registered images, sparse points, mean track length,
mean reprojection error, plus wall time and feature counts.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from itertools import combinations
from pathlib import Path

import numpy as np

from ...formats.colmap import (
    find_camera_prior,
    import_images,
    list_image_names,
    require_pycolmap,
    write_features,
)
from ...image.files import read_image
from ..features import extract_features
from ..matching.protocol import mutual_nn
from ..specs import NATIVE, DetectorSpec, build_detector
from .cameras import camera_errors, read_strecha_cameras
from .dense import dense_points

__all__ = ["feature_stage", "fresh_dir", "import_stage", "map_stage", "match_stage", "matcher_for",
           "model_stats", "pose_errors", "run_sfm", "verified_stats"]


def matcher_for(spec: DetectorSpec, matcher: str) -> str:
    """The matcher that can run ``spec``'s descriptor: ``mnn`` for ``desc=native``, else ``matcher``.

    COLMAP's matcher takes 128-D SIFT-scaled ``uint8`` descriptors; a learned
    descriptor (64-D for XFeat, signed) is matched by our mutual-NN matcher on its
    float values, the same rule (mutual nearest neighbours, no ratio test).

    Examples
    --------
    >>> from sogdd.evaluation.specs import parse_spec
    >>> matcher_for(parse_spec("sift"), "colmap"), matcher_for(parse_spec("xfeat:desc=native"), "colmap")
    ('colmap', 'mnn')
    """
    return "mnn" if spec.desc == NATIVE else matcher


def import_stage(db_path: str, image_dir: Path, names: list[str]):
    """Images into the database with one shared camera: ``(prior, {name: image_id})``."""
    prior = find_camera_prior(image_dir)
    return prior, import_images(db_path, image_dir, names, prior)


def feature_stage(db_path: str, image_dir: Path, ids: dict[str, int], spec: DetectorSpec, *,
                  keep_descriptors: bool = False, say: Callable[[str], None] = lambda _m: None
                  ) -> tuple[dict[str, int], dict[int, np.ndarray]]:
    """Detect, describe and write every image's features: ``(counts per name, descriptors per id)``.

    Descriptors are returned only with ``keep_descriptors`` (for :func:`match_stage`'s ``mnn``).
    """
    pycolmap = require_pycolmap()
    det = build_detector(spec)
    counts, descs = {}, {}
    with pycolmap.Database.open(db_path) as db:
        for name, iid in ids.items():
            fs = extract_features(read_image(image_dir / name), spec, det)
            # the orientation is inside the descriptor; COLMAP's mapper does not use it. A native
            # descriptor is not COLMAP's uint8 SIFT (matcher_for: matched by mnn), so it stays out
            own = spec.desc == NATIVE
            write_features(db, iid, fs.keypoints, fs.size, None, None if own else fs.descriptors)
            counts[name] = len(fs)
            if keep_descriptors:
                descs[iid] = fs.descriptors
            say(f"{spec.label}: {name}: {len(fs)} features")
    return counts, descs


def _match_mnn(db, ids: list[int], descs: dict[int, np.ndarray]) -> int:
    total = 0
    for a, b in combinations(ids, 2):
        m = mutual_nn(descs[a], descs[b]).astype(np.uint32)
        db.write_matches(a, b, m)
        total += len(m)
    return total


def verified_stats(db_path: str) -> tuple[int, int]:
    """The database's geometrically verified image pairs and their inlier matches: ``(pairs, matches)``."""
    pycolmap = require_pycolmap()
    with pycolmap.Database.open(db_path) as db:
        pairs = db.read_two_view_geometries()
        # (pair ids, geometries) in pycolmap 4.x
        geoms = pairs[1] if isinstance(pairs, tuple) else [g for _, g in pairs]
        n_pairs = sum(1 for g in geoms if len(g.inlier_matches) > 0)
        n_inl = int(sum(len(g.inlier_matches) for g in geoms))
    return n_pairs, n_inl


def match_stage(db_path: str, matcher: str, counts: dict[str, int], descs: dict[int, np.ndarray],
                num_threads: int = -1) -> int | None:
    """Match all pairs and verify them geometrically; the raw match count for ``mnn`` (else ``None``)."""
    pycolmap = require_pycolmap()
    if matcher == "colmap":
        mo = pycolmap.FeatureMatchingOptions()
        mo.use_gpu = False
        mo.sift.max_ratio = 1.0  # the paper: no nearest-neighbour ratio test
        mo.sift.cross_check = True
        mo.max_num_matches = max(32768, max(counts.values(), default=0))
        if num_threads > 0:
            mo.num_threads = num_threads
        pycolmap.match_exhaustive(db_path, matching_options=mo, device=pycolmap.Device.cpu)
        return None
    with pycolmap.Database.open(db_path) as db:
        n_raw = _match_mnn(db, sorted(descs), descs)
    pycolmap.geometric_verification(db_path)
    return n_raw


def map_stage(db_path: str, image_dir: Path, sparse: Path, *, seed: int = 0, num_threads: int = -1,
              max_runtime_seconds: float = -1) -> dict:
    """COLMAP's incremental mapper: ``{model index: Reconstruction}`` written under ``sparse``."""
    pycolmap = require_pycolmap()
    opts = pycolmap.IncrementalPipelineOptions()
    opts.random_seed = seed
    opts.num_threads = num_threads
    if max_runtime_seconds and max_runtime_seconds > 0:
        opts.max_runtime_seconds = float(max_runtime_seconds)
    sparse.mkdir(parents=True, exist_ok=True)
    return pycolmap.incremental_mapping(db_path, str(image_dir), str(sparse), opts)


def model_stats(rec) -> dict:
    """Table 2's numbers of one model: registered images, points, track length, reprojection error."""
    return {"registered": int(rec.num_reg_images()), "points": int(rec.num_points3D()),
            "track_length": float(rec.compute_mean_track_length()),
            "reproj_error": float(rec.compute_mean_reprojection_error()),
            "observations": int(rec.compute_num_observations())}


def pose_errors(rec, gt_cameras: str | Path) -> dict:
    """The reconstruction's posed cameras compared with the ground truth's (:func:`camera_errors`)."""
    est = {}
    for im in rec.images.values():
        if im.has_pose:
            pose = im.cam_from_world()
            est[im.name] = (np.asarray(pose.rotation.matrix()), np.asarray(im.projection_center()).ravel())
    return camera_errors(est, read_strecha_cameras(gt_cameras))


def fresh_dir(work_dir: str | Path) -> Path:
    """``work_dir`` made empty (removed first if it exists) and returned."""
    work = Path(work_dir)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    return work


def chosen_images(image_dir: Path, image_names: list[str] | None) -> list[str]:
    """The images of ``image_dir`` to reconstruct: all, or ``image_names`` in folder order (each must exist)."""
    names = list_image_names(image_dir)
    if image_names is None:
        return names
    missing = sorted(set(image_names) - set(names))
    if missing:
        raise ValueError(f"{image_dir}: no image {missing[0]}")
    return [n for n in names if n in set(image_names)]


def run_sfm(
    image_dir: str | Path,
    spec: DetectorSpec,
    work_dir: str | Path,
    *,
    matcher: str = "colmap",
    gt_cameras: str | Path | None = None,
    dense: bool = True,
    num_threads: int = -1,
    seed: int = 0,
    max_runtime_seconds: float = -1,
    image_names: list[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Reconstruct ``image_dir`` with one detector; return Table 2's metrics.

    Parameters
    ----------
    image_dir : path
        Folder of images (``K.txt``/YAML intrinsics beside them are used).
    spec : DetectorSpec
        Detector and feature pipeline (:func:`sogdd.evaluation.specs.parse_spec`).
    work_dir : path
        Database and models go here (``work_dir/database.db``, ``work_dir/sparse``);
        it is cleared first.
    matcher : {"colmap", "mnn"}
        COLMAP's exhaustive CPU matcher (cross-check, ratio test off) or our
        mutual-NN matches; both are followed by COLMAP's geometric verification.
        ``desc=native`` always uses ``mnn`` (:func:`matcher_for`; the result's
        ``matcher`` says which ran).
    gt_cameras : path, optional
        Strecha-format camera folder for pose errors.
    dense : bool
        Try MVS for the dense point count (needs a CUDA build of COLMAP).
    max_runtime_seconds : float
        Limit of the incremental mapper (-1: none).
    image_names : list of str, optional
        Use only these images of the folder.

    Returns
    -------
    dict
        ``registered``, ``images``, ``points``, ``track_length``, ``reproj_error``,
        ``observations``, ``dense_points``, ``features`` (mean per image),
        ``features_total``, ``matches``/``verified_pairs``/``inlier_matches``,
        ``seconds`` (end to end) and ``timing`` per stage, and ``pose_errors``
        with GT cameras.
    """
    pycolmap = require_pycolmap()
    if matcher not in ("colmap", "mnn"):
        raise ValueError(f"matcher must be 'colmap' or 'mnn', got {matcher!r}")
    matcher = matcher_for(spec, matcher)
    image_dir = Path(image_dir)
    names = chosen_images(image_dir, image_names)
    work = fresh_dir(work_dir)
    db_path = str(work / "database.db")
    say = progress or (lambda _m: None)
    pycolmap.set_random_seed(seed)
    timing: dict[str, float] = {}
    t_start = time.perf_counter()

    prior, ids = import_stage(db_path, image_dir, names)
    ids = {n: ids[n] for n in names}
    t0 = time.perf_counter()
    counts, descs = feature_stage(db_path, image_dir, ids, spec, keep_descriptors=matcher == "mnn", say=say)
    timing["features"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    n_raw = match_stage(db_path, matcher, counts, descs, num_threads)
    timing["matching"] = time.perf_counter() - t0
    verified_pairs, inliers = verified_stats(db_path)
    say(f"{spec.label}: {verified_pairs} verified pairs, {inliers} inlier matches")
    t0 = time.perf_counter()
    sparse = work / "sparse"
    recs = map_stage(db_path, image_dir, sparse, seed=seed, num_threads=num_threads,
                     max_runtime_seconds=max_runtime_seconds)
    timing["mapping"] = time.perf_counter() - t0

    result: dict = {
        "detector": spec.label,
        "spec": spec.to_json(),
        "images": len(names),
        "camera_prior": None if prior is None else {"model": prior.model, "source": prior.source},
        "matcher": matcher,
        "features": float(np.mean(list(counts.values()))) if counts else 0.0,
        "features_total": int(sum(counts.values())),
        "matches": n_raw,
        "verified_pairs": verified_pairs,
        "inlier_matches": inliers,
        "models": len(recs),
    }
    if not recs:
        result.update(registered=0, points=0, track_length=None, reproj_error=None, observations=0,
                      dense_points=None)
    else:
        key = max(recs, key=lambda k: (recs[k].num_reg_images(), recs[k].num_points3D()))
        rec = recs[key]
        result.update(model_stats(rec), model_dir=str(sparse / str(key)))
        if gt_cameras is not None:
            result["pose_errors"] = pe = pose_errors(rec, gt_cameras)
            if pe.get("aligned"):
                result.update(rotation_deg_median=pe["rotation_deg_median"],
                              position_median=pe["position_median"])
        t0 = time.perf_counter()
        if dense:
            try:
                result["dense_points"] = dense_points(work, image_dir, sparse / str(key))
            except Exception as exc:  # noqa: BLE001 - MVS failure must not lose the SfM result
                result["dense_points"] = f"n/a: {type(exc).__name__}: {exc}"
        else:
            result["dense_points"] = "not run"
        timing["dense"] = time.perf_counter() - t0
    result["seconds"] = round(time.perf_counter() - t_start, 2)
    result["timing"] = {k: round(v, 2) for k, v in timing.items()}
    (work / "result.json").write_text(json.dumps(result, indent=1))
    return result
