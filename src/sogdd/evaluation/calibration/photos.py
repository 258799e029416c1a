"""Real photos from other cameras: every board method on every real calibration set, counted side by side.

For each set (:mod:`.photo_sets`: a folder of photos, or each camera of a rig)
and each method, on the same images:

- ``complete``: views whose (first) board has every inner corner of the set's
  board (its labels span the whole pattern, either way round);
- ``partial``: views whose first board has fewer, and the median of their
  corner counts;
- ``extra``: boards beyond the first in a view, summed over the views (sogdd
  only: ``sogdd.calib.detect_boards`` returns every board it finds; the other
  methods return one board at most);
- ``corners per board``: the mean corner count of the first boards found;
- ``wrong labels`` (sets with hand labels): detected corners whose label,
  after the view's best alignment to the hand labels' lattice, is not the hand
  label they sit on (:func:`.metrics.score_view`, as for the rendered
  sequences; the hand labels' lattice: :func:`.photo_sets.hand_lattice`; a
  corner pairs with a hand label within half a cell, so the labels' offset of
  under 1 px does not matter);
- ``calibration``: ``sogdd.calib.calibrate`` on the method's complete boards
  (pinhole with ``k3`` fixed at 0, or OpenCV's fisheye model for a fisheye
  set; outlier rejection on; at least 3 boards), per image size: RMS
  reprojection (px), views used, ``fx, fy, cx, cy``, beside the set's
  reference camera where it has one (:func:`.photo_sets.read_reference`);
- ``ms per view``: the median wall time of the method's call.

The methods are those of :mod:`.comparators` that return boards (``sogdd``
here calls ``sogdd.calib.detect_boards`` itself so as to see every board).
mrgingham reads ``N x N`` boards only and is skipped, with a note, on the
others; a set whose board is not a chessboard (a grid of separate squares) is
skipped with a note. A set whose board no file describes has it inferred from
its views (:func:`.photo_sets.infer_target`, said in a note): every method,
OpenCV's detectors included, is then given that inferred pattern.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ...formats.safe_write import write_text
from .comparators import METHODS, Detection
from .metrics import score_view
from .photo_sets import PhotoSet, hand_lattice

__all__ = ["PHOTO_METHODS", "ViewCount", "count_view", "is_complete", "photo_methods", "run_set", "run_photos",
           "photos_markdown", "write_photos", "merge_photos"]

#: the methods run by default: sogdd, OpenCV's two detectors, calib-targets and mrgingham
PHOTO_METHODS = ("sogdd", "opencv", "opencv-sb", "calib-targets", "mrgingham")
_JSON, _MD = "photos.json", "photos.md"
_MIN_VIEWS = 3


def photo_methods(names: list[str] | None) -> list[str]:
    """The methods to run (default :data:`PHOTO_METHODS`); a points-only method is a ``ValueError``.

    Examples
    --------
    >>> photo_methods(None)[:3]
    ['sogdd', 'opencv', 'opencv-sb']
    >>> photo_methods(["hr"])
    Traceback (most recent call last):
    ...
    ValueError: --photos counts boards; these methods return points only: hr
    """
    names = list(PHOTO_METHODS) if names is None else names
    points = [n for n in names if METHODS[n].kind != "board"]
    if points:
        raise ValueError(f"--photos counts boards; these methods return points only: {', '.join(points)}")
    return names


def is_complete(labels: np.ndarray, pattern: tuple[int, int]) -> bool:
    """Whether ``labels`` are every inner corner of a ``pattern`` board, either way round.

    Examples
    --------
    >>> lab = np.array([(i, j) for j in range(2) for i in range(3)])
    >>> is_complete(lab, (3, 2)), is_complete(lab[:, ::-1] + 4, (3, 2)), is_complete(lab[1:], (3, 2))
    (True, True, False)
    """
    lab = np.unique(np.asarray(labels, dtype=np.int64).reshape(-1, 2), axis=0)
    if len(lab) != pattern[0] * pattern[1]:
        return False
    extent = sorted((lab.max(axis=0) - lab.min(axis=0) + 1).tolist())
    return extent == sorted(pattern)


@dataclass
class ViewCount:
    """One method on one view: corners of each board it returned (first = the main one), wrong labels, time."""

    corners: list[int] = field(default_factory=list)
    complete: bool = False
    wrong: int | None = None
    seconds: float = 0.0

    @property
    def partial(self) -> bool:
        return bool(self.corners) and not self.complete

    @property
    def extra(self) -> int:
        return max(0, len(self.corners) - 1)


def count_view(boards: list[Detection], pattern: tuple[int, int], hand: np.ndarray | None = None,
               seconds: float = 0.0) -> ViewCount:
    """Count one view's boards (module doc); ``hand``: the view's hand labels (points in target order).

    Examples
    --------
    >>> lab = np.array([(i, j) for j in range(4) for i in range(6)])
    >>> full = Detection(lab * 40.0 + 100, lab)
    >>> c = count_view([full, Detection(full.points[:9] + 400, lab[:9])], (6, 4))
    >>> c.corners, c.complete, c.partial, c.extra
    ([24, 9], True, False, 1)
    >>> count_view([Detection(full.points[:12], lab[:12])], (6, 4)).partial
    True
    """
    boards = [b for b in boards if b.found]
    out = ViewCount([len(b.points) for b in boards], seconds=seconds)
    if not boards:
        return out
    first = boards[0]
    out.complete = is_complete(first.labels, pattern)
    lattice = None if hand is None else hand_lattice(hand, pattern)
    if lattice is not None:
        score = score_view(first.points, first.labels, hand, lattice, np.ones(len(hand), bool))
        out.wrong = score.n_wrong
    return out


def _detect(method: str, image: np.ndarray, pattern: tuple[int, int]) -> list[Detection]:
    if method == "sogdd":  # every board, not only the first: extra boards are counted
        from sogdd.calib import detect_boards

        return [Detection(np.asarray(b.image_points, np.float64), np.asarray(b.labels, np.int64))
                for b in detect_boards(image, pattern)]
    det = METHODS[method].detect(image, pattern)
    return [det] if det.found else []


def _calibrations(boards: dict[tuple[int, int], list], square: float, model: str) -> list[dict]:
    from sogdd.calib import Board, calibrate

    out = []
    for size, found in sorted(boards.items()):
        row: dict = {"size": list(size), "boards": len(found)}
        if len(found) < _MIN_VIEWS:
            row["note"] = f"{len(found)} complete board{'s' if len(found) != 1 else ''}: too few to calibrate"
            out.append(row)
            continue
        flags = cv2.CALIB_FIX_K3 if model == "pinhole" else 0
        try:
            cal = calibrate([Board(p, lab) for p, lab in found], size, square=square, model=model, flags=flags,
                            cross_validate=False, min_views=_MIN_VIEWS)
        except (ValueError, cv2.error) as exc:
            row["note"] = f"calibration failed: {str(exc).splitlines()[0]}"
            out.append(row)
            continue
        K = np.asarray(cal.K)
        row.update(rms=round(float(cal.rms), 4), used=int(np.sum(cal.view_used)), fx=round(float(K[0, 0]), 2),
                   fy=round(float(K[1, 1]), 2), cx=round(float(K[0, 2]), 2), cy=round(float(K[1, 2]), 2))
        out.append(row)
    return out


def _summary(counts: list[ViewCount]) -> dict:
    found = [c for c in counts if c.corners]
    partial = [c.corners[0] for c in counts if c.partial]
    wrong = [c.wrong for c in counts if c.wrong is not None]
    times = [c.seconds for c in counts]
    return {
        "views": len(counts),
        "complete": sum(c.complete for c in counts),
        "partial": len(partial),
        "partial_median_corners": float(np.median(partial)) if partial else None,
        "extra": sum(c.extra for c in counts),
        "corners_per_board": round(float(np.mean([c.corners[0] for c in found])), 1) if found else None,
        "labelled_views": len(wrong),
        "wrong_labels": sum(wrong) if wrong else None,
        "ms_per_view": round(1000 * float(np.median(times)), 1) if times else None,
        "seconds": round(float(np.sum(times)), 2),
    }


def _board_notes(photo_set: PhotoSet) -> list[str]:
    """What the set's board is when it is not its own file, or why the set is skipped (no chessboard)."""
    t, name = photo_set.target, photo_set.name
    if t is None:
        return [f"{name}: no board file (calibration_target.yaml, info.txt, an OpenCV calibration with "
                "board_width) and no board size in a clear majority of its views: skipped"]
    if not t.chessboard_like:
        return [f"{name}: a {t.kind.replace('_', ' ')} board, not a chessboard: "
                "no method here reads it, skipped"]
    if t.inferred:
        return [f"{name}: no board file; a {t.pattern[0]} x {t.pattern[1]} board {t.source}; "
                "every method, OpenCV's included, is given that pattern"]
    if Path(t.source).parent != photo_set.folder:
        return [f"{name}: no board file of its own; {'/'.join(Path(t.source).parts[-2:])} read"]
    return []


def run_set(photo_set: PhotoSet, methods: list[str], *, views: int | None = None,
            progress: Callable[[str], None] | None = None) -> tuple[list[dict], list[str]]:
    """Every method on one set (module doc): one row per method, and notes for what was not run."""
    t = photo_set.target
    notes = _board_notes(photo_set)
    if t is None or not t.chessboard_like:
        return [], notes
    run = [m for m in methods if not (METHODS[m].square_only and t.pattern[0] != t.pattern[1])]
    notes += [f"{photo_set.name}: {m} reads N x N boards only, not run on {t.pattern[0]} x {t.pattern[1]}"
             for m in methods if m not in run]
    chosen = list(zip(photo_set.images, photo_set.labels))[:views]
    counts: dict[str, list[ViewCount]] = {m: [] for m in run}
    boards: dict[str, dict] = {m: {} for m in run}
    for k, (path, hand) in enumerate(chosen):
        image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise ValueError(f"cannot read image {path}")
        size = (image.shape[1], image.shape[0])
        for m in run:
            t0 = time.perf_counter()
            dets = _detect(m, image, t.pattern)
            c = count_view(dets, t.pattern, hand, time.perf_counter() - t0)
            counts[m].append(c)
            if c.complete:
                boards[m].setdefault(size, []).append((dets[0].points, dets[0].labels))
        if progress:
            progress(f"{photo_set.name}: view {k + 1}/{len(chosen)}")
    rows = []
    for m in run:
        row = {"set": photo_set.name, "method": m, **_summary(counts[m]),
               "calibration": _calibrations(boards[m], t.square, photo_set.model)}
        rows.append(row)
    return rows, notes


def _set_info(s: PhotoSet) -> dict:
    t = s.target
    return {"folder": str(s.folder), "images": len(s.images), "labelled": s.n_labelled, "model": s.model,
            "target": None if t is None else {"kind": t.kind, "pattern": list(t.pattern), "square": t.square,
                                               "source": t.source},
            "reference": s.reference}


def run_photos(sets: list[PhotoSet], methods: list[str], *, views: int | None = None,
               progress: Callable[[str], None] | None = None) -> dict:
    """Every method on every set: ``{"sets": {name: info}, "rows": [...], "notes": [...], "seconds": s}``."""
    t0 = time.perf_counter()
    rows, notes, info = [], [], {}
    for s in sets:
        r, n = run_set(s, methods, views=views, progress=progress)
        rows += r
        notes += n
        info[s.name] = _set_info(s)
    return {"sets": info, "rows": rows, "notes": notes, "views": views,
            "seconds": round(time.perf_counter() - t0, 1)}


def _fmt(v, digits: int = 2) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def _rms(row: dict) -> str:
    cals = [c for c in row["calibration"] if "rms" in c]
    if not cals:
        return "-"
    return " / ".join(f"{c['rms']:.3f}" for c in cals)


def _board_table(res: dict) -> list[str]:
    lines = ["| set | method | views | complete | partial (median corners) | extra | corners/board | "
             "wrong labels | RMS (px) | ms/view |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in res["rows"]:
        part = f"{r['partial']} ({_fmt(r['partial_median_corners'], 0)})" if r["partial"] else "0"
        extra = str(r["extra"]) if r["method"] == "sogdd" else "-"
        wrong = "-" if r["wrong_labels"] is None else f"{r['wrong_labels']} ({r['labelled_views']} views)"
        lines.append(f"| {r['set']} | {r['method']} | {r['views']} | {r['complete']} | {part} | {extra} | "
                     f"{_fmt(r['corners_per_board'], 1)} | {wrong} | {_rms(r)} | {_fmt(r['ms_per_view'], 0)} |")
    return lines


def _short(cal: dict) -> str:
    """A calibration's failure note up to its first colon (OpenCV's message stays in the JSON)."""
    return cal.get("note", "").split(":")[0]


def _camera_table(res: dict) -> list[str]:
    lines = ["| set | size | method | boards (used) | fx | fy | cx | cy |",
             "|---|---|---|---:|---:|---:|---:|---:|"]
    for name, info in res["sets"].items():
        ref = info.get("reference")
        if ref:
            lines.append(f"| {name} | | reference ({ref['model']}) | | {_fmt(ref['fx'], 1)} | "
                         f"{_fmt(ref['fy'], 1)} | {_fmt(ref['cx'], 1)} | {_fmt(ref['cy'], 1)} |")
        for r in (r for r in res["rows"] if r["set"] == name):
            for c in r["calibration"]:
                size = "x".join(str(v) for v in c["size"])
                used = f"{c['boards']} ({c['used']})" if "used" in c else f"{c['boards']} ({_short(c)})"
                lines.append(f"| {name} | {size} | {r['method']} | {used} | {_fmt(c.get('fx'), 1)} | "
                             f"{_fmt(c.get('fy'), 1)} | {_fmt(c.get('cx'), 1)} | {_fmt(c.get('cy'), 1)} |")
    return lines


def photos_markdown(res: dict) -> str:
    """The result as markdown: the boards table, the cameras table (beside references), notes.

    Examples
    --------
    >>> print(photos_markdown({"sets": {}, "rows": [], "notes": ["x: skipped"]}).splitlines()[0])
    # Real photos from other cameras
    """
    out = ["# Real photos from other cameras", ""]
    if res.get("command"):
        out += [f"`{res['command']}` ({res.get('seconds', 0)} s)", ""]
    out += _board_table(res) + ["", "Calibration from each method's complete boards:", ""] + _camera_table(res)
    refs = {i["reference"]["note"] for i in res["sets"].values() if i.get("reference")}
    out += [""] + [f"- reference: {n}" for n in sorted(refs)] + [f"- {n}" for n in res.get("notes", [])]
    return "\n".join(out) + "\n"


def merge_photos(old: dict, new: dict) -> dict:
    """``old`` with ``new``'s sets and rows added; rows of the same set and method replaced.

    Examples
    --------
    >>> a = {"sets": {"s": {}}, "rows": [{"set": "s", "method": "opencv", "complete": 1}], "notes": ["n"]}
    >>> b = {"sets": {"s": {}}, "rows": [{"set": "s", "method": "opencv", "complete": 2}], "notes": ["n"]}
    >>> merge_photos(a, b)["rows"]
    [{'set': 's', 'method': 'opencv', 'complete': 2}]
    """
    keys = {(r["set"], r["method"]) for r in new["rows"]}
    rows = [r for r in old.get("rows", []) if (r["set"], r["method"]) not in keys] + new["rows"]
    order = list(dict.fromkeys([*old.get("sets", {}), *new["sets"]]))
    rows.sort(key=lambda r: order.index(r["set"]) if r["set"] in order else len(order))
    return {**old, **new, "sets": {**old.get("sets", {}), **new["sets"]}, "rows": rows,
            "notes": list(dict.fromkeys([*old.get("notes", []), *new.get("notes", [])]))}


def write_photos(res: dict, out: str | Path, *, merge: bool = False) -> Path:
    """Write ``photos.json`` and ``photos.md`` into ``out`` (``merge``: into the JSON there); its path."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / _JSON
    if merge and path.is_file():
        res = merge_photos(json.loads(path.read_text()), res)
    write_text(path, json.dumps(res, indent=1))
    write_text(out / _MD, photos_markdown(res))
    return path
