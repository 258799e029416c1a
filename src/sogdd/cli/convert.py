"""sogdd convert IN OUT --to FORMAT: a calibration into the files another tool reads, or back.

IN is a sogdd calibration (camera.yaml, camera.json, rig.yaml, rig.json, or the output folder of
sogdd calibrate) or a file or folder in any format below, recognised by its content (--from names
it). OUT is a file or a folder, as the format wants:

  sogdd   camera.yaml (one camera) or rig.yaml (a rig), OpenCV FileStorage
  ros     ROS camera_info YAML: OUT.yaml for one camera; a folder with left.yaml and right.yaml for
          a stereo pair (rectified by cv2.stereoRectify)
  kalibr  Kalibr's camchain YAML (OUT.yaml, or OUT/camchain.yaml): cam0, cam1, ..., T_cn_cnm1
  mrcal   mrcal's .cameramodel (OUT.cameramodel, or OUT/camera-K.cameramodel for each camera)
  colmap  a COLMAP text model folder: cameras.txt and rigs.txt (needs pycolmap)
  mrgingham  the corners, not the camera: IN's corners.csv (a rig's NAME/corners.csv, views named
          NAME/VIEW) as mrgingham's corners.vnl, for mrcal-calibrate-cameras --corners-cache
  kalibr-corners  the corners as Kalibr's target observations: a CSV per camera (OUT.csv, or
          OUT/observations.csv; a rig's OUT/NAME.csv) of timestamp_ns, view, Kalibr's corner id,
          pixel x y, Kalibr's target point and used; an AprilGrid needs --board

A model a format cannot hold (mrcal has no OpenCV fisheye, Kalibr no rational model, ...) is
refused with the reason, and nothing is written; every number goes out and comes back to float
precision. Translations keep the unit of the calibration's square unless --scale changes it
(--scale 0.001 for a square in mm to Kalibr's and ROS's metres). Reading YAML needs PyYAML, and
COLMAP pycolmap: pip install 'sogdd[formats]'. The library: sogdd.calib.exchange.convert.
"""

from __future__ import annotations

import argparse

__all__ = ["configure"]

#: the options that apply to some formats only: option -> (its argument's name, the --to values it applies to)
_ONLY = {"--pattern": ("pattern", ("mrgingham", "kalibr-corners")),
         "--used-only": ("used_only", ("mrgingham", "kalibr-corners")),
         "--board": ("board", ("kalibr-corners",))}


def _check_options(args: argparse.Namespace) -> None:
    """A one-line ``ValueError`` for an option given that the format of ``--to`` has no use for."""
    for flag, (name, formats) in _ONLY.items():
        if getattr(args, name) not in (None, False) and args.to not in formats:
            raise ValueError(f"{flag} applies to --to {' and '.join(formats)}, not to --to {args.to}")
    if args.to == "mrgingham" and args.scale != 1.0:
        raise ValueError("--scale does not apply to --to mrgingham: corners.vnl holds pixels only")
    if args.source is not None and args.to in ("mrgingham", "kalibr-corners"):
        raise ValueError(f"--from names a calibration's format; --to {args.to} reads sogdd's corners.csv")


def run(args: argparse.Namespace) -> int:
    from ..calib.exchange import convert

    _check_options(args)
    if args.to == "mrgingham":
        from ..calib.exchange.mrgingham import write_corners_vnl

        path = write_corners_vnl(args.input, args.output, pattern=args.pattern, used_only=args.used_only)
        print(f"sogdd: wrote the corners as mrgingham's corners.vnl: {path}")
        return 0
    if args.to == "kalibr-corners":
        from ..calib.exchange.kalibr_corners import write_kalibr_corners

        files = write_kalibr_corners(args.input, args.output, pattern=args.pattern, grid=args.board,
                                     used_only=args.used_only, scale=args.scale)
        print(f"sogdd: wrote the corners as Kalibr's observations: {', '.join(str(f) for f in files)}")
        return 0
    rig, files = convert(args.input, args.output, args.to, source_format=args.source, scale=args.scale)
    cams = ", ".join(f"{c.name} ({c.model})" for c in rig.cameras)
    print(f"sogdd: wrote {cams} as {args.to}: {', '.join(str(f) for f in files)}")
    return 0


def configure(p: argparse.ArgumentParser) -> None:
    """The ``convert`` command's arguments."""
    from ..calib.exchange import FORMATS

    p.description = __doc__
    p.add_argument("input", metavar="IN", help="a calibration: sogdd's file or output folder, or any format "
                   "below")
    p.add_argument("output", metavar="OUT", help="the file or folder to write")
    p.add_argument("--to", required=True, choices=(*FORMATS, "mrgingham", "kalibr-corners"),
                   help="the format to write (mrgingham, kalibr-corners: the corners, not the camera)")
    p.add_argument("--from", dest="source", choices=tuple(FORMATS), default=None,
                   help="IN's format (default: recognised from its content)")
    p.add_argument("--scale", type=float, default=1.0, metavar="S",
                   help="multiply every translation (kalibr-corners: every target point) by S (0.001: "
                   "millimetres to metres)")
    p.add_argument("--pattern", type=_pattern, metavar="WxH", default=None,
                   help="--to mrgingham, kalibr-corners: the board's inner corners (default: from the labels)")
    p.add_argument("--used-only", action="store_true",
                   help="--to mrgingham, kalibr-corners: only the corners the calibration used (mrgingham: "
                   "the others '-')")
    p.add_argument("--board", metavar="SPEC", default=None,
                   help="--to kalibr-corners: the AprilGrid, aprilgrid:COLSxROWS:SIZE:SPACING (Kalibr's ids "
                   "and target points of its corners)")
    p.set_defaults(func=run)


def _pattern(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give WxH, such as 9x6") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: W and H are at least 1")
    return w, h
