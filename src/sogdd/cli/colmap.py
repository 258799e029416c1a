"""``sogdd colmap export FEATDIR --database DB``: a feature folder into a COLMAP database.

``FEATDIR`` holds one file per image as ``sogdd detect DIR --out FEATDIR --format
npz`` writes it: ``<image name>.npz`` with ``xy`` (N, 2; x = column, y = row,
pixel centres at integers), ``response``, ``size`` and optionally
``descriptors`` (N, 128). Keypoints are written with +0.5 (COLMAP's pixel
centres) as ``[x, y, size / 2, 0]``.

Images already in the database are matched by name. Others are imported from
``--images DIR`` with one shared camera (intrinsics from ``K.txt`` or a YAML
there, if any). Without descriptors in the files, ``--describe sift`` (the
default when ``--images`` is given) computes OpenCV SIFT descriptors at the
points with :func:`sogdd.describe` (diameter 8 px times the pyramid scale, as
``sogdd eval sfm`` does); COLMAP's matchers need them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

__all__ = ["register", "export_features"]


def _feature_files(folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        raise ValueError(f"{folder}: not a folder")
    files = {p.name[: -len(".npz")]: p for p in sorted(folder.glob("*.npz"))}
    if not files:
        raise ValueError(f"{folder}: no .npz feature files")
    return files


def export_features(feature_dir: str | Path, database: str | Path, images: str | Path | None = None,
                    describe_method: str | None = "auto", progress=None) -> dict:
    """Write every feature file of ``feature_dir`` into ``database``; return counts.

    Parameters
    ----------
    feature_dir : path
        ``<image name>.npz`` files (``xy``, ``response``, ``size``, optional ``descriptors``).
    database : path
        COLMAP database (created if missing).
    images : path, optional
        Image folder, to import images the database lacks and to compute descriptors.
    describe_method : {"auto", "sift", "rootsift", None}
        Descriptors for files without them: ``"auto"`` is ``"sift"`` when
        ``images`` is given, else none.
    """
    from ..evaluation.colmap_io import import_images, require_pycolmap, write_features

    pycolmap = require_pycolmap()
    files = _feature_files(Path(feature_dir))
    db_path = Path(database)
    known: dict[str, int] = {}
    if db_path.exists():
        with pycolmap.Database.open(str(db_path)) as db:
            known = {im.name: im.image_id for im in db.read_all_images()}
    missing = [n for n in files if n not in known]
    if missing:
        if images is None:
            raise ValueError(f"{len(missing)} image(s) not in {db_path} (e.g. {missing[0]}): pass --images DIR")
        img_dir = Path(images)
        absent = [n for n in missing if not (img_dir / n).is_file()]
        if absent:
            raise ValueError(f"{img_dir / absent[0]}: no such image (feature file {files[absent[0]].name})")
        known = import_images(db_path, img_dir, missing)
    if describe_method == "auto":
        describe_method = "sift" if images is not None else None
    n_kp = n_desc = 0
    with pycolmap.Database.open(str(db_path)) as db:
        for name, f in files.items():
            with np.load(f) as z:
                if "xy" not in z:
                    raise ValueError(f"{f}: no 'xy' array (not a sogdd feature file)")
                xy = np.asarray(z["xy"], dtype=np.float64).reshape(-1, 2)
                size = np.asarray(z["size"], dtype=np.float64) if "size" in z else None
                desc = np.asarray(z["descriptors"]) if "descriptors" in z else None
                level = np.asarray(z["level"]) if "level" in z else None
                resp = np.asarray(z["response"]) if "response" in z else None
            if desc is None and describe_method and images is not None:
                from ..corners import Corners
                from ..describe import describe
                from ..evaluation.matching_common import descriptor_sizes
                from ..io import read_image

                c = Corners(xy, resp, size, level)
                # the same descriptor scale as `sogdd eval sfm` uses for sogdd's corners
                c = Corners(xy, resp, descriptor_sizes(c, "auto"), level)
                desc = describe(read_image(Path(images) / name), c, describe_method)
            iid = known[name]
            if desc is not None and db.exists_descriptors(iid):
                raise ValueError(f"{name} already has descriptors in {db_path}; use a fresh database")
            write_features(db, iid, xy, size, None, desc)
            n_kp += len(xy)
            n_desc += 0 if desc is None else len(desc)
            if progress:
                progress(f"{name}: {len(xy)} keypoints{'' if desc is None else ', descriptors'}")
    return {"images": len(files), "keypoints": n_kp, "descriptors": n_desc, "database": str(db_path)}


def run_export(args) -> int:
    say = None if args.quiet else (lambda m: print(m, file=sys.stderr))
    method = None if args.describe == "none" else args.describe
    r = export_features(args.features, args.database, args.images, method, progress=say)
    print(f"sogdd: wrote {r['keypoints']} keypoints ({r['descriptors']} with descriptors) "
          f"of {r['images']} images into {r['database']}")
    return 0


def register(subparsers) -> None:
    """Add the ``colmap`` command (sub-command ``export``)."""
    p = subparsers.add_parser("colmap", help="COLMAP interoperability (needs pycolmap)", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="colmap_command", metavar="SUBCOMMAND")
    e = sub.add_parser("export", help="write a feature folder into a COLMAP database", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    e.add_argument("features", metavar="DIR", help="feature folder (sogdd detect --out DIR --format npz)")
    e.add_argument("--database", required=True, metavar="DB", help="COLMAP database (created if missing)")
    e.add_argument("--images", metavar="DIR", help="the images: to add those the database lacks, and for "
                   "descriptors")
    e.add_argument("--describe", choices=("auto", "sift", "rootsift", "none"), default="auto",
                   help="descriptors for files without them [auto: sift when --images is given]")
    e.add_argument("--quiet", action="store_true")
    e.set_defaults(func=run_export)

    def _help(_args) -> int:
        p.print_help(sys.stderr)
        return 2

    p.set_defaults(func=_help)
