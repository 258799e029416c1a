"""Average repeatability under image transforms: the protocol of the paper's Fig. 9.

For a reference image and a transformed one (:mod:`.transforms`), with
detections ``F`` (reference) and ``D`` (transformed):

* Reference corners are mapped into the transformed image by the known
  transform; for JPEG and noise the map is the identity.
* **Common region.** Only points whose mapped position lies inside the other
  image count: a reference corner ``p`` counts when ``A p`` falls on the
  transformed image's content (always true here, as the canvas holds the whole
  transformed image), and a transformed corner ``q`` counts when ``A^-1 q``
  lies inside the reference image. With ``margin > 0`` both positions must
  also be at least ``margin`` reference pixels from the reference border.
* ``L_b`` and ``L_d`` are the counted reference and transformed corners;
  ``L_r`` the pairs matched one to one, nearest first, within 4 px (in the
  transformed image's pixels).
* ``R_avg = (L_r / 2) (1 / L_b + 1 / L_d)`` (eq. 27); 0 when ``L_r = 0``.

Each detector runs with its default parameters, as in the paper. Family
averages are means over images and parameters; the overall figure is the
mean of the six family averages.

Work is split into (image, family) tasks run in worker processes; within a
task each transformed image is generated once and shared by all detectors.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..points import match_points
from ..specs import DetectorSpec, build_detector, detect
from .transforms import FAMILIES, apply_transform, family_grid, map_points

__all__ = ["RepeatabilityReport", "repeatability_score", "pair_repeatability", "evaluate_repeatability"]

def repeatability_score(lr: int, lb: int, ld: int) -> float:
    """Eq. 27: ``(L_r / 2) (1/L_b + 1/L_d)``; 0 when nothing matched."""
    if lr == 0:
        return 0.0
    return 0.5 * lr * (1.0 / lb + 1.0 / ld)


def _inside(xy: np.ndarray, shape: tuple[int, int], margin: float) -> np.ndarray:
    h, w = shape[:2]
    lo = -0.5 + margin
    return ((xy[:, 0] >= lo) & (xy[:, 0] <= w - 0.5 - margin)
            & (xy[:, 1] >= lo) & (xy[:, 1] <= h - 0.5 - margin))


def pair_repeatability(ref_xy: np.ndarray, det_xy: np.ndarray, affine: np.ndarray,
                       ref_shape: tuple[int, int], *, radius: float = 4.0, margin: float = 0.0
                       ) -> tuple[int, int, int, float]:
    """``(L_b, L_d, L_r, R_avg)`` for one reference/transformed pair (see module doc)."""
    ref_xy = np.asarray(ref_xy, dtype=np.float64).reshape(-1, 2)
    det_xy = np.asarray(det_xy, dtype=np.float64).reshape(-1, 2)
    inv = cv2.invertAffineTransform(affine)
    f = ref_xy[_inside(ref_xy, ref_shape, margin)]
    d = det_xy[_inside(map_points(det_xy, inv), ref_shape, margin)]
    m = match_points(map_points(f, affine), d, radius)
    lb, ld, lr = len(f), len(d), len(m)
    return lb, ld, lr, repeatability_score(lr, lb, ld)


def _task(name: str, image: np.ndarray, family: str, specs: list[DetectorSpec], quick: bool,
          radius: float, margin: float, seed: int) -> tuple[list[dict], dict[str, float]]:
    dets = [build_detector(s) for s in specs]
    secs: dict[str, float] = defaultdict(float)
    refs = []
    for s, det in zip(specs, dets):
        t0 = time.perf_counter()
        refs.append(detect(s, image, det).xy)
        secs[s.label] += time.perf_counter() - t0
    recs = []
    for tr in family_grid(family, quick):
        timg, a, _ = apply_transform(image, tr, seed=seed)  # once, shared by all detectors
        for s, det, ref in zip(specs, dets, refs):
            t0 = time.perf_counter()
            xy = detect(s, timg, det).xy
            secs[s.label] += time.perf_counter() - t0
            lb, ld, lr, r = pair_repeatability(ref, xy, a, image.shape, radius=radius,
                                               margin=margin)
            recs.append({"image": name, "family": family, "param": tr.param, "label": tr.label,
                         "detector": s.label, "lb": lb, "ld": ld, "lr": lr, "r": r})
    return recs, dict(secs)


@dataclass
class RepeatabilityReport:
    """Per-pair records plus curves and family averages."""

    records: list[dict]
    detectors: list[str]
    families: list[str]
    images: list[str]
    quick: bool
    radius: float
    margin: float
    seconds: float = 0.0
    detector_seconds: dict[str, float] = field(default_factory=dict)

    def family_average(self, detector: str, family: str) -> float:
        rs = [r["r"] for r in self.records if r["detector"] == detector and r["family"] == family]
        return float(np.mean(rs)) if rs else math.nan

    def overall(self, detector: str) -> float:
        vals = [self.family_average(detector, f) for f in self.families]
        vals = [v for v in vals if math.isfinite(v)]
        return float(np.mean(vals)) if vals else math.nan

    def curve(self, detector: str, family: str) -> tuple[np.ndarray, np.ndarray]:
        """``(x, mean R)`` over images. Anisotropic: x is sy, averaged over sx too."""
        acc: dict[float, list[float]] = defaultdict(list)
        for r in self.records:
            if r["detector"] == detector and r["family"] == family:
                p = r["param"]
                acc[float(p[1] if isinstance(p, (tuple, list)) else p)].append(r["r"])
        xs = np.array(sorted(acc))
        return xs, np.array([np.mean(acc[x]) for x in xs])

    def summary(self) -> dict:
        """Per detector: the average per family and overall (the ``--json`` output)."""
        return {d: {**{f: self.family_average(d, f) for f in self.families},
                    "overall": self.overall(d)} for d in self.detectors}

    def to_json(self) -> dict:
        return {
            "protocol": {"radius": self.radius, "margin": self.margin, "quick": self.quick,
                         "families": self.families, "images": self.images},
            "seconds": self.seconds,
            "detector_seconds": self.detector_seconds,
            "detectors": self.summary(),
        }

    def write(self, out: str | os.PathLike) -> list[Path]:
        """``repeatability.json`` (summary), ``repeatability_records.csv``, ``repeatability.csv``."""
        o = Path(out)
        o.mkdir(parents=True, exist_ok=True)
        (o / "repeatability.json").write_text(json.dumps(self.to_json(), indent=1))
        lines = ["image,family,param,detector,lb,ld,lr,r"]
        for r in self.records:
            lines.append(f"{r['image']},{r['family']},\"{r['label']}\",{r['detector']},"
                         f"{r['lb']},{r['ld']},{r['lr']},{r['r']:.6f}")
        (o / "repeatability_records.csv").write_text("\n".join(lines) + "\n")
        summ = self.summary()
        lines = ["detector," + ",".join(self.families) + ",overall"]
        for d in self.detectors:
            lines.append(d + "," + ",".join(f"{summ[d][f]:.4f}" for f in self.families)
                         + f",{summ[d]['overall']:.4f}")
        (o / "repeatability.csv").write_text("\n".join(lines) + "\n")
        return [o / "repeatability.json", o / "repeatability_records.csv", o / "repeatability.csv"]


def evaluate_repeatability(
    images: list[tuple[str, np.ndarray]],
    specs: list[DetectorSpec],
    *,
    families: tuple[str, ...] | list[str] = FAMILIES,
    quick: bool = False,
    jobs: int = 1,
    radius: float = 4.0,
    margin: float = 0.0,
    seed: int = 0,
    progress: bool = True,
) -> RepeatabilityReport:
    """Run the Fig. 9 protocol (module doc) on ``images`` for every detector in ``specs``."""
    for f in families:
        family_grid(f)  # validates the name
    if not images:
        raise ValueError("no images")
    # seed per image, so results do not depend on the task order
    tasks = [(name, img, fam, specs, quick, radius, margin, seed * 100003 + i)
             for i, (name, img) in enumerate(images) for fam in families]
    t0 = time.perf_counter()
    records: list[dict] = []
    secs: dict[str, float] = defaultdict(float)
    bar = tqdm(total=len(tasks), desc="repeatability", disable=not progress, leave=False)
    if jobs <= 1:
        for t in tasks:
            recs, s = _task(*t)
            records += recs
            for k, v in s.items():
                secs[k] += v
            bar.update(1)
    else:
        with ProcessPoolExecutor(max_workers=jobs) as ex:
            futs = [ex.submit(_task, *t) for t in tasks]
            for fut in as_completed(futs):
                recs, s = fut.result()
                records += recs
                for k, v in s.items():
                    secs[k] += v
                bar.update(1)
    bar.close()
    order = {(n, f): i for i, (n, _, f, *_r) in enumerate(tasks)}
    records.sort(key=lambda r: order[(r["image"], r["family"])])
    return RepeatabilityReport(records, [s.label for s in specs], list(families),
                               [n for n, _ in images], quick, radius, margin,
                               time.perf_counter() - t0, dict(secs))
