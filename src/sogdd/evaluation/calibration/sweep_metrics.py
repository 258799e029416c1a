"""The randomized corpus's benchmark: every method on every view of :mod:`.sweep`, scored, and its tables.

:func:`run_sweep` renders views ``0 .. n - 1`` of a sweep (:func:`.sweep.sweep_view`), runs every
board method's ``detect(image, pattern)`` (:data:`~.comparators.METHODS`) on each and scores it
(:func:`score_detection`, the rules in :mod:`.sweep`'s doc: complete boards, corners found, wrong
labels, off-board points, corner error, time); :data:`FACTOR_BINS` bins each drawn factor for the
by-factor table; :func:`sweep_markdown` and :func:`write_sweep` give ``sweep.md`` and ``sweep.json``
(``sogdd eval calibration --sweep N --seed S``).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...formats.safe_write import write_text
from .comparators import METHODS, Detection
from .metrics import error_stats, local_cell, score_view
from .sweep import LENSES, MAX_PIXELS, SWEEP_METHODS, SweepView, sweep_view

__all__ = ["FACTOR_BINS", "OFF_BOARD_PX", "FactorBins", "factor_table", "run_sweep", "score_detection",
           "sweep_markdown", "sweep_methods", "write_sweep"]

#: a returned point farther than this (px) from every inner corner is off the board
OFF_BOARD_PX = 3.0
#: each method runs once, untimed, on the sweep's first view at this size before the views it is scored on
WARM_PIXELS = 320 * 240


def score_detection(view: SweepView, det: Detection) -> dict:
    """One method's result on one view (module doc), as JSON values.

    Examples
    --------
    >>> v = sweep_view(1, 4, max_pixels=320 * 240)
    >>> r = score_detection(v, Detection(v.corners.copy(), v.labels.copy()))
    >>> r["complete"], r["wrong"], r["off_board"], r["recalled"] == int(v.expected.sum())
    (True, 0, 0, True)
    >>> score_detection(v, Detection(np.zeros((0, 2)), None))["complete"]
    False
    """
    return _scored(view, det)[0]


def _scored(view: SweepView, det: Detection) -> tuple[dict, np.ndarray]:
    """:func:`score_detection`'s dict and the errors (px) of the correctly labelled corners."""
    s = score_view(det.points, det.labels, view.corners, view.labels, view.expected)
    pts = np.asarray(det.points, dtype=np.float64).reshape(-1, 2)
    off = 0
    if len(pts):
        near = np.min(np.linalg.norm(pts[:, None] - view.corners[None], axis=2), axis=1)
        off = int(np.sum(~(near <= OFF_BOARD_PX)))
    n = int(view.expected.sum())
    e = s.errors
    return {"found": bool(det.found), "complete": bool(det.found and n > 0 and s.recalled == n),
            "points": int(len(pts)), "recalled": int(s.recalled), "wrong": int(s.n_wrong), "off_board": off,
            "flipped": bool(s.flipped),
            "error_mean": round(float(e.mean()), 4) if len(e) else None,
            "error_p95": round(float(np.percentile(e, 95)), 4) if len(e) else None}, e


def sweep_methods(names: list[str] | None) -> list[str]:
    """The methods to run (default :data:`SWEEP_METHODS`); a points-only method is a ``ValueError``.

    Examples
    --------
    >>> sweep_methods(None)
    ['sogdd', 'opencv', 'opencv-sb']
    >>> sweep_methods(["hr"])
    Traceback (most recent call last):
    ...
    ValueError: --sweep counts complete boards; these methods return points only: hr
    """
    names = list(SWEEP_METHODS) if names is None else list(names)
    unknown = [n for n in names if n not in METHODS]
    if unknown:
        raise ValueError(f"unknown method(s) {', '.join(unknown)}; known: {', '.join(METHODS)}")
    points = [n for n in names if METHODS[n].kind != "board"]
    if points:
        raise ValueError("--sweep counts complete boards; these methods return points only: "
                         + ", ".join(points))
    return names


def _run_method(name: str, view: SweepView) -> tuple[dict, np.ndarray]:
    t0 = time.perf_counter()
    try:
        det = METHODS[name].detect(view.image, view.pattern)
    except Exception as exc:  # noqa: BLE001 - one method's failure on one view is a result, not the end
        det, failed = Detection(np.zeros((0, 2)), None), f"{type(exc).__name__}: {exc}"
    else:
        failed = None
    dt = time.perf_counter() - t0
    res, errors = _scored(view, det)
    res["ms"] = round(1000 * dt, 1)
    if failed:
        res["failed"] = failed
    return res, errors


def _view_record(view: SweepView) -> dict:
    f = view.factors
    cells = local_cell(view.corners, view.labels)
    return {"index": f.index, "factors": f.to_dict(), "expected": int(view.expected.sum()),
            "covered": view.labels[view.covered].tolist(),
            "cell_min_px": round(float(np.min(cells)), 2), "render_s": round(view.render_s, 3), "results": {}}


def run_sweep(n: int, seed: int, methods: list[str] | None = None, *, max_pixels: int = MAX_PIXELS,
              progress: Callable[[str], None] | None = None) -> dict:
    """Render views ``0 .. n - 1`` of sweep ``seed``, run ``methods`` on each and score them (module doc).

    Each method first runs once, untimed, on view 0 rendered at :data:`WARM_PIXELS`, so that no view's
    time holds a first call's compiling or importing.

    Returns a dict: ``seed``, ``n``, ``max_pixels``, ``methods``, ``seconds`` (wall), ``render_seconds``,
    ``summary`` (per method: views, complete, found, recall, wrong labels, off-board points, corner
    error, ms per view), ``by_factor`` (rows of :data:`FACTOR_BINS`' bins: factor, bin, views and
    each method's complete boards) and ``views`` (each view's factors and results).

    Examples
    --------
    >>> res = run_sweep(2, 1, ["opencv"], max_pixels=320 * 240)
    >>> res["summary"]["opencv"]["views"], res["by_factor"][0]["factor"], len(res["views"])
    (2, 'all', 2)
    """
    if int(n) < 1:
        raise ValueError(f"the sweep needs >= 1 view, got {n}")
    methods = sweep_methods(methods)
    t0 = time.perf_counter()
    warm = sweep_view(seed, 0, max_pixels=WARM_PIXELS)
    for m in methods:  # untimed: a method's first call compiles or imports (35 s for sogdd's cold cache)
        try:
            METHODS[m].detect(warm.image, warm.pattern)
        except Exception:  # noqa: BLE001, S110 - a failure is scored on the views it happens on, not here
            pass
    views, errors = [], {m: [] for m in methods}
    for k in range(int(n)):
        view = sweep_view(seed, k, max_pixels=max_pixels)
        rec = _view_record(view)
        for m in methods:
            rec["results"][m], e = _run_method(m, view)
            errors[m].append(e)
        views.append(rec)
        if progress:
            f = view.factors
            done = " ".join(f"{m}:{'ok' if rec['results'][m]['complete'] else '-'}" for m in methods)
            progress(f"sweep: view {k + 1}/{n} {f.width}x{f.height} {f.cols}x{f.rows} cell {f.cell_px:.0f} px "
                     f"{f.lens} (render {view.render_s:.1f} s) {done}")
    return {"seed": int(seed), "n": int(n), "max_pixels": int(max_pixels), "methods": methods,
            "seconds": round(time.perf_counter() - t0, 1),
            "render_seconds": round(sum(v["render_s"] for v in views), 1),
            "summary": {m: _summary(views, m, errors[m]) for m in methods},
            "by_factor": factor_table(views, methods), "views": views}


def _summary(views: list[dict], m: str, errors: list[np.ndarray]) -> dict:
    rs = [v["results"][m] for v in views]
    ms = np.array([r["ms"] for r in rs])
    expected = sum(v["expected"] for v in views)
    return {"views": len(rs), "complete": sum(r["complete"] for r in rs), "found": sum(r["found"] for r in rs),
            "recall": round(sum(r["recalled"] for r in rs) / max(1, expected), 4),
            "wrong_labels": sum(r["wrong"] for r in rs), "wrong_views": sum(r["wrong"] > 0 for r in rs),
            "off_board": sum(r["off_board"] for r in rs),
            "off_board_views": sum(r["off_board"] > 0 for r in rs),
            "flipped_views": sum(r["flipped"] for r in rs), "failed": sum("failed" in r for r in rs),
            "corner": error_stats(np.concatenate(errors) if errors else np.zeros(0)),
            "ms_median": round(float(np.median(ms)), 1), "ms_mean": round(float(ms.mean()), 1),
            "ms_max": round(float(ms.max()), 1)}


# ---------------------------------------------------------------------------------------------
# the tables


@dataclass(frozen=True)
class FactorBins:
    """A factor's bins: ``value`` of a view's factors (a dict); ``edges`` split a number into
    ``len(edges) + 1`` bins named ``labels`` (``[edges[i - 1], edges[i])``), or, without edges,
    ``value`` is the bin's name itself and ``labels`` their order.

    Examples
    --------
    >>> FactorBins("noise", lambda f: f["noise"], (3.0, 6.0), ("0-3", "3-6", "6-12")).bin({"noise": 3.0})
    '3-6'
    """

    name: str
    value: Callable[[dict], float | str]
    edges: tuple[float, ...] = ()
    labels: tuple[str, ...] = ()

    def bin(self, factors: dict) -> str:
        v = self.value(factors)
        if not self.edges:
            return str(v)
        return self.labels[int(np.searchsorted(self.edges, float(v), side="right"))]


def _yes(key: str) -> Callable[[dict], str]:
    return lambda f: "yes" if f[key] else "no"


def _jpeg(f: dict) -> str:
    return "none" if f["jpeg"] is None else ("60-95" if f["jpeg"] >= 60 else "30-59")


#: the factors' bins of the by-factor table
FACTOR_BINS: tuple[FactorBins, ...] = (
    FactorBins("frame (MP)", lambda f: f["width"] * f["height"] / 1e6, (1.0, 4.0), ("< 1", "1-4", ">= 4")),
    FactorBins("inner corners", lambda f: f["cols"] * f["rows"], (30, 70), ("9-29", "30-69", "70-144")),
    FactorBins("cell (px)", lambda f: f["cell_px"], (20.0, 60.0), ("8-20", "20-60", "60-300")),
    FactorBins("tilt (deg)", lambda f: f["tilt"], (30.0, 50.0), ("0-30", "30-50", "50-70")),
    FactorBins("lens", lambda f: f["lens"], (), LENSES),
    FactorBins("margin (cells)", lambda f: f["margin"], (0.3,), ("< 0.3", ">= 0.3")),
    FactorBins("outer squares", lambda f: "full" if f["edge"] == 1.0 else "cut", (), ("full", "cut")),
    FactorBins("contrast (grey)", lambda f: f["light"] - f["dark"], (80.0,), ("< 80", ">= 80")),
    FactorBins("ramp", lambda f: f["ramp"], (0.25,), ("< 0.25", ">= 0.25")),
    FactorBins("vignetting", lambda f: f["vignetting"], (0.3,), ("< 0.3", ">= 0.3")),
    FactorBins("glare", _yes("glare"), (), ("no", "yes")),
    FactorBins("noise (grey)", lambda f: f["noise"], (3.0, 6.0), ("0-3", "3-6", "6-12")),
    FactorBins("blur (px)", lambda f: f["blur"], (1.8,), ("< 1.8", ">= 1.8")),
    FactorBins("motion (px)", lambda f: f["motion"], (5.0, 10.0), ("0-5", "5-10", "10-20")),
    FactorBins("jpeg", _jpeg, (), ("none", "60-95", "30-59")),
    FactorBins("texture", _yes("texture"), (), ("no", "yes")),
    FactorBins("rectangles", _yes("rectangles"), (), ("no", "yes")),
    FactorBins("second board", _yes("second"), (), ("no", "yes")),
    FactorBins("hand", _yes("hand"), (), ("no", "yes")),
)


def factor_table(views: list[dict], methods: list[str]) -> list[dict]:
    """Rows ``{factor, bin, views, complete: {method: count}}``: first all views, then every bin of
    :data:`FACTOR_BINS` that holds a view.

    Examples
    --------
    >>> v = [{"factors": {"noise": 1.0}, "results": {"m": {"complete": True}}},
    ...      {"factors": {"noise": 7.0}, "results": {"m": {"complete": False}}}]
    >>> factor_table(v, ["m"])[0]
    {'factor': 'all', 'bin': '', 'views': 2, 'complete': {'m': 1}}
    """
    def row(factor: str, b: str, vs: list[dict]) -> dict:
        return {"factor": factor, "bin": b, "views": len(vs),
                "complete": {m: sum(bool(v["results"][m]["complete"]) for v in vs) for m in methods}}

    rows = [row("all", "", views)]
    for fb in FACTOR_BINS:
        try:
            keys = [fb.bin(v["factors"]) for v in views]
        except KeyError:
            continue
        for label in fb.labels:
            vs = [v for v, k in zip(views, keys) if k == label]
            if vs:
                rows.append(row(fb.name, label, vs))
    return rows


def _pct(k: int, n: int) -> str:
    return f"{k} ({100 * k / n:.0f}%)" if n else "-"


def _num(v, digits: int) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}f}"


def _overall_table(res: dict) -> list[str]:
    lines = ["| method | views | complete | boards returned | corners found | wrong labels (views) | "
             "off-board points (views) | error mean (px) | error p95 (px) | ms/view median | ms/view max |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for m, s in res["summary"].items():
        lines.append(f"| {m} | {s['views']} | {_pct(s['complete'], s['views'])} | {s['found']} | "
                     f"{100 * s['recall']:.1f}% | {s['wrong_labels']} ({s['wrong_views']}) | "
                     f"{s['off_board']} ({s['off_board_views']}) | {_num(s['corner']['mean'], 3)} | "
                     f"{_num(s['corner']['p95'], 3)} | {s['ms_median']:.0f} | {s['ms_max']:.0f} |")
    return lines


def _factor_lines(res: dict) -> list[str]:
    methods = res["methods"]
    lines = ["| factor | bin | views | " + " | ".join(methods) + " |",
             "|---|---|---:|" + "---:|" * len(methods)]
    for r in res["by_factor"]:
        cells = " | ".join(_pct(r["complete"][m], r["views"]) for m in methods)
        lines.append(f"| {r['factor']} | {r['bin']} | {r['views']} | {cells} |")
    return lines


def sweep_markdown(res: dict) -> str:
    """The sweep as markdown: the command, the overall table, the complete boards by factor bin.

    Examples
    --------
    >>> res = run_sweep(1, 1, ["opencv"], max_pixels=320 * 240)
    >>> md = sweep_markdown(res)
    >>> md.splitlines()[0], "| all |  | 1 |" in md
    ('# Chessboard sweep', True)
    """
    share = 100 * res["render_seconds"] / max(res["seconds"], 1e-9)
    cap = "" if res["max_pixels"] == MAX_PIXELS else f", max_pixels={res['max_pixels']}"
    out = ["# Chessboard sweep", ""]
    if res.get("command"):
        out += [f"`{res['command']}`", ""]
    out += [f"{res['n']} rendered views of seed {res['seed']} (frames up to {res['max_pixels'] / 1e6:g} MP), "
            f"{res['seconds']} s, of which rendering {res['render_seconds']} s ({share:.0f}%). A view is "
            f"re-rendered by `sogdd.evaluation.calibration.sweep.sweep_view({res['seed']}, index{cap})`.", "",
            "## Overall", ""] + _overall_table(res)
    out += ["", "## Complete boards by factor", ""] + _factor_lines(res)
    out += [""] + [f"- {n}" for n in res.get("notes", [])]
    return "\n".join(out).rstrip() + "\n"


def _plain(obj):
    """``obj`` with non-finite floats as None (JSON has no NaN)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    return obj


def write_sweep(res: dict, out: str | Path, *, merge: bool = False) -> Path:
    """Write ``sweep.json`` and ``sweep.md`` into ``out`` (made if missing); the JSON's path.

    ``merge`` is not supported (a sweep is one run): ``ValueError``.
    """
    if merge:
        raise ValueError("--merge does not apply to --sweep")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "sweep.json"
    write_text(path, json.dumps(_plain(res), indent=1))
    write_text(out / "sweep.md", sweep_markdown(res))
    return path
