"""Dense points from COLMAP's multi-view stereo, where pycolmap has CUDA."""

from __future__ import annotations

from pathlib import Path

from ...formats.colmap import require_pycolmap

__all__ = ["DENSE_NA", "dense_points", "undistort_for_mvs"]

DENSE_NA = "n/a: needs a CUDA build"


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
