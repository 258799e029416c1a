"""One detector, several COLMAP seeds: the features once, matching and mapping per seed.

A single COLMAP run is not enough to rank detectors: RANSAC in the geometric
verification and the mapper's choice of initial pair and next images are random,
and the rotation error of one detector can vary by a factor of five from seed to
seed. :func:`run_sfm_seeds` detects and describes every image once, then for each
seed copies that database, sets the seed (``pycolmap.set_random_seed`` and the
mapper's ``random_seed``), matches, verifies and maps. :func:`seed_summary` gives
the median over the runs and the spread (min and max) of each number.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ...formats.colmap import require_pycolmap
from ..specs import DetectorSpec
from .pipeline import (
    chosen_images,
    feature_stage,
    fresh_dir,
    import_stage,
    map_stage,
    match_stage,
    matcher_for,
    model_stats,
    pose_errors,
    verified_stats,
)

__all__ = ["SUMMARISED", "run_sfm_seeds", "seed_summary", "seed_values"]

#: Numbers summarised over seeds (top-level keys of a run, and the pose errors' medians).
SUMMARISED = ("registered", "points", "track_length", "reproj_error", "rotation_deg_median", "position_median")


def _value(run: dict, key: str):
    if key in ("rotation_deg_median", "position_median"):
        pe = run.get("pose_errors") or {}
        return pe.get(key) if pe.get("aligned") else None
    return run.get(key)


def seed_summary(runs: Sequence[dict]) -> dict:
    """Median and spread over seed runs: ``{key: {"median", "min", "max", "values"}}``.

    Runs without a value (no model, no GT alignment) are left out of that key;
    a key no run has is ``None``.

    Examples
    --------
    >>> s = seed_summary([{"points": 10}, {"points": 30}, {"points": 12}])
    >>> s["points"]["median"], s["points"]["min"], s["points"]["max"]
    (12.0, 10.0, 30.0)
    >>> s["reproj_error"] is None
    True
    """
    out: dict = {}
    for key in SUMMARISED:
        vals = [float(v) for v in (_value(r, key) for r in runs) if v is not None]
        out[key] = None if not vals else {"median": float(np.median(vals)), "min": min(vals),
                                          "max": max(vals), "values": vals}
    return out


def seed_values(runs: Sequence[dict]) -> dict:
    """The numbers a result over seeds reports in place of a single run's.

    ``registered`` is the smallest over the runs (so that "every image
    registered" holds for each seed); every other key of :data:`SUMMARISED` is
    the median over the runs that have it (``None`` if none has): one unlucky
    seed moves a mean, not a median.

    Examples
    --------
    >>> v = seed_values([{"registered": 5, "points": 10}, {"registered": 4, "points": 90},
    ...                  {"registered": 5, "points": 14}])
    >>> v["registered"], v["points"], v["reproj_error"]
    (4, 14.0, None)
    """
    spread = seed_summary(runs)
    out: dict = {"registered": min(r["registered"] for r in runs)}
    for key in SUMMARISED[1:]:
        out[key] = None if spread[key] is None else spread[key]["median"]
    return out


def _one_seed(db_feat: Path, work: Path, image_dir: Path, seed: int, matcher: str, counts: dict,
              descs: dict, num_threads: int, max_runtime_seconds: float, gt_cameras) -> dict:
    pycolmap = require_pycolmap()
    run_dir = fresh_dir(work / f"seed{seed}")
    db_path = str(run_dir / "database.db")
    shutil.copyfile(db_feat, db_path)
    pycolmap.set_random_seed(seed)
    t0 = time.perf_counter()
    n_raw = match_stage(db_path, matcher, counts, descs, num_threads)
    t_match = time.perf_counter() - t0
    pairs, inliers = verified_stats(db_path)
    t0 = time.perf_counter()
    sparse = run_dir / "sparse"
    recs = map_stage(db_path, image_dir, sparse, seed=seed, num_threads=num_threads,
                     max_runtime_seconds=max_runtime_seconds)
    t_map = time.perf_counter() - t0
    r: dict = {"seed": seed, "matches": n_raw, "verified_pairs": pairs, "inlier_matches": inliers,
               "models": len(recs), "timing": {"matching": round(t_match, 2), "mapping": round(t_map, 2)}}
    if not recs:
        r.update(registered=0, points=0, track_length=None, reproj_error=None, observations=0)
        return r
    key = max(recs, key=lambda k: (recs[k].num_reg_images(), recs[k].num_points3D()))
    r.update(model_stats(recs[key]), model_dir=str(sparse / str(key)))
    if gt_cameras is not None:
        r["pose_errors"] = pose_errors(recs[key], gt_cameras)
    return r


def run_sfm_seeds(
    image_dir: str | Path,
    spec: DetectorSpec,
    work_dir: str | Path,
    seeds: Sequence[int] = (0, 1, 2),
    *,
    matcher: str = "colmap",
    gt_cameras: str | Path | None = None,
    num_threads: int = -1,
    max_runtime_seconds: float = -1,
    image_names: list[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Reconstruct ``image_dir`` once per seed with the same features; median and spread.

    Parameters are those of :func:`sogdd.evaluation.sfm.run_sfm` (no dense
    stage), plus ``seeds``.

    Returns
    -------
    dict
        The keys of a single run (``registered`` is the smallest over the seeds,
        so that "every image registered" holds for all of them; ``points``,
        ``track_length``, ``reproj_error`` and the pose errors' medians are the
        medians over the seeds), plus ``seeds``, ``runs`` (every seed's result)
        and ``spread`` (:func:`seed_summary`).
    """
    require_pycolmap()
    if matcher not in ("colmap", "mnn"):
        raise ValueError(f"matcher must be 'colmap' or 'mnn', got {matcher!r}")
    matcher = matcher_for(spec, matcher)  # desc=native: mnn
    seeds = [int(s) for s in seeds]
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct integers, got {seeds!r}")
    image_dir = Path(image_dir)
    names = chosen_images(image_dir, image_names)
    work = fresh_dir(work_dir)
    say = progress or (lambda _m: None)
    t_start = time.perf_counter()
    db_feat = work / "features.db"
    prior, ids = import_stage(str(db_feat), image_dir, names)
    ids = {n: ids[n] for n in names}
    t0 = time.perf_counter()
    counts, descs = feature_stage(str(db_feat), image_dir, ids, spec, keep_descriptors=matcher == "mnn",
                                  say=say)
    t_feat = time.perf_counter() - t0
    runs = []
    for s in seeds:
        r = _one_seed(db_feat, work, image_dir, s, matcher, counts, descs, num_threads, max_runtime_seconds,
                      gt_cameras)
        pe = r.get("pose_errors") or {}
        say(f"{spec.label}: seed {s}: {r['registered']}/{len(names)} registered, {r['points']} points"
            + (f", rotation {pe['rotation_deg_median']:.3f} deg" if pe.get("aligned") else ""))
        runs.append(r)
    spread = seed_summary(runs)
    result: dict = {
        "detector": spec.label, "spec": spec.to_json(), "images": len(names),
        "camera_prior": None if prior is None else {"model": prior.model, "source": prior.source},
        "matcher": matcher, "seeds": seeds,
        "features": float(np.mean(list(counts.values()))) if counts else 0.0,
        "features_total": int(sum(counts.values())),
        **seed_values(runs), "dense_points": "not run", "runs": runs, "spread": spread,
    }
    if gt_cameras is not None:
        result["pose_errors"] = {"aligned": spread["rotation_deg_median"] is not None,
                                 "rotation_deg_median": result["rotation_deg_median"],
                                 "position_median": result["position_median"],
                                 "note": "medians over seeds of each run's median"}
    result["seconds"] = round(time.perf_counter() - t_start, 2)
    result["timing"] = {"features": round(t_feat, 2),
                        "matching": round(sum(r["timing"]["matching"] for r in runs), 2),
                        "mapping": round(sum(r["timing"]["mapping"] for r in runs), 2)}
    (work / "result.json").write_text(json.dumps(result, indent=1, default=float))
    return result
