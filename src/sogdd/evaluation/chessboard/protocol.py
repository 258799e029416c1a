"""The dense-checkerboard benchmark: every row on every rendered board, scored per cell size.

:func:`run_benchmark` renders each scene of :func:`~.scenes.scene_grid` once,
runs every row (:mod:`.rows`) on it and scores the detections
(:mod:`.metrics`). :func:`evaluate` is the one-detector shortcut that other
studies call with custom configurations.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from .metrics import ImageScore, pool, score_image
from .rows import make_row, make_rows
from .scenes import CELLS, FULL_GRID, QUICK_GRID, render_board, scene_grid

__all__ = ["ChessboardReport", "run_benchmark", "evaluate", "clean_json"]


@dataclass
class ChessboardReport:
    """Per (row, scene) scores; pooled per cell size on demand."""

    labels: list[str]
    cells: list[float]
    quick: bool
    seed: int
    records: list[dict] = field(default_factory=list)  # detector, cell, angle, psf, noise, score
    seconds: dict = field(default_factory=dict)  # detector -> detection seconds (all scenes)

    def per_cell(self, label: str, **where: float) -> dict[str, dict]:
        """``cell -> {mean_error, p95_error, recall, false, ...}`` for one row.

        ``where`` restricts to scenes with given ``angle``, ``psf`` or ``noise``.
        """
        acc: dict[float, list[ImageScore]] = defaultdict(list)
        for r in self.records:
            if r["detector"] != label or any(r[k] != v for k, v in where.items()):
                continue
            acc[r["cell"]].append(r["score"])
        return {f"{c:g}": pool(acc[c]) for c in self.cells if acc.get(c)}

    def summary(self) -> dict[str, dict]:
        """``detector -> cell -> {mean_error, p95_error, recall, false, located, counts}``."""
        return {lab: self.per_cell(lab) for lab in self.labels}

    def by_condition(self, key: str) -> dict[str, dict]:
        """``detector -> value of key (psf, noise or angle) -> cell -> row``."""
        vals = sorted({r[key] for r in self.records})
        return {lab: {f"{v:g}": self.per_cell(lab, **{key: v}) for v in vals} for lab in self.labels}

    def to_json(self) -> dict:
        g = QUICK_GRID if self.quick else FULL_GRID
        return {
            "quick": self.quick, "seed": self.seed, "cells": [float(c) for c in self.cells],
            "grid": {"phases": g.phases, "angles": list(g.angles), "psf": list(g.psfs),
                     "noise": list(g.noises)},
            "radius": 1.0, "capture": "cell/2",
            "seconds": self.seconds,
            "detectors": self.summary(),
        }

    def table(self, key: str = "mean_error") -> str:
        """A Markdown table: rows = detectors, columns = cells, ``key`` / recall per cell."""
        head = "| detector | " + " | ".join(f"{c:g} px" for c in self.cells) + " |"
        lines = [f"{key} (px) / recall / false per corner / duplicates per corner", "", head,
                 "|---|" + "---|" * len(self.cells)]
        for lab in self.labels:
            pc = self.per_cell(lab)
            cells = []
            for c in self.cells:
                r = pc.get(f"{c:g}")
                if r is None:
                    cells.append("-")
                    continue
                v = r[key]
                cells.append(f"{'n/a' if v is None else f'{v:.2f}'} / {r['recall']:.2f} / "
                             f"{r['false']:.2f} / {r['duplicates']:.2f}")
            lines.append(f"| {lab} | " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"

    def write(self, out: str | os.PathLike) -> list[Path]:
        """``chessboard.json`` and ``chessboard.md`` in ``out`` (figure: ``sogdd.report.chessboard_plot``)."""
        o = Path(out)
        o.mkdir(parents=True, exist_ok=True)
        js = self.to_json()
        js["by_psf"] = self.by_condition("psf")
        js["by_noise"] = self.by_condition("noise")
        (o / "chessboard.json").write_text(json.dumps(clean_json(js), indent=1))
        (o / "chessboard.md").write_text(self.table())
        return [o / "chessboard.json", o / "chessboard.md"]


def clean_json(obj):
    """``obj`` with numpy scalars as Python numbers and non-finite floats as ``None``."""
    if isinstance(obj, dict):
        return {str(k): clean_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean_json(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def run_benchmark(detectors: Any = None, *, cells=CELLS, quick: bool = False, seed: int = 0,
                  progress: bool = False) -> ChessboardReport:
    """Run rows on every scene and keep the per-image scores.

    Parameters
    ----------
    detectors : str, list or callable, optional
        Anything :func:`~.rows.make_rows` accepts (default: :data:`~.rows.DEFAULT_ROWS`).
    cells : sequence of float
        Cell sizes in px (each in [2, 64]).
    quick : bool
        The small grid (:data:`~.scenes.QUICK_GRID`).
    seed : int
        Seeds the phases and the noise.
    progress : bool
        A progress bar on stderr.
    """
    rows = make_rows(detectors)
    cells = [float(c) for c in cells]
    if not cells:
        raise ValueError("no cell sizes given")
    scenes = scene_grid(cells, quick=quick, seed=seed)
    rep = ChessboardReport([r.label for r in rows], sorted(set(cells)), quick, seed)
    secs = dict.fromkeys(rep.labels, 0.0)
    for s in tqdm(scenes, desc="chessboard", disable=not progress, leave=False):
        rb = render_board(s)
        for row in rows:
            t0 = time.perf_counter()
            xy = row.run(rb.image, s.pattern_size)
            secs[row.label] += time.perf_counter() - t0
            sc = score_image(rb.corners, rb.region, xy, s.cell)
            rep.records.append({"detector": row.label, "cell": s.cell, "angle": s.angle,
                                "psf": s.psf, "noise": s.noise, "score": sc})
    rep.seconds = {k: round(v, 3) for k, v in secs.items()}
    return rep


def evaluate(detector: Any, *, cells=CELLS, quick: bool = False, seed: int = 0) -> dict[str, dict]:
    """Score one detector on the benchmark: ``cell -> {mean_error, p95_error, recall, false, ...}``.

    Parameters
    ----------
    detector : str, DetectorSpec, callable or detector object
        A registry spec (``"sogdd:sigma2=2.0"``), ``"gftt+subpix"``,
        ``"chessboard-sb"``, an object with ``detect_corners(image)``, or any
        callable ``image (uint8 H x W) -> (N, 2) xy`` (x = column, pixel
        centres at integers).
    cells, quick, seed
        As :func:`run_benchmark`.

    Returns
    -------
    dict
        Keys are the cell sizes as text (``"3"``, ``"16"``); values as
        :meth:`.metrics.CellScore.as_dict`: ``recall`` (within 1 px),
        ``false`` (per inner corner), ``mean_error`` and ``p95_error`` (px, over
        corners located within half a cell), ``located`` and raw counts.

    Examples
    --------
    >>> import cv2
    >>> def peaks(img):  # Shi-Tomasi maxima, no refinement
    ...     p = cv2.goodFeaturesToTrack(img, 0, 0.01, 2)
    ...     return np.zeros((0, 2)) if p is None else p.reshape(-1, 2)
    >>> r = evaluate(peaks, cells=[16], quick=True)
    >>> {"mean_error", "p95_error", "recall", "false"} <= set(r["16"])
    True
    >>> r["16"]["located"] > 0.9
    True
    """
    row = make_row(detector)
    return run_benchmark([row], cells=cells, quick=quick, seed=seed).per_cell(row.label)
