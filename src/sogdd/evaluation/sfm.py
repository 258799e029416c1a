"""3D reconstruction with COLMAP (through pycolmap): the paper's Table 2 protocol.

Pipeline, per detector (:func:`run_sfm`):

1. import the images into a fresh database with one shared camera (seeded from
   ``K.txt`` or a YAML next to the images, see :mod:`.colmap_io`);
2. detect with the detector spec, describe every point with OpenCV's SIFT
   descriptor (:func:`sogdd.describe`), write keypoints (+0.5: COLMAP's pixel
   centres) and ``uint8`` descriptors;
3. match every pair, either with COLMAP's exhaustive CPU matcher
   (``matcher="colmap"``: mutual nearest neighbours, no ratio test, as the
   paper does) or with our own mutual-NN matcher (``matcher="mnn"``), then
   COLMAP's geometric verification;
4. incremental mapping; the largest model is reported.

Reported, as in Table 2: registered images, sparse points, mean track length,
mean reprojection error, plus wall time and feature counts. Dense points need
COLMAP's patch-match stereo, which only a CUDA build has; :func:`dense_points`
runs it where available and otherwise reports ``"n/a: needs a CUDA build"``.

Where ground-truth cameras exist (Strecha's ``gt_dense_cameras``), the model is
aligned to them by a similarity transform fitted to the camera centres
(Umeyama, least squares) and per-camera rotation and position errors are given.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

import numpy as np

from ..io import read_image
from .colmap_io import find_camera_prior, import_images, list_images, require_pycolmap, write_features
from .matching_common import FeatureSpec, build_detector, extract_features
from .matching_mma import mutual_nn

__all__ = [
    "DENSE_NA",
    "GTCamera",
    "align_similarity",
    "camera_errors",
    "dense_points",
    "undistort_for_mvs",
    "read_strecha_cameras",
    "run_sfm",
]

DENSE_NA = "n/a: needs a CUDA build"


# ----------------------------------------------------------------- ground truth
@dataclass(frozen=True)
class GTCamera:
    """A ground-truth camera: ``K``, world-to-camera rotation ``R``, centre ``C``, image size."""

    K: np.ndarray
    R: np.ndarray
    C: np.ndarray
    size: tuple[int, int]


def read_strecha_cameras(folder: str | Path) -> dict[str, GTCamera]:
    """Read Strecha-format cameras: ``{image name: GTCamera}``.

    Each ``NAME.camera`` file holds K (3 lines), the radial distortion
    (``0 0 0``), a rotation (3 lines), the camera centre C, and ``width height``.
    The rotation is camera-to-world (Strecha's convention, ``P = K [R^T | -R^T C]``);
    it is stored transposed here, as world-to-camera.
    """
    out = {}
    for f in sorted(Path(folder).glob("*.camera")):
        v = np.array(f.read_text().split(), dtype=np.float64)
        if v.size < 26:
            raise ValueError(f"{f}: expected 26 numbers, got {v.size}")
        k = v[0:9].reshape(3, 3)
        r_c2w = v[12:21].reshape(3, 3)
        out[f.name[: -len(".camera")]] = GTCamera(k, r_c2w.T, v[21:24].copy(), (int(v[24]), int(v[25])))
    if not out:
        raise ValueError(f"{folder}: no *.camera files")
    return out


def align_similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity ``dst ~ s R src + t`` (Umeyama 1991): returns ``(s, R, t)``."""
    src = np.asarray(src, dtype=np.float64)
    dst = np.asarray(dst, dtype=np.float64)
    if len(src) < 3:
        raise ValueError("need at least 3 points to fit a similarity")
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    cov = b.T @ a / len(src)
    u, d, vt = np.linalg.svd(cov)
    e = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        e[2, 2] = -1
    r = u @ e @ vt
    var = (a**2).sum() / len(src)
    s = float(np.trace(np.diag(d) @ e) / var) if var > 0 else 1.0
    return s, r, md - s * r @ ms


def _rot_angle_deg(r: np.ndarray) -> float:
    # atan2 of the sine and cosine parts stays accurate near 0 where arccos does not
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(w) / 2.0, (np.trace(r) - 1.0) / 2.0)))


def camera_errors(est: dict[str, tuple[np.ndarray, np.ndarray]], gt: dict[str, GTCamera]) -> dict:
    """Align estimated cameras to GT and measure them.

    Parameters
    ----------
    est : dict
        ``{image name: (R_world_to_cam, centre)}`` of the reconstruction.
    gt : dict
        ``{image name: GTCamera}``.

    Returns
    -------
    dict
        ``per_camera`` (name -> rotation error in degrees, position error in GT
        units), their means and medians, the scale, and the number of cameras
        used. The similarity is fitted to all common camera centres.
    """
    names = [n for n in est if n in gt]
    if len(names) < 3:
        return {"aligned": False, "reason": f"only {len(names)} cameras in common with the GT", "n": len(names)}
    src = np.array([est[n][1] for n in names])
    dst = np.array([gt[n].C for n in names])
    s, r, t = align_similarity(src, dst)
    per = {}
    for n in names:
        r_est, c_est = est[n]
        c_al = s * r @ c_est + t
        # world-to-camera rotation of the estimate, expressed in the GT frame
        r_al = r_est @ r.T
        per[n] = {"rotation_deg": _rot_angle_deg(r_al @ gt[n].R.T),
                  "position": float(np.linalg.norm(c_al - gt[n].C))}
    rot = np.array([v["rotation_deg"] for v in per.values()])
    pos = np.array([v["position"] for v in per.values()])
    return {"aligned": True, "n": len(names), "scale": s, "per_camera": per,
            "rotation_deg_mean": float(rot.mean()), "rotation_deg_median": float(np.median(rot)),
            "position_mean": float(pos.mean()), "position_median": float(np.median(pos))}


# ----------------------------------------------------------------- pipeline
def _match_mnn(db, ids: list[int], descs: dict[int, np.ndarray]) -> int:
    total = 0
    for a, b in combinations(ids, 2):
        m = mutual_nn(descs[a], descs[b]).astype(np.uint32)
        db.write_matches(a, b, m)
        total += len(m)
    return total


def _verified_stats(db_path: str) -> tuple[int, int]:
    pycolmap = require_pycolmap()
    with pycolmap.Database.open(db_path) as db:
        pairs = db.read_two_view_geometries()
        # (pair ids, geometries) in pycolmap 4.x
        geoms = pairs[1] if isinstance(pairs, tuple) else [g for _, g in pairs]
        n_pairs = sum(1 for g in geoms if len(g.inlier_matches) > 0)
        n_inl = int(sum(len(g.inlier_matches) for g in geoms))
    return n_pairs, n_inl


def undistort_for_mvs(mvs_dir: Path, image_dir: Path, model_dir: Path, max_image_size: int = 2000) -> Path:
    """COLMAP's image undistortion into an MVS workspace (CPU; no CUDA needed).

    ``max_image_size`` caps the undistorted images' larger side (COLMAP's MVS
    default is the full size; 2000 px keeps a 6 MP set within GPU-time limits).
    """
    pycolmap = require_pycolmap()
    opts = pycolmap.UndistortCameraOptions()
    opts.max_image_size = int(max_image_size)
    Path(mvs_dir).parent.mkdir(parents=True, exist_ok=True)
    pycolmap.undistort_images(str(mvs_dir), str(model_dir), str(image_dir), undistort_options=opts)
    return Path(mvs_dir)


def dense_points(workspace: Path, image_dir: Path | None = None, model_dir: Path | None = None, *,
                 max_image_size: int = 2000) -> int | str:
    """Dense points from COLMAP's MVS (patch-match stereo, then fusion), or :data:`DENSE_NA`.

    Parameters
    ----------
    workspace : path
        The MVS workspace is ``workspace/mvs``. When it does not exist yet it is
        made from ``image_dir`` and ``model_dir`` by :func:`undistort_for_mvs`,
        which needs no CUDA; a workspace prepared beforehand can be carried to a
        machine with a CUDA build.

    Returns
    -------
    int or str
        The number of fused points (``workspace/mvs/fused.ply`` is written), or
        ``"n/a: needs a CUDA build"`` when pycolmap has no CUDA.
    """
    pycolmap = require_pycolmap()
    if not getattr(pycolmap, "has_cuda", False):
        return DENSE_NA
    mvs = Path(workspace) / "mvs"
    if not mvs.is_dir():
        if image_dir is None or model_dir is None:
            raise ValueError(f"{mvs}: no MVS workspace, and no images/model to make one")
        undistort_for_mvs(mvs, Path(image_dir), Path(model_dir), max_image_size)
    pm = pycolmap.PatchMatchOptions()
    pm.max_image_size = int(max_image_size)
    pm.geom_consistency = True
    pycolmap.patch_match_stereo(str(mvs), options=pm)
    fo = pycolmap.StereoFusionOptions()
    fo.max_image_size = int(max_image_size)
    try:
        fused = pycolmap.stereo_fusion(str(mvs / "fused.ply"), str(mvs), options=fo, output_type="ply")
    except ValueError:  # an output type this pycolmap does not know: its default binary model
        (mvs / "fused").mkdir(exist_ok=True)
        fused = pycolmap.stereo_fusion(str(mvs / "fused"), str(mvs), options=fo)
    return int(fused.num_points3D())


def run_sfm(
    image_dir: str | Path,
    spec: FeatureSpec,
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
    spec : FeatureSpec
        Detector and feature pipeline (:func:`.matching_common.parse_feature_spec`).
    work_dir : path
        Database and models go here (``work_dir/database.db``, ``work_dir/sparse``);
        it is cleared first.
    matcher : {"colmap", "mnn"}
        COLMAP's exhaustive CPU matcher (cross-check, ratio test off) or our
        mutual-NN matches; both are followed by COLMAP's geometric verification.
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
    image_dir = Path(image_dir)
    names = list_images(image_dir)
    if image_names is not None:
        missing = sorted(set(image_names) - set(names))
        if missing:
            raise ValueError(f"{image_dir}: no image {missing[0]}")
        names = [n for n in names if n in set(image_names)]
    work = Path(work_dir)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    db_path = str(work / "database.db")
    say = progress or (lambda _m: None)
    pycolmap.set_random_seed(seed)
    timing: dict[str, float] = {}
    t_start = time.perf_counter()

    # 1. images and camera
    prior = find_camera_prior(image_dir)
    ids = import_images(db_path, image_dir, names, prior)

    # 2-3. features
    t0 = time.perf_counter()
    det = build_detector(spec.name, **spec.params)
    counts, descs = {}, {}
    with pycolmap.Database.open(db_path) as db:
        for name in names:
            img = read_image(image_dir / name)
            fs = extract_features(img, spec, det)
            iid = ids[name]
            # the orientation is inside the descriptor; COLMAP's mapper does not use it
            write_features(db, iid, fs.keypoints, fs.size, None, fs.descriptors)
            counts[name] = len(fs)
            if matcher == "mnn":
                descs[iid] = fs.descriptors
            say(f"{spec.label}: {name}: {len(fs)} features")
    timing["features"] = time.perf_counter() - t0

    # 4. matching and geometric verification
    t0 = time.perf_counter()
    if matcher == "colmap":
        mo = pycolmap.FeatureMatchingOptions()
        mo.use_gpu = False
        mo.sift.max_ratio = 1.0  # the paper: no nearest-neighbour ratio test
        mo.sift.cross_check = True
        mo.max_num_matches = max(32768, max(counts.values(), default=0))
        if num_threads > 0:
            mo.num_threads = num_threads
        pycolmap.match_exhaustive(db_path, matching_options=mo, device=pycolmap.Device.cpu)
        n_raw = None
    else:
        with pycolmap.Database.open(db_path) as db:
            n_raw = _match_mnn(db, sorted(descs), descs)
        pycolmap.geometric_verification(db_path)
    timing["matching"] = time.perf_counter() - t0
    verified_pairs, inliers = _verified_stats(db_path)
    say(f"{spec.label}: {verified_pairs} verified pairs, {inliers} inlier matches")

    # 5. incremental mapping
    t0 = time.perf_counter()
    opts = pycolmap.IncrementalPipelineOptions()
    opts.random_seed = seed
    opts.num_threads = num_threads
    if max_runtime_seconds and max_runtime_seconds > 0:
        opts.max_runtime_seconds = float(max_runtime_seconds)
    sparse = work / "sparse"
    sparse.mkdir()
    recs = pycolmap.incremental_mapping(db_path, str(image_dir), str(sparse), opts)
    timing["mapping"] = time.perf_counter() - t0

    result: dict = {
        "detector": spec.label,
        "spec": spec.describe(),
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
        result.update(
            registered=int(rec.num_reg_images()),
            points=int(rec.num_points3D()),
            track_length=float(rec.compute_mean_track_length()),
            reproj_error=float(rec.compute_mean_reprojection_error()),
            observations=int(rec.compute_num_observations()),
            model_dir=str(sparse / str(key)),
        )
        if gt_cameras is not None:
            gt = read_strecha_cameras(gt_cameras)
            est = {}
            for im in rec.images.values():
                if im.has_pose:
                    pose = im.cam_from_world()
                    centre = np.asarray(im.projection_center()).ravel()
                    est[im.name] = (np.asarray(pose.rotation.matrix()), centre)
            result["pose_errors"] = camera_errors(est, gt)
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
