"""The rig form of sogdd calibrate: cameras calibrated together, each with --camera NAME PATTERN...

  sogdd calibrate --camera left 'left/*.jpg' --camera right 'right/*.jpg' --board chessboard:9x6 --out rig/
  sogdd calibrate --camera left left.mp4 --camera right right.mp4 --board chessboard:9x6 --out rig/

Part of :mod:`sogdd.cli.calibrate` (its options and help are there): --camera's arguments, parsed into
:func:`sogdd.calib.inputs.calibrate_inputs_into`'s mapping of cameras, and the rig's summary.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ._common import print_json, verdict_level

__all__ = ["RIG_WORDS", "add_rig_arguments", "camera_inputs", "rig_summary"]

#: the rig's words in the library's errors (:class:`sogdd.calib.session.ParameterError`), as this command
#: says them: its cameras are --camera options
RIG_WORDS = {"camera": "--camera", "cameras": "--camera"}

#: the --help text of the rig options (sogdd calibrate's module doc says more)
RIG_HELP = """Rigs (--camera NAME PATTERN... once per camera, the first the reference; one --camera is a rig
  of one, written as a rig):
  the images are matched into frames by the number in their file names (the last
  run of digits: left12.jpg with right12.png, cam0_000012.png with cam1_12.png),
  else, when no name has a number, by sorted order. Frames must match: a number one
  camera lacks is an error, unless --allow-missing-frames (that camera's view of the
  frame is then absent). --board must give the size (chessboard:COLSxROWS or charuco:...).
  --model is every camera's (auto: each camera's own, chosen by its views).
  Writes rig.yaml (OpenCV FileStorage: camera_matrix_NAME, distortion_coefficients_NAME,
  image_size_NAME, R_NAME, T_NAME with x_NAME = R_NAME x_first + T_NAME in the unit of
  --square; for two cameras also stereoCalibrate's R, T, E, F and stereoRectify's R1, R2,
  P1, P2, Q), rig.json (the same with every standard deviation), NAME/ per camera (its
  camera.yaml, camera.json, views.csv, corners.csv) and report.html.
  A rig of videos: --camera NAME VIDEO, one video file per camera (all cameras videos,
  or all images). Frame k of every video is one rig frame; videos of unequal length
  are matched over the shortest one's frames (a note says so). The frames are chosen
  as for one video (--video-step, --max-views): a frame where a camera sees a sharp
  board (a chessboard whole), at a pose new for some camera that sees it, those seen
  by two or more cameras first, then the most new coverage; NAME/views.csv names
  each frame (left.mp4#frame000123) and its reasons."""


def add_rig_arguments(p: argparse.ArgumentParser) -> None:
    """--camera and --allow-missing-frames (:mod:`sogdd.cli.calibrate` calls it)."""
    p.add_argument("--camera", dest="cameras", action="append", nargs="+", metavar=("NAME", "PATTERN"),
                   help="a camera of a rig: its name (letters, digits, _ and -) then its image files, folders "
                        "or glob patterns (quoted), or its one video; once per camera, instead of the images")
    p.add_argument("--allow-missing-frames", action="store_true",
                   help="rig: a frame some cameras have no image of is used by the others (by default an "
                        "error naming the frames)")


def camera_inputs(given: list[list[str]]) -> dict[str, list[str]]:
    """``--camera NAME PATTERN...`` options as ``{name: patterns}`` (the names and their number are the
    library's to check)."""
    out: dict[str, list[str]] = {}
    for name, *patterns in given:
        if not patterns:
            raise ValueError(f"--camera {name}: give the camera's images after its name (--camera NAME "
                             "PATTERN...)")
        if name in out:
            raise ValueError(f"--camera {name}: given twice; give each camera once, with all its images")
        out[name] = patterns
    return out


def _camera_summary(c) -> dict:
    cal, K = c.calibration, c.K
    return {"name": c.name, "model": c.model, "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2],
            "dist": np.ravel(c.dist).tolist(), "std": {k: c.std.get(k) for k in ("fx", "fy", "cx", "cy")},
            "rms": cal.rms, "views_used": cal.n_used, "views": len(cal.names),
            "baseline": c.baseline, "baseline_std": c.std.get("baseline"),
            "rotation_deg": c.rotation_deg, "rotation_std_deg": c.std.get("rotation_deg"),
            "R": np.asarray(c.R).tolist(), "T": np.ravel(c.T).tolist()}


def _fmt_std(v) -> str:
    return "" if v is None or not np.isfinite(v) else f" ± {v:.2g}"


def rig_summary(args: argparse.Namespace, result, written: dict) -> list[tuple[str, str]]:
    """Print the summary (text, or one JSON object); return the verdict's findings."""
    from ..calib.rig.verdict import rig_verdict

    rig = result.rig
    findings = rig_verdict(rig)
    cams = [_camera_summary(c) for c in rig.cameras]
    not_used = [(n, v.name, v.status, v.reason) for n, views in result.views.items() for v in views
                if v.status != "used"]
    n_used = int(np.sum(rig.frame_used))
    if args.json:
        print_json({"out": args.out, "files": sorted(str(p) for p in written.values()), "cameras": cams,
                    "reference": rig.cameras[0].name, "rms": rig.rms, "sigma": rig.sigma,
                    "square": rig.square, "frames_used": n_used, "frames": len(rig.frames),
                    "verdict": [{"level": lv, "text": t} for lv, t in findings],
                    "verdict_level": verdict_level(findings), "notes": list(rig.notes),
                    "not_used": [{"camera": c, "view": n, "status": s, "reason": r} for c, n, s, r in not_used],
                    "unreadable": [v.file for v in result.unreadable]})
        return findings
    first = rig.cameras[0].name
    lines = [f"rig of {len(cams)} cameras: {n_used} of {len(rig.frames)} frames used, RMS {rig.rms:.4f} px; "
             f"poses in {first}'s frame (x_cam = R x_{first} + T), in the unit of --square"]
    width = max(len(c["name"]) for c in cams)
    for c in cams:
        pose = "the reference" if c["name"] == first else (
            f"baseline {c['baseline']:.6g}{_fmt_std(c['baseline_std'])}, "
            f"rotation {c['rotation_deg']:.3f}{_fmt_std(c['rotation_std_deg'])} deg")
        lines.append(f"  {c['name']:<{width}} {c['model']}: fx {c['fx']:.2f} fy {c['fy']:.2f} cx {c['cx']:.2f} "
                     f"cy {c['cy']:.2f}, {pose}, RMS {c['rms']:.4f} px, {c['views_used']} of {c['views']} "
                     "views used")
    lines += [f"  {lv}: {t}" for lv, t in findings]
    lines += [f"  note: {t}" for t in rig.notes]
    lines += [f"  {s} {c}/{n}: {r}" for c, n, s, r in not_used[:5]]
    if len(not_used) > 5:
        lines.append(f"  ... and {len(not_used) - 5} more views not used (NAME/views.csv)")
    main = [n for n in ("rig.yaml", "report.html") if n in written]
    lines.append(f"written to {args.out}/: {', '.join(main)} ...")
    sys.stdout.write("\n".join(lines) + "\n")
    return findings
