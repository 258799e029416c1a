"""The COLMAP adapter: databases, the +0.5 pixel shift, cameras and feature export (pycolmap).

Used by ``sogdd colmap export`` (:func:`export_features`) and by the SfM
evaluation (:mod:`sogdd.evaluation.sfm`). Needs ``pip install 'sogdd[sfm]'``.

Conventions
-----------
* **Keypoints.** sogdd puts pixel centres at integer coordinates (OpenCV);
  COLMAP puts them at ``+0.5`` (the top-left pixel's centre is ``(0.5, 0.5)``).
  :func:`to_colmap_xy` adds 0.5, :func:`from_colmap_xy` removes it. Keypoints
  are written as ``[x, y, scale, orientation]`` rows, with ``scale = size / 2``
  and the orientation in radians.
* **Descriptors.** COLMAP's SIFT descriptors are ``uint8``: a unit-L2 vector
  times 512, rounded and clipped to 255 (``FeatureDescriptorsToUnsignedByte``).
  OpenCV's SIFT already uses that scale; RootSIFT (unit L2) is multiplied by 512.
* **Cameras.** One shared camera per image size (EXIF is absent in the benchmark
  images), seeded from ``K.txt`` (a 3x3 matrix, the Strecha sets) or from a BoofCV/OpenCV-style
  YAML (``pinhole`` block and ``radial_tangential``, the ``chair`` set) in the
  image folder, else COLMAP's default guess (``SIMPLE_RADIAL``, focal length
  1.2 x the larger image side).

pycolmap is imported lazily so that the rest of sogdd never needs it.
"""

from __future__ import annotations

import os
import re
import shutil
import sqlite3
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..corners import Corners
from ..descriptors import describe
from ..image.files import list_images, read_image
from ..image.header import probe
from .colmap_database import check_database, copy_database, forget_features, quiet_colmap
from .features import feature_files, read_descriptors, read_features
from .safe_write import check_not_inputs, temporary_beside, user_mode

__all__ = [
    "CameraPrior",
    "descriptors_to_colmap",
    "export_features",
    "find_camera_prior",
    "from_colmap_xy",
    "list_image_names",
    "import_images",
    "keypoints_to_colmap",
    "require_pycolmap",
    "to_colmap_xy",
    "write_features",
]


def require_pycolmap():
    """Import pycolmap, or raise ``ValueError`` saying how to install it."""
    try:
        import pycolmap
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ValueError("pycolmap is not installed: pip install 'sogdd[sfm]' (or: pip install pycolmap)"
                         ) from exc
    return pycolmap


def to_colmap_xy(xy: np.ndarray) -> np.ndarray:
    """sogdd/OpenCV pixel coordinates (centres at integers) to COLMAP's (centres at +0.5).

    Examples
    --------
    >>> to_colmap_xy([[0.0, 0.0], [10.25, 3.0]]).tolist()
    [[0.5, 0.5], [10.75, 3.5]]
    """
    return np.asarray(xy, dtype=np.float64).reshape(-1, 2) + 0.5


def from_colmap_xy(xy: np.ndarray) -> np.ndarray:
    """COLMAP pixel coordinates to sogdd/OpenCV's (inverse of :func:`to_colmap_xy`)."""
    return np.asarray(xy, dtype=np.float64).reshape(-1, 2) - 0.5


def keypoints_to_colmap(xy: np.ndarray, size: np.ndarray | None = None, angle_deg: np.ndarray | None = None
                        ) -> np.ndarray:
    """(N, 4) float32 ``[x + 0.5, y + 0.5, size / 2, angle in radians]`` for ``Database.write_keypoints``."""
    p = to_colmap_xy(xy)
    n = len(p)
    scale = np.ones(n) if size is None else np.asarray(size, dtype=np.float64).reshape(-1) / 2.0
    ori = np.zeros(n) if angle_deg is None else np.deg2rad(np.asarray(angle_deg, dtype=np.float64).reshape(-1))
    return np.column_stack([p, scale, ori]).astype(np.float32)


def descriptors_to_colmap(desc: np.ndarray) -> np.ndarray:
    """Float descriptors to COLMAP's uint8 SIFT scale.

    Vectors already on OpenCV's SIFT scale (maximum above 1) are rounded and
    clipped; unit-norm vectors (RootSIFT, or any L2-normalised descriptor) are
    first multiplied by 512, as COLMAP does.
    """
    d = np.asarray(desc, dtype=np.float32)
    if d.size and float(d.max()) <= 1.0 + 1e-6:
        d = d * 512.0
    return np.clip(np.round(d), 0, 255).astype(np.uint8)


@dataclass(frozen=True)
class CameraPrior:
    """A COLMAP camera model name and its parameters (COLMAP's conventions)."""

    model: str
    params: tuple[float, ...]
    source: str

    def params_text(self) -> str:
        return ",".join(f"{v:.10g}" for v in self.params)


def _parse_k(path: Path) -> np.ndarray:
    k = np.loadtxt(path, dtype=np.float64)
    if k.shape != (3, 3):
        raise ValueError(f"{path}: expected a 3x3 calibration matrix")
    return k


def _yaml_numbers(text: str, key: str) -> float | None:
    m = re.search(rf"^\s*{key}\s*:\s*([-+0-9.eE]+)\s*$", text, re.M)
    return float(m.group(1)) if m else None


def _yaml_radial(text: str) -> list[float]:
    m = re.search(r"^\s*radial\s*:\s*\n((?:\s*-\s*[-+0-9.eE]+\s*\n?)+)", text, re.M)
    if not m:
        return []
    return [float(v) for v in re.findall(r"-\s*([-+0-9.eE]+)", m.group(1))]


def find_camera_prior(image_dir: str | Path) -> CameraPrior | None:
    """Intrinsics found next to the images: ``K.txt`` or a pinhole YAML; ``None`` if neither.

    OpenCV-convention intrinsics (principal point with pixel centres at
    integers) are shifted by +0.5 to COLMAP's convention. ``K.txt`` of the
    Strecha sets is used as given (its convention is not documented; the
    difference is half a pixel, far below the accuracy of a seed that bundle
    adjustment refines).
    """
    d = Path(image_dir)
    kf = d / "K.txt"
    if kf.is_file():
        k = _parse_k(kf)
        return CameraPrior("PINHOLE", (k[0, 0], k[1, 1], k[0, 2], k[1, 2]), str(kf))
    for y in sorted(list(d.glob("*.yaml")) + list(d.glob("*.yml"))):
        text = y.read_text(errors="replace")
        fx, fy, cx, cy = (_yaml_numbers(text, k) for k in ("fx", "fy", "cx", "cy"))
        if None in (fx, fy, cx, cy):
            continue
        # BoofCV's intrinsics use pixel centres at integers (as OpenCV): +0.5 for COLMAP
        cx, cy = cx + 0.5, cy + 0.5
        radial = _yaml_radial(text)
        t1 = _yaml_numbers(text, "t1") or 0.0
        t2 = _yaml_numbers(text, "t2") or 0.0
        if radial or t1 or t2:
            k1, k2 = (radial + [0.0, 0.0])[:2]
            return CameraPrior("OPENCV", (fx, fy, cx, cy, k1, k2, t1, t2), str(y))
        return CameraPrior("PINHOLE", (fx, fy, cx, cy), str(y))
    return None


def list_image_names(image_dir: str | Path) -> list[str]:
    """Image file names in a folder (sorted); ``ValueError`` if there is none."""
    d = Path(image_dir)
    if not d.is_dir():
        raise ValueError(f"{d}: not a folder")
    names = [p.name for p in list_images(d)]
    if not names:
        raise ValueError(f"{d}: no images")
    return names


def _sizes(image_dir: Path, names: list[str]) -> dict[tuple[int, int], list[str]]:
    """``{(width, height): names}``, from the files' headers (decoded only where the header is unknown)."""
    groups: dict[tuple[int, int], list[str]] = {}
    for n in names:
        p = image_dir / n
        try:
            with open(p, "rb") as f:
                # the size is in the first bytes of the usual formats; a TIFF's may be anywhere
                data = f.read(1 << 20)
                head = probe(data)
                if head is None and len(data) == 1 << 20:
                    head = probe(data + f.read())
        except OSError as exc:
            raise ValueError(f"{p}: cannot read ({exc.strerror.lower()})") from None
        wh = (head[0], head[1]) if head else tuple(read_image(p).shape[1::-1])
        groups.setdefault(wh, []).append(n)
    return groups


def import_images(database_path: str | Path, image_dir: str | Path, image_names: list[str] | None = None,
                  prior: CameraPrior | None | str = "auto") -> dict[str, int]:
    """Add images to a database with one shared camera per image size; return ``{name: image_id}``.

    ``prior="auto"`` looks for intrinsics with :func:`find_camera_prior`. A
    prior describes one camera, so images of several sizes with a prior are
    refused (``ValueError``), as is an image COLMAP cannot import.
    """
    pycolmap = require_pycolmap()
    img_dir = Path(image_dir)
    names = image_names if image_names is not None else list_image_names(img_dir)
    if prior == "auto":
        prior = find_camera_prior(img_dir)
    groups = _sizes(img_dir, names)
    if prior is not None and len(groups) > 1:
        sizes = ", ".join(f"{w}x{h}" for w, h in groups)
        raise ValueError(f"{img_dir}: images of {len(groups)} sizes ({sizes}) but one camera's intrinsics "
                         f"({prior.source}); export each size from its own folder")
    db = str(database_path)
    with quiet_colmap(db) as log:
        if not Path(db).exists() or Path(db).stat().st_size == 0:
            pycolmap.Database.open(db).close()  # creates the schema
        for group in groups.values():
            # one import per size: COLMAP's single-camera mode refuses an image of another size
            opts = pycolmap.ImageReaderOptions()
            if prior is not None:
                opts.camera_model = prior.model
                opts.camera_params = prior.params_text()
            pycolmap.import_images(db, str(img_dir), pycolmap.CameraMode.SINGLE, group, opts)
        with pycolmap.Database.open(db) as d:
            ids = {im.name: im.image_id for im in d.read_all_images()}
    lost = [n for n in names if n not in ids]
    if lost:
        said = log.last_line(lost[0])
        more = f" (and {len(lost) - 1} other image(s))" if len(lost) > 1 else ""
        why = f": {said}" if said else ""
        raise ValueError(f"{img_dir / lost[0]}: COLMAP could not import it{more}{why}")
    return ids


def write_features(db, image_id: int, xy: np.ndarray, size: np.ndarray | None = None,
                   angle_deg: np.ndarray | None = None, descriptors: np.ndarray | None = None) -> None:
    """Write one image's keypoints (and descriptors) into an open ``pycolmap.Database``.

    Existing keypoints of that image are replaced. Existing descriptors are
    refused (``ValueError``): pycolmap cannot replace one image's, so
    :func:`export_features` deletes them first
    (:func:`~sogdd.formats.colmap_database.forget_features`).
    """
    pycolmap = require_pycolmap()
    kp = keypoints_to_colmap(xy, size, angle_deg)
    if db.exists_keypoints(image_id):
        db.update_keypoints(image_id, kp)
    else:
        db.write_keypoints(image_id, kp)
    if descriptors is not None:
        if len(descriptors) != len(kp):
            raise ValueError(f"{len(descriptors)} descriptors for {len(kp)} keypoints")
        data = descriptors_to_colmap(descriptors)
        fd = pycolmap.FeatureDescriptors(pycolmap.FeatureExtractorType.SIFT, data)
        if db.exists_descriptors(image_id):
            # no update call for descriptors: clear and rewrite is not per image, so refuse
            raise ValueError(f"image {image_id} already has descriptors in the database")
        db.write_descriptors(image_id, fd)


# ----------------------------------------------------------------- export
def _read_feature_file(path: Path) -> tuple[Corners, tuple[int, int], np.ndarray | None]:
    """A ``sogdd detect`` feature file, npz, CSV or JSON (:mod:`sogdd.formats.features`): corners, the
    image shape (height, width; ``(0, 0)`` if unknown) and the optional descriptors (npz only). A bad
    file is a one-line ``ValueError`` naming it."""
    recs = read_features(path)
    if len(recs) != 1:
        raise ValueError(f"{path}: holds {len(recs)} images; export takes one feature file per image")
    return recs[0].corners, recs[0].image_shape, read_descriptors(path)


def export_features(feature_dir: str | Path, database: str | Path, images: str | Path | None = None,
                    describe_method: str | None = "auto", progress=None) -> dict:
    """Write every feature file of ``feature_dir`` into ``database``; return counts.

    Parameters
    ----------
    feature_dir : path
        One feature file per image, ``<image name>.npz``, ``.csv`` or ``.json``, as
        ``sogdd detect DIR --out FEATDIR [--format csv|json]`` writes them
        (:mod:`sogdd.formats.features`); only npz files can also hold ``descriptors``.
    database : path
        COLMAP database (created if missing). Images already in it are matched by name.
        Anything else (a text file, an SQLite file without COLMAP's tables) is refused.
    images : path, optional
        Image folder, to import the images the database lacks (one shared camera
        per image size, :func:`import_images`) and to compute descriptors.
    describe_method : {"auto", "sift", "rootsift", None}
        Descriptors for files without them: ``"auto"`` is ``"sift"`` when
        ``images`` is given, else none. They are computed at the diameter the
        SfM evaluation uses (:func:`sogdd.descriptors.descriptor_sizes`).

    Returns
    -------
    dict
        ``images``, ``keypoints``, ``descriptors`` (counts written), ``database``,
        ``stale_descriptors`` (images whose old descriptors were deleted, as no new
        ones were exported) and ``stale_pairs`` (image pairs whose matches were
        deleted, as the keypoints they index changed).

    An image's keypoints, descriptors and matches always agree: keypoints that
    changed replace the old ones together with their descriptors (deleted when
    the export has none) and their matches (deleted: match again). A bad feature file
    or database is a one-line ``ValueError`` naming it, and the database is then
    left as it was: everything is written to a copy that replaces it only when
    the whole export has succeeded.
    """
    pycolmap = require_pycolmap()
    files = feature_files(Path(feature_dir))
    db_path = Path(database)
    inputs = list(files.values()) + ([Path(images) / n for n in files] if images is not None else [])
    check_not_inputs([("--database", db_path)], inputs)
    exists = check_database(db_path)
    real = Path(os.path.realpath(db_path))  # a symbolic link keeps pointing at the database
    # all or nothing: the work happens on a copy that replaces the database only when everything is written
    try:
        work = temporary_beside(real)
    except OSError as exc:  # the message names the database, not the temporary file
        raise ValueError(f"{db_path}: cannot write in its folder ({exc.strerror.lower()})") from None
    try:
        if exists:
            copy_database(real, work)
            shutil.copymode(real, work)
        else:
            work.unlink()
        result = _export(pycolmap, files, db_path, work, images, describe_method, progress)
        if not exists:
            os.chmod(work, user_mode())
        try:
            os.replace(work, real)
        except OSError as exc:
            raise ValueError(f"{db_path}: cannot replace it ({exc.strerror.lower()})") from None
    finally:
        for leftover in (work, Path(f"{work}-wal"), Path(f"{work}-shm"), Path(f"{work}-journal")):
            leftover.unlink(missing_ok=True)
    return result


def _known_images(pycolmap, files: dict[str, Path], db_path: Path, work: Path, images) -> dict[str, int]:
    """``{name: image_id}`` of the database copy ``work``, after importing the images it lacks."""
    known: dict[str, int] = {}
    if work.exists():
        with quiet_colmap(str(db_path)), pycolmap.Database.open(str(work)) as db:
            known = {im.name: im.image_id for im in db.read_all_images()}
    missing = [n for n in files if n not in known]
    if missing:
        if images is None:
            raise ValueError(f"{len(missing)} image(s) not in {db_path} (e.g. {missing[0]}): pass --images DIR")
        img_dir = Path(images)
        absent = [n for n in missing if not (img_dir / n).is_file()]
        if absent:
            raise ValueError(f"{img_dir / absent[0]}: no such image (feature file {files[absent[0]].name})")
        known = import_images(work, img_dir, missing)
    return known


def _check_sizes(pycolmap, work: Path, db_path: Path, files: dict[str, Path], shapes: dict[str, tuple],
                 known: dict[str, int]) -> None:
    """Refuse features detected on an image of another size than COLMAP's camera for it (rotated by EXIF,
    say): the keypoints would land elsewhere."""
    with quiet_colmap(str(db_path)), pycolmap.Database.open(str(work)) as db:
        cams = {c.camera_id: (c.height, c.width) for c in db.read_all_cameras()}
        cam_of = {im.image_id: im.camera_id for im in db.read_all_images()}
    for name, shape in shapes.items():
        hw = cams.get(cam_of.get(known[name]))
        if tuple(shape) != (0, 0) and hw is not None and tuple(shape) != hw:
            raise ValueError(f"{files[name]}: detected on a {shape[1]}x{shape[0]} image, but COLMAP's camera "
                             f"for {name} is {hw[1]}x{hw[0]}")


def _export(pycolmap, files: dict[str, Path], db_path: Path, work: Path, images, describe_method,
            progress) -> dict:
    from ..descriptors import descriptor_sizes

    if describe_method == "auto":
        describe_method = "sift" if images is not None else None
    # read and check every file before the database is touched
    read = {name: _read_feature_file(f) for name, f in files.items()}
    known = _known_images(pycolmap, files, db_path, work, images)
    _check_sizes(pycolmap, work, db_path, files, {n: r[1] for n, r in read.items()}, known)
    loaded = {}
    for name, (c, _shape, desc) in read.items():
        if desc is None and describe_method and images is not None:
            sized = Corners(c.xy, c.response, descriptor_sizes(c, "auto"), c.level)
            desc = describe(read_image(Path(images) / name), sized, describe_method)
        loaded[name] = (c, desc)
    # what the new keypoints make stale: the descriptors and matches of changed keypoints (unchanged
    # keypoints keep theirs unless new descriptors are exported)
    with quiet_colmap(str(db_path)), pycolmap.Database.open(str(work)) as db:
        had_desc = {known[n] for n in loaded if db.exists_descriptors(known[n])}
        changed = {known[n] for n, (c, _d) in loaded.items()
                   if db.exists_keypoints(known[n]) and not _same_points(db.read_keypoints(known[n]), c.xy)}
    renewed = {known[n] for n, (_c, d) in loaded.items() if d is not None}
    try:
        _, n_pairs = forget_features(work, had_desc & (changed | renewed), changed)
    except sqlite3.Error as exc:
        raise ValueError(f"{db_path}: cannot delete stale rows (SQLite: {exc})") from None
    n_kp = n_desc = 0
    said = []
    with quiet_colmap(str(db_path)), pycolmap.Database.open(str(work)) as db:
        for name, (c, desc) in loaded.items():
            write_features(db, known[name], c.xy, c.size, None, desc)
            n_kp += len(c)
            n_desc += 0 if desc is None else len(desc)
            said.append(f"{name}: {len(c)} keypoints{'' if desc is None else ', descriptors'}")
    for line in said if progress else ():
        progress(line)
    stale = len((had_desc & changed) - renewed)
    return {"images": len(files), "keypoints": n_kp, "descriptors": n_desc, "database": str(db_path),
            "stale_descriptors": stale, "stale_pairs": n_pairs}


def _same_points(old: np.ndarray, xy: np.ndarray) -> bool:
    new = keypoints_to_colmap(xy)
    return old.shape[0] == len(new) and bool(np.array_equal(np.asarray(old)[:, :2], new[:, :2]))
