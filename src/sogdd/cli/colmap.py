"""sogdd colmap export FEATDIR --database DB: a feature folder into a COLMAP database.

FEATDIR holds one feature file per image as "sogdd detect DIR --out FEATDIR"
writes it, in any of its formats: <image name>.npz (xy (N, 2), response, size,
and optionally descriptors (N, 128), which only npz files can hold), .csv (x, y,
response, size rows) or .json (x, y, n, response, size); x = column, y = row,
pixel centres at integers. Keypoints are written with +0.5 (COLMAP's pixel
centres) as [x, y, size / 2, 0].

Images already in the database are matched by name. Others are imported from
--images DIR with one shared camera per image size (intrinsics from K.txt or a
YAML there, if any). DB must be a COLMAP database or a new file: anything else
(a text file, an unrelated SQLite file) is refused, untouched. Exported
keypoints that differ from an image's old ones replace them with their
descriptors (deleted if none are exported) and matches (deleted), so the
database never holds descriptors or matches of points that are gone.

Without descriptors in the files, --describe sift (the default when --images
is given) computes OpenCV SIFT descriptors at the points (diameter 8 px times
the pyramid scale, as "sogdd eval sfm" does); COLMAP's matchers need them. The adapter is sogdd.formats.colmap.
"""

from __future__ import annotations

import argparse
import sys

from ._common import HelpFormatter, reporter

__all__ = ["configure"]


def run_export(args: argparse.Namespace) -> int:
    from ..formats.colmap import export_features

    method = None if args.describe == "none" else args.describe
    r = export_features(args.features, args.database, args.images, method, progress=reporter(args))
    print(f"sogdd: wrote {r['keypoints']} keypoints ({r['descriptors']} with descriptors) "
          f"of {r['images']} images into {r['database']}")
    if r["stale_descriptors"]:
        print(f"sogdd: deleted the old descriptors of {r['stale_descriptors']} image(s) (none exported for "
              "the new keypoints)")
    if r["stale_pairs"]:
        print(f"sogdd: deleted the matches of {r['stale_pairs']} image pair(s) whose keypoints changed: "
              "match again")
    return 0


def configure(p: argparse.ArgumentParser) -> None:
    """The ``colmap`` command (sub-command ``export``)."""
    p.description = "COLMAP interoperability (needs pycolmap); sogdd colmap export --help: the details"
    sub = p.add_subparsers(dest="colmap_command", metavar="SUBCOMMAND")
    e = sub.add_parser("export", help="write a feature folder into a COLMAP database", description=__doc__,
                       formatter_class=HelpFormatter)
    e.add_argument("features", metavar="DIR", help="feature folder (sogdd detect --out DIR): .npz, .csv or "
                   ".json files")
    e.add_argument("--database", required=True, metavar="DB", help="COLMAP database (created if missing)")
    e.add_argument("--images", metavar="DIR", help="the images: to add those the database lacks, and for "
                   "descriptors")
    e.add_argument("--describe", choices=("auto", "sift", "rootsift", "none"), default="auto",
                   help="descriptors for files without them (auto: sift when --images is given)")
    e.add_argument("--quiet", action="store_true", help="no progress on stderr")
    e.set_defaults(func=run_export)
    p.set_defaults(func=lambda _args: (p.print_help(sys.stderr), 2)[1])
