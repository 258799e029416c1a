"""The hr2 study's screening benchmarks (docs/hr2.md, section 1) on one half of the data.

B1: SfM on each scene's half with three COLMAP seeds (``sogdd.evaluation.sfm.run_sfm_seeds``);
B2: matching at an equal budget of 2,000 points (MMA@1, MMA@3, homography AUC@3).
B3/B4 and the constraints for the finalists come from ``studies/hr/bench.py`` and the package.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import candidates  # noqa: E402,F401 - registers hr2

from sogdd.evaluation.features import extract_features  # noqa: E402
from sogdd.evaluation.matching import load_sequences  # noqa: E402
from sogdd.evaluation.matching.budget import with_budget  # noqa: E402
from sogdd.evaluation.matching.homography import auc_of_errors, corner_error, estimate_homography  # noqa: E402
from sogdd.evaluation.matching.protocol import match_errors, mma_of_errors, mutual_nn  # noqa: E402
from sogdd.evaluation.sfm import run_sfm_seeds  # noqa: E402
from sogdd.evaluation.specs import build_detector, parse_spec  # noqa: E402
from sogdd.image.files import read_image  # noqa: E402

DATA = Path(os.environ.get("SOGDD_DATA", "/work/shared/data"))
WORK = Path(os.environ.get("HR2_WORK", "/tmp/hr2-work"))
SCENES = ("fountain-P11", "Herz-Jesus-P8")
SEEDS = (0, 1, 2)
BUDGET = 2000
SETS = (("oxford", "homography/oxford"), ("hpatches", "homography/hpatches"), ("homogr", "homography/homogr"))


def half_of(names: list[str], half: str) -> list[str]:
    """Sorted-name parity: even positions development, odd confirmation; ``full``: all."""
    s = sorted(names)
    return s if half == "full" else (s[0::2] if half == "dev" else s[1::2])


def _safe(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_=" else "_" for ch in text)


def bench_sfm(row: str, half: str, threads: int | None = None) -> dict:
    """B1: per scene, the seed summary of :func:`run_sfm_seeds` (medians, spread, every run).

    ``threads``: COLMAP's threads, default ``$HR2_THREADS`` or 2 (the rows added in stop 20 ran with 1).
    """
    threads = int(os.environ.get("HR2_THREADS", 2)) if threads is None else int(threads)
    spec = parse_spec(row)
    out = {}
    for scene in SCENES:
        d = DATA / "multiview" / scene
        names = half_of([p.name for p in (d / "images").glob("*.jpg")], half)
        r = run_sfm_seeds(d / "images", spec, WORK / half / f"{scene}-{_safe(row)}", SEEDS,
                          gt_cameras=d / "gt_dense_cameras", image_names=names, num_threads=threads)
        for run in r["runs"]:
            run.pop("model_dir", None)
            (run.get("pose_errors") or {}).pop("per_camera", None)
        out[scene] = {k: r[k] for k in ("images", "features", "registered", "points", "track_length",
                                        "reproj_error", "rotation_deg_median", "position_median", "spread",
                                        "seconds", "timing")}
        out[scene]["all_registered"] = all(x["registered"] == r["images"] for x in r["runs"])
    ok = all(out[s]["all_registered"] for s in SCENES)
    for key in ("rotation_deg_median", "position_median", "reproj_error"):
        vals = [out[s][key] for s in SCENES]
        out[key] = float(np.mean(vals)) if ok and None not in vals else None
    out["all_registered"] = ok
    out["threads"] = threads
    return out


def _pairs(set_name: str, half: str):
    seqs = load_sequences(DATA / dict(SETS)[set_name])
    if set_name == "homogr":
        keep = set(half_of([s.name for s in seqs], half))
        return [(s.reference, t, h) for s in seqs if s.name in keep for t, h in s.targets]
    out = []
    for s in seqs:
        ts = s.targets if half == "full" else (s.targets[0::2] if half == "dev" else s.targets[1::2])
        out += [(s.reference, t, h) for t, h in ts]
    return out


def _cached_features(row: str, budget: int | None):
    """The row's spec at ``budget``, and ``feats(path)``: its features of an image, computed once."""
    spec = with_budget(parse_spec(row), budget)
    det = build_detector(spec)
    cache: dict[Path, object] = {}

    def feats(p: Path):
        if p not in cache:
            cache[p] = extract_features(read_image(p), spec, det)
        return cache[p]

    return spec, feats


def bench_matching(row: str, half: str, budget: int | None = BUDGET) -> dict:
    """B2: MMA@1, MMA@3 and H AUC@3 per set and their means, at ``budget`` points per image."""
    spec, feats = _cached_features(row, budget)

    out: dict = {"label": spec.label}
    for name, _ in SETS:
        acc, errs, nf = [], [], []
        for ref, tgt, h in _pairs(name, half):
            fa, fb = feats(ref), feats(tgt)
            m = mutual_nn(fa.descriptors, fb.descriptors)
            acc.append(mma_of_errors(match_errors(fa.keypoints, fb.keypoints, m, h), [1, 3]))
            h_est, _ = estimate_homography(np.asarray(fa.keypoints)[m[:, 0], :2],
                                           np.asarray(fb.keypoints)[m[:, 1], :2])
            errs.append(corner_error(h_est, h, fa.image_shape))
            nf += [len(fa), len(fb)]
        a = np.mean(acc, axis=0)
        out[name] = {"mma1": float(a[0]), "mma3": float(a[1]), "auc3": float(auc_of_errors(errs, [3])[0]),
                     "features": float(np.mean(nf)), "pairs": len(acc)}
    for k in ("mma1", "mma3", "auc3"):
        out[k] = float(np.mean([out[n][k] for n, _ in SETS]))
    return out


def bench_residuals(row: str, half: str, budget: int | None = BUDGET, within: float = 3.0) -> dict:
    """Localisation under viewpoint change: residuals of the mutual-NN matches within ``within`` px.

    For every match whose partner lies within ``within`` px of the GT projection, the residual vector
    (partner minus projection). Reported per set: ``bias`` (length of the mean residual vector, px),
    ``sd`` (RMS distance to that mean, px) and ``median`` (median residual length), over all the set's
    pairs; the same budget as B2.
    """
    from sogdd.evaluation.matching.protocol import project

    spec, feats = _cached_features(row, budget)

    out: dict = {"label": spec.label}
    for name, _ in SETS:
        res = []
        for ref, tgt, h in _pairs(name, half):
            fa, fb = feats(ref), feats(tgt)
            m = mutual_nn(fa.descriptors, fb.descriptors)
            d = np.asarray(fb.keypoints)[m[:, 1], :2] - project(h, np.asarray(fa.keypoints)[m[:, 0], :2])
            res.append(d[np.linalg.norm(d, axis=1) <= within])
        r = np.concatenate(res) if res else np.zeros((0, 2))
        mu = r.mean(axis=0) if len(r) else np.zeros(2)
        out[name] = {"bias": float(np.linalg.norm(mu)),
                     "sd": float(np.sqrt(np.mean(np.sum((r - mu) ** 2, axis=1)))) if len(r) else None,
                     "median": float(np.median(np.linalg.norm(r, axis=1))) if len(r) else None, "n": len(r)}
    return out


BENCHES = {"sfm": bench_sfm, "matching": bench_matching, "residuals": bench_residuals}
