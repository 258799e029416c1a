"""The five benchmarks of the hr study's objective (docs/hr.md, section 1), on one half of the data.

Every benchmark calls the package's evaluation functions; only the glue (the
dev/confirmation split, top-500 selection, the blur family that the
repeatability package does not have yet) lives here.

A *detector* is anything with ``detect_corners(image) -> Corners`` and
``permissive()`` (the registry's objects and :class:`proto.ProtoDetector`).
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import cv2
import numpy as np
from _compat import (
    FAMILIES,
    apply_transform,
    configurations,
    extract_features,
    family_grid,
    feature_spec,
    find_gt_sets,
    joint_tuning,
    load_images,
    load_sequences,
    match_errors,
    mma_of_errors,
    mutual_nn,
    pair_repeatability,
    render_configuration,
    score_configuration,
    sweep_curve,
)

from sogdd.image.files import read_image

DATA = Path(os.environ.get("SOGDD_DATA", "/work/shared/data"))
HALVES = ("dev", "conf")
TOP_N = 500
#: screening (exploration) mode: 3 of the 6 dev photos for repeatability, every 3rd adjacent-corner
#: configuration, no matching; declared in docs/hr.md
SCREEN = os.environ.get("HR_SCREEN", "") != ""


def half_of(names: list[str], half: str) -> list[str]:
    """Sorted-name parity: even positions are development, odd confirmation (docs/hr.md, section 2)."""
    s = sorted(names)
    return s[0::2] if half == "dev" else s[1::2]


def seed_of(half: str) -> int:
    return 0 if half == "dev" else 1


def _top(det, image, n: int = TOP_N):
    """The ``n`` strongest points with the threshold off (prototypes cut before refining: same points)."""
    if hasattr(det, "top"):
        return det.top(n).detect_corners(image).xy
    return _sorted_perm(det, image).xy[:n]


def _sorted_perm(det, image):
    c = det.permissive().detect_corners(image)
    r = np.nan_to_num(np.asarray(c.response, dtype=np.float64), nan=-np.inf)
    return c.subset(np.argsort(-r, kind="stable"))


# -- B1: GT joint-threshold F1 ------------------------------------------------------------
def bench_gt(det, half: str) -> dict:
    sets = find_gt_sets(DATA / "corners_gt")
    keep = set(half_of([s.name for s in sets], half))
    curves = []
    for s in sets:
        if s.name in keep:
            p = _sorted_perm(det, s.image)
            curves.append(sweep_curve(s.corners, p.xy, p.response, 2.0))
    t, idx = joint_tuning(curves)
    m = curves[0].metrics(idx[0])
    for c, i in zip(curves[1:], idx[1:]):
        m = m + c.metrics(i)
    return {"f1": m.f1, "precision": m.precision, "recall": m.recall, "le": m.le, "threshold": t}


# -- B2: top-500 repeatability with the blur family ----------------------------------------
BLUR_QUICK = [("gauss", s) for s in (1.0, 2.0, 3.0, 4.0, 5.0)] + [("motion", n) for n in (3, 7, 11, 15)]


def motion_kernel(length: int, angle: float) -> np.ndarray:
    """A normalised line of ``length`` px through the centre at ``angle`` (anti-aliased)."""
    k = np.zeros((length, length), np.float32)
    c = (length - 1) / 2
    dx, dy = math.cos(angle) * c, math.sin(angle) * c
    sh = 8
    p0 = (int(round((c - dx) * 2**sh)), int(round((c - dy) * 2**sh)))
    p1 = (int(round((c + dx) * 2**sh)), int(round((c + dy) * 2**sh)))
    cv2.line(k, p0, p1, 1.0, 1, cv2.LINE_AA, sh)
    return k / k.sum()


def blur(image: np.ndarray, kind: str, param: float, seed: int) -> np.ndarray:
    """Identity-geometry blur: Gaussian (sigma) or motion (length, seeded random angle)."""
    img = image.astype(np.float32)
    if kind == "gauss":
        out = cv2.GaussianBlur(img, (0, 0), float(param), borderType=cv2.BORDER_REFLECT)
    else:
        ang = float(np.random.default_rng([seed, int(param)]).uniform(0, np.pi))
        out = cv2.filter2D(img, -1, motion_kernel(int(param), ang), borderType=cv2.BORDER_REFLECT)
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def bench_repeat(det, half: str) -> dict:
    imgs = load_images(DATA / "repeatability")
    names = [n for n, _ in imgs]
    keep = set(half_of(names, half))
    if SCREEN:
        keep = set(sorted(keep)[0::2])
    fam: dict[str, list[float]] = {f: [] for f in (*FAMILIES, "blur")}
    ident = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    for i, (name, img) in enumerate(imgs):
        if name not in keep:
            continue
        ref = _top(det, img)
        for f in FAMILIES:
            for tr in family_grid(f, quick=True):
                timg, a, _ = apply_transform(img, tr, seed=i)
                xy = _top(det, timg)
                fam[f].append(pair_repeatability(ref, xy, a, img.shape)[3])
        for kind, prm in BLUR_QUICK:
            xy = _top(det, blur(img, kind, prm, i))
            fam["blur"].append(pair_repeatability(ref, xy, ident, img.shape)[3])
    out = {f: float(np.mean(v)) for f, v in fam.items()}
    out["overall"] = float(np.mean([out[f] for f in fam]))
    return out


# -- B3: adjacent corners, d <= 6 ------------------------------------------------------------
def bench_resolution(det, half: str) -> dict:
    res: dict[float, list[bool]] = {}
    le = []
    for i, cfg in enumerate(configurations(quick=False, seed=seed_of(half))):
        if cfg.d > 6 or (SCREEN and i % 3):
            continue
        img, corners = render_configuration(cfg)
        ok, dist = score_configuration(corners, det.detect_corners(img).xy, 1.5)
        res.setdefault(cfg.d, []).append(ok)
        if ok:
            le += list(dist)
    rate = {f"{d:g}": float(np.mean(v)) for d, v in sorted(res.items())}
    return {"mean_rate": float(np.mean([x for v in res.values() for x in v])), "rate": rate,
            "le": float(np.sqrt(np.mean(np.square(le)))) if le else math.nan}


# -- B4: dense checkerboards -------------------------------------------------------------------
B4_CELLS = (4, 5, 6, 8)


CHESS_QUICK = os.environ.get("HR_CHESS_FULL", "") == ""


def bench_chessboard(det, half: str, cells=B4_CELLS) -> dict:
    """Mean error over cells 4-8 (recall < 0.5 counts 1 px), by ``sogdd.evaluation.chessboard.evaluate``.

    Exploration uses its quick grid; ``HR_CHESS_FULL=1`` runs the full grid (final rows).
    """
    from sogdd.evaluation.chessboard import evaluate

    r = evaluate(lambda im: det.detect_corners(im).xy, cells=cells, seed=seed_of(half), quick=CHESS_QUICK)
    errs = []
    for c in cells:
        e = r.get(f"{c:g}", {})
        ok = e.get("recall", 0) >= 0.5 and e.get("mean_error") is not None and np.isfinite(e["mean_error"])
        errs.append(e["mean_error"] if ok else 1.0)
    return {"mean_error": float(np.mean(errs)), "grid": "quick" if CHESS_QUICK else "full",
            "cells": {f"{c:g}": r.get(f"{c:g}") for c in cells}}


# -- B5: MMA@3 with SIFT descriptors -------------------------------------------------------------
_SETS = (("oxford", "homography/oxford"), ("hpatches", "homography/hpatches"),
         ("homogr", "homography/homogr"))


def _pairs(set_name: str, half: str):
    seqs = load_sequences(DATA / dict(_SETS)[set_name])
    if set_name == "homogr":
        keep = set(half_of([s.name for s in seqs], half))
        return [(s.reference, t, h) for s in seqs if s.name in keep for t, h in s.targets]
    out = []
    for s in seqs:
        ts = s.targets[0::2] if half == "dev" else s.targets[1::2]  # targets 2,4,6 | 3,5
        out += [(s.reference, t, h) for t, h in ts]
    return out


def bench_mma(det, half: str) -> dict:
    spec = feature_spec()
    cache: dict[Path, object] = {}

    def feats(p: Path):
        if p not in cache:
            cache[p] = extract_features(read_image(p), spec, detector=det)
        return cache[p]

    out = {}
    for name, _ in _SETS:
        accs = []
        for ref, tgt, h in _pairs(name, half):
            fa, fb = feats(ref), feats(tgt)
            m = mutual_nn(fa.descriptors, fb.descriptors)
            accs.append(mma_of_errors(match_errors(fa.keypoints, fb.keypoints, m, h), [3])[0])
        out[name] = float(np.mean(accs))
    out["mean"] = float(np.mean([out[n] for n, _ in _SETS]))
    return out


BENCHES = {"gt": bench_gt, "repeat": bench_repeat, "resolution": bench_resolution,
           "chessboard": bench_chessboard, "mma": bench_mma}
KEY = {"gt": ("f1", True), "repeat": ("overall", True), "resolution": ("mean_rate", True),
       "chessboard": ("mean_error", False), "mma": ("mean", True)}


def run(det, half: str, benches=tuple(BENCHES)) -> dict:
    """Every requested benchmark, with its wall time in seconds."""
    out = {}
    for b in benches:
        t0 = time.perf_counter()
        out[b] = BENCHES[b](det, half)
        out[b]["seconds"] = round(time.perf_counter() - t0, 2)
    return out


def mean_ranks(results: dict[str, dict], benches=tuple(BENCHES)) -> dict[str, float]:
    """Mean rank over the benchmarks (1 = best, ties share the mean rank; NaN ranks last)."""
    from scipy.stats import rankdata

    labels = list(results)
    ranks = np.zeros(len(labels))
    for b in benches:
        k, higher = KEY[b]
        v = np.array([results[lab].get(b, {}).get(k, math.nan) for lab in labels], dtype=np.float64)
        v = np.where(np.isfinite(v), -v if higher else v, np.inf)
        ranks += rankdata(v, method="average")
    return {lab: float(r / len(benches)) for lab, r in zip(labels, ranks)}
