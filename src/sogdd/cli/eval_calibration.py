"""``sogdd eval calibration``: calibration targets, rendered through an exactly known camera, and real photos.

Rendered sequences (``--sequences``; all by default): sharp (cells 33-60 px, blur
0.8, noise 2), dense (cells 7-10 px), 6mp (3000 x 2000, cells ~25 px, blur 1.2,
noise 3), blur (sigma 2.5 px, noise 4), partial (6 of 15 views cut by the
frame); a pinhole camera with k1, k2, p1, p2, tilts up to 40 degrees, 4 x 4
supersampling, illumination falloff. ``--draws N`` noise draws per view. Per
method and sequence: boards found, corner recall, wrong labels (after each
view's best label alignment), corner error (mean, RMS, p95, max), and the
calibration's projection difference to the true camera, focal error and RMS
reprojection; time per frame. ``--quick``: two small sequences of 3 views.

Real photos (``--data`` or ``$SOGDD_DATA/calibration``, skipped with
``--no-real``): boards found, label distance after one global offset per set,
RMS reprojection, fx against BoofCV's calibration.

Real photos from other cameras (``--photos``, instead of the above; ``--sets``
to choose sets, ``--views N`` the first N photos of each): every set under
``--data``, each camera of a rig on its own; per set and board method:
complete, partial and extra boards, corners per board, wrong labels against
hand labels, RMS reprojection and ``fx, fy, cx, cy`` of a calibration from the
complete boards beside a reference camera (photos.json, photos.md):
:mod:`sogdd.evaluation.calibration.photos`.

Camera rigs (``--rigs``, instead of the above): rendered rigs with exact ground truth
(parallel: 2 cameras 1280 x 960, baseline 120 mm; convergent: 2 cameras 640 x 480,
300 mm, toe-in 16 deg; trio: 3 cameras 640 x 480, 60 and 250 mm; ``--sequences`` names
rigs, ``--quick`` one small rig) and, with ``--data``, the real ``rig3_ecocheck``
(three cameras); ``--sessions N`` adds the uncertainty's calibration over N
independent sessions of the convergent rig (``--sequences`` to choose it). Methods:
sogdd, opencv-stereo-fix, opencv-stereo-free, opencv-multiview, mrcal (rigs.json,
rigs.md): :mod:`sogdd.evaluation.calibration.rig_metrics`.

A randomized rendered corpus (``--sweep N``, instead of the above; ``--seed S``, ``--max-pixels``):
N single views, each drawing every factor (frame size up to 12 MP, board, cell size, tilt, roll,
lens from pincushion to a 200-degree fisheye, paper margin, contrast, illumination ramp,
vignetting, glare, noise, blur, motion blur, JPEG, textured background, rectangles, a second
board, a hand) from the view's own seed; per method (sogdd, opencv, opencv-sb by default):
complete boards, corners found, wrong labels, off-board points, corner error and time, overall
and by factor bin (sweep.json, sweep.md): :mod:`sogdd.evaluation.calibration.sweep`,
:mod:`sogdd.evaluation.calibration.sweep_metrics`.

Methods (``--methods``, comma-separated; all by default): sogdd, opencv-refine, hr-grid,
opencv, opencv-sb, calib-targets, mrgingham, chess-corners, hr. A comparator
that is not installed is skipped with a note (``pip install calib-targets
chess-corners``, ``apt-get install mrgingham``). Protocol:
:mod:`sogdd.evaluation.calibration`.
"""

from __future__ import annotations

import shlex
import time
from pathlib import Path

from ._common import HelpFormatter, add_output_arguments, print_json, reporter, write_stdout

__all__ = ["register_calibration", "run_calibration"]


def _names(text: str | None, option: str = "--sequences") -> list[str] | None:
    if text is None:
        return None
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise ValueError(f"{option}: no names given")
    return names


def evaluate_photos(args, argv_text: str) -> dict:
    """The ``--photos`` evaluation that ``args`` asks for, as one dict (also what photos.json holds)."""
    from .._version import __version__
    from ..evaluation.calibration.comparators import method_names
    from ..evaluation.calibration.photo_sets import photo_sets
    from ..evaluation.calibration.photos import photo_methods, run_photos
    from ..evaluation.calibration.protocol import availability, data_root

    clash = [f for f in ("quick", "sequences", "no_real", "no_rendered") if getattr(args, f, None)]
    if clash or args.draws != 1:
        drop = (clash or ["draws"])[0].replace("_", "-")
        raise ValueError(f"--photos runs the real photos only; drop --{drop}")
    if args.views is not None and args.views < 3:
        raise ValueError(f"--views must be >= 3 (a calibration needs 3 views), got {args.views}")
    root = data_root(args.data)
    if root is None:
        raise ValueError("--photos: no $SOGDD_DATA/calibration; pass --data DIR")
    sets = photo_sets(root, _names(args.sets, "--sets"))
    methods, notes = availability(photo_methods(method_names(args.methods) if args.methods else None))
    res = run_photos(sets, methods, views=args.views, progress=reporter(args))
    return {"version": __version__, "command": argv_text, "methods": methods, **res,
            "notes": notes + res["notes"]}


def evaluate_sweep(args, argv_text: str) -> dict:
    """The ``--sweep`` evaluation that ``args`` asks for, as one dict (also what sweep.json holds)."""
    from .._version import __version__
    from ..evaluation.calibration.comparators import method_names
    from ..evaluation.calibration.protocol import availability
    from ..evaluation.calibration.sweep import MAX_PIXELS
    from ..evaluation.calibration.sweep_metrics import run_sweep, sweep_methods

    clash = [f for f in ("photos", "rigs", "quick", "sequences", "sets", "sessions", "views", "data", "no_real",
                         "no_rendered", "merge") if getattr(args, f, None) not in (None, False)]
    if clash or args.draws != 1:
        drop = (clash or ["draws"])[0].replace("_", "-")
        raise ValueError(f"--sweep renders its own views (with --seed, --max-pixels, --methods); drop --{drop}")
    if args.sweep < 1:
        raise ValueError(f"--sweep must be >= 1 view, got {args.sweep}")
    seed = 0 if args.seed is None else args.seed
    if seed < 0:
        raise ValueError(f"--seed must be >= 0, got {seed}")
    max_pixels = MAX_PIXELS if args.max_pixels is None else args.max_pixels
    if max_pixels < 160 * 120:
        raise ValueError(f"--max-pixels must be >= 19200 (160 x 120), got {max_pixels}")
    methods, notes = availability(sweep_methods(method_names(args.methods) if args.methods else None))
    if not methods:
        raise ValueError("--sweep: none of the methods can run here (" + "; ".join(notes) + ")")
    res = run_sweep(args.sweep, seed, methods, max_pixels=max_pixels, progress=reporter(args))
    return {"version": __version__, "command": argv_text, **res, "notes": notes}


def _run_sweep(args) -> int:
    from ..evaluation.calibration.sweep_metrics import sweep_markdown, write_sweep

    return _emit(args, evaluate_sweep(args, command_text(args)), write_sweep, sweep_markdown)


def _emit(args, res: dict, write, markdown) -> int:
    """The result into ``--out`` (``write``), then on stdout as JSON or as ``markdown``."""
    if args.out:
        write(res, Path(args.out), merge=args.merge)
    if args.json:
        print_json(res)
    else:
        write_stdout(markdown(res).encode())
    return 0


def _run_photos(args) -> int:
    from ..evaluation.calibration.photos import photos_markdown, write_photos

    return _emit(args, evaluate_photos(args, command_text(args)), write_photos, photos_markdown)


def evaluate(args, argv_text: str) -> dict:
    """Run the evaluation that ``args`` asks for; the results as one dict (also what the JSON holds)."""
    from .._version import __version__
    from ..evaluation.calibration.comparators import method_names
    from ..evaluation.calibration.protocol import availability, data_root, run_real, run_sequences
    from ..evaluation.calibration.sequences import sequences

    if args.no_rendered and args.no_real:
        raise ValueError("--no-rendered and --no-real leave nothing to run")
    if getattr(args, "sets", None):
        raise ValueError("--sets needs --photos")
    if getattr(args, "sessions", None) is not None:
        raise ValueError("--sessions needs --rigs")
    if args.merge and not args.out:
        raise ValueError("--merge needs --out")
    if args.draws < 1:
        raise ValueError(f"--draws must be >= 1, got {args.draws}")
    if args.views is not None and args.views < 3:
        raise ValueError(f"--views must be >= 3 (a calibration needs 3 views), got {args.views}")
    seqs = [] if args.no_rendered else sequences(_names(args.sequences), quick=args.quick)
    methods, notes = availability(method_names(args.methods))
    real_root = None if args.no_real else data_root(args.data)
    if real_root is not None and not real_root.is_dir():
        raise ValueError(f"--data: {real_root} is not a folder")
    if real_root is None and not args.no_real:
        notes.append("real photos skipped: no $SOGDD_DATA/calibration (pass --data)")
    say = reporter(args)
    t0 = time.perf_counter()
    rows = run_sequences(seqs, methods, draws=args.draws, views=args.views, progress=say)
    real = run_real(real_root, methods, progress=say) if real_root is not None else []
    if real_root is not None and "mrgingham" in methods:
        notes.append("mrgingham reads square grids only: not run on the 6 x 4 real boards")
    return {"version": __version__, "command": argv_text, "quick": bool(args.quick), "draws": args.draws,
            "views": args.views,
            "seconds": round(time.perf_counter() - t0, 1), "methods": methods, "notes": notes,
            "sequences": {s.name: s.note for s in seqs}, "synthetic": rows, "real": real}


def evaluate_rigs(args, argv_text: str) -> dict:
    """The ``--rigs`` evaluation that ``args`` asks for, as one dict (also what rigs.json holds)."""
    from .._version import __version__
    from ..evaluation.calibration.protocol import data_root
    from ..evaluation.calibration.rig_comparators import MODEL, rig_method_names
    from ..evaluation.calibration.rig_metrics import (
        rig_availability,
        run_real_rig,
        run_rendered_rigs,
        run_sessions,
    )
    from ..evaluation.calibration.rigs import RIGS, rigs

    if (getattr(args, "photos", False) or args.draws != 1 or args.views is not None
            or getattr(args, "sets", None)):
        raise ValueError("--rigs takes --quick, --sequences (rig names), --methods, --sessions, --data, "
                         "--no-real, --no-rendered")
    if args.sessions is not None and args.sessions < 2:
        raise ValueError(f"--sessions must be >= 2, got {args.sessions}")
    if args.merge and not args.out:
        raise ValueError("--merge needs --out")
    names = _names(args.sequences, "--sequences")
    specs = [] if args.no_rendered else rigs(names, quick=args.quick)
    methods, notes = rig_availability(rig_method_names(args.methods))
    say = reporter(args)
    t0 = time.perf_counter()
    rendered, more = run_rendered_rigs(specs, methods, progress=say)
    notes += more
    sessions = None
    if args.sessions:
        spec = rigs(names[:1], quick=args.quick)[0] if names else (rigs(quick=True)[0] if args.quick
                                                                    else RIGS["convergent"])
        sessions = run_sessions(spec, args.sessions, progress=say)
    real: list = []
    quick_skip = args.quick and not args.data  # the real rig takes minutes: --quick runs it only when asked
    root = None if args.no_real or quick_skip else data_root(args.data)
    if root is not None and (root / "rig3_ecocheck").is_dir():
        real, more = run_real_rig(root, methods, progress=say)
        notes += more
    elif quick_skip and not args.no_real:
        notes.append("real rig skipped with --quick (pass --data to run it)")
    elif not args.no_real:
        notes.append("real rig skipped: no rig3_ecocheck under $SOGDD_DATA/calibration (pass --data)")
    return {"version": __version__, "command": argv_text, "quick": bool(args.quick), "model": MODEL,
            "seconds": round(time.perf_counter() - t0, 1), "methods": methods, "notes": notes,
            "rigs": {s.name: s.note for s in specs}, "rendered": rendered, "sessions": sessions, "real": real}


def _run_rigs(args) -> int:
    from ..evaluation.calibration.rig_metrics import rigs_markdown, write_rigs

    return _emit(args, evaluate_rigs(args, command_text(args)), write_rigs, rigs_markdown)


def run_calibration(args) -> int:
    from ..report.calibration_section import results_markdown, write_results

    if getattr(args, "sweep", None) is not None:
        return _run_sweep(args)
    for flag in ("seed", "max_pixels"):
        if getattr(args, flag, None) is not None:
            raise ValueError(f"--{flag.replace('_', '-')} needs --sweep")
    if getattr(args, "rigs", False):
        return _run_rigs(args)
    if getattr(args, "photos", False):
        return _run_photos(args)
    return _emit(args, evaluate(args, command_text(args)), write_results, results_markdown)


def command_text(args) -> str:
    """The command line that runs what ``args`` asks for (recorded in the results).

    Examples
    --------
    >>> from argparse import Namespace
    >>> command_text(Namespace(quick=True, sequences="sharp", methods=None, draws=1, views=None, data=None,
    ...                        no_real=True, no_rendered=False, out="out dir", merge=False))
    "sogdd eval calibration --quick --sequences sharp --no-real --out 'out dir'"
    """
    parts = ["sogdd", "eval", "calibration"] + (["--quick"] if getattr(args, "quick", False) else [])
    parts += ["--photos"] if getattr(args, "photos", False) else []
    parts += ["--rigs"] if getattr(args, "rigs", False) else []
    if getattr(args, "sweep", None) is not None:
        parts += ["--sweep", str(args.sweep), "--seed", str(getattr(args, "seed", None) or 0)]
    for name in ("max_pixels", "sequences", "sets", "methods", "draws", "views", "sessions", "data"):
        val = getattr(args, name, None)
        if val is not None and not (name == "draws" and val == 1):
            parts += [f"--{name.replace('_', '-')}", str(val)]
    for flag in ("no_real", "no_rendered"):
        if getattr(args, flag, False):
            parts.append("--" + flag.replace("_", "-"))
    if getattr(args, "out", None):
        parts += ["--out", str(args.out)]
    if getattr(args, "merge", False):
        parts.append("--merge")
    return " ".join(shlex.quote(p) for p in parts)


def register_calibration(eval_subparsers) -> None:
    """Add ``calibration`` to ``sogdd eval``."""
    c = eval_subparsers.add_parser(
        "calibration", help="calibration targets: rendered sequences with a known camera, and real photos",
        description=__doc__, formatter_class=HelpFormatter)
    c.add_argument("--quick", action="store_true", help="two small sequences of 3 views (tests, CI)")
    c.add_argument("--sequences", metavar="A,B", help="only these sequences [default: all]")
    c.add_argument("--methods", metavar="A,B", help="only these methods [default: all]")
    c.add_argument("--draws", type=int, default=1, help="noise draws per view")
    c.add_argument("--views", type=int, metavar="N",
                   help="only the first N views of each sequence (cut views kept in proportion) [default: all]")
    c.add_argument("--data", metavar="DIR", help="calibration photos [default: $SOGDD_DATA/calibration]")
    c.add_argument("--no-real", action="store_true", help="skip the real calibration photos")
    c.add_argument("--no-rendered", action="store_true", help="skip the rendered sequences (real photos only)")
    c.add_argument("--photos", action="store_true",
                   help="real photos from other cameras instead: every set under --data, boards counted per "
                        "method (photos.json, photos.md)")
    c.add_argument("--sets", metavar="A,B",
                   help="with --photos: only these sets (a rig's name: all its cameras) [default: all]")
    c.add_argument("--rigs", action="store_true",
                   help="camera rigs instead: rendered rigs with exact ground truth and the real rig3_ecocheck "
                        "(rigs.json, rigs.md); --sequences names rigs")
    c.add_argument("--sessions", type=int, metavar="N",
                   help="with --rigs: the uncertainty's calibration over N independent sessions of one rig")
    c.add_argument("--sweep", type=int, metavar="N",
                   help="a randomized rendered corpus instead: N single views, every factor drawn per view, "
                        "complete boards per method overall and by factor bin (sweep.json, sweep.md)")
    c.add_argument("--seed", type=int, metavar="S",
                   help="with --sweep: the corpus's seed (view k draws from default_rng([S, k])) [default: 0]")
    c.add_argument("--max-pixels", type=int, metavar="P",
                   help="with --sweep: the largest frame drawn, in pixels (small for quick runs) "
                        "[default: 12000000]")
    add_output_arguments(c, "calibration.json, calibration.md and calibration.png")
    c.add_argument("--merge", action="store_true",
                   help="add to the calibration.json already in --out (rows of the same sequence or photo set "
                        "and method are replaced), so that sequences can run one command each")
    c.set_defaults(func=run_calibration)
