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
mean of the paper's six family averages (``blur``, beyond the paper, is
reported beside it, not in it).

**Fixed-count mode** (``top_n=N``). At defaults R_avg rewards a detector for
how many points its threshold happens to return. With ``top_n`` every detector
also runs with its threshold off (the registry's ``permissive()``) and keeps
its ``N`` strongest points on both images
(:meth:`sogdd.baselines.registry.BaselineDetector.top_n`: ranked by
``response``; a detector without a strength keeps its first ``N`` in its own
order; one whose permissive run finds fewer than ``N`` keeps them all, and the
mean point count in the tables shows it). Its rows are labelled
``"<spec> [top-N]"`` beside the default rows (Oxford / SuperPoint practice).

Work is split into (image, family) tasks run in worker processes; within a
task each transformed image is generated once and shared by all detectors.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from collections import defaultdict
from concurrent.futures import as_completed
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from ..points import match_points
from ..pools import process_pool
from ..specs import DetectorSpec, build_detector, detect
from .transforms import ALL_FAMILIES, FAMILIES, apply_transform, family_grid, map_points

__all__ = ["RUN_FILE", "RepeatabilityReport", "evaluate_repeatability", "image_digest", "pair_repeatability",
           "repeatability_score", "top_n_label", "transforms_digest"]

#: the file of :meth:`RepeatabilityReport.write` that holds a whole run (records and protocol), for reuse
RUN_FILE = "repeatability_run.json"

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


def image_digest(image: np.ndarray) -> str:
    """The first 16 hex digits of the SHA-256 of an image's shape, type and pixels (what a run was made on).

    Examples
    --------
    >>> a = np.zeros((4, 5), np.uint8)
    >>> image_digest(a) == image_digest(a.copy()), image_digest(a) == image_digest(a.T)
    (True, False)
    """
    a = np.ascontiguousarray(image)
    h = hashlib.sha256(f"{a.shape}{a.dtype.str}".encode())
    h.update(a.view(np.uint8).tobytes())
    return h.hexdigest()[:16]


def transforms_digest(images: list[tuple[str, np.ndarray]], families, quick: bool, seed: int = 0) -> str:
    """A digest of what the transforms make of the first image: every member of each family's grid.

    Part of :meth:`RepeatabilityReport.protocol`, so that a cached run made
    before the transform code changed (another resampling, noise, JPEG
    encoder) no longer passes for the same test. The first image stands for
    all (the code is the same for every image); it costs one pass over one
    image's grid.

    Examples
    --------
    >>> img = np.arange(64 * 64, dtype=np.uint8).reshape(64, 64)
    >>> one = [("a", img)]
    >>> d = transforms_digest(one, ["jpeg", "rotation"], True)
    >>> d == transforms_digest(one, ["jpeg", "rotation"], True), d == transforms_digest(one, ["jpeg"], True)
    (True, False)
    """
    if not images:
        return ""
    h = hashlib.sha256()
    img = images[0][1]
    for fam in families:
        for tr in family_grid(fam, quick):
            out, a, _ = apply_transform(img, tr, seed=seed * 100003)  # image 0's task seed
            h.update(fam.encode() + tr.label.encode())
            h.update(np.ascontiguousarray(out).view(np.uint8).tobytes())
            h.update(np.asarray(a, np.float64).round(12).tobytes())
    return h.hexdigest()[:16]


def top_n_label(label: str, n: int) -> str:
    """The row label of a spec in the fixed-count mode."""
    return f"{label} [top-{n}]"


def _points(spec: DetectorSpec, det, image: np.ndarray, top_n: int | None) -> np.ndarray:
    """The spec's points: as configured, or its ``top_n`` strongest with the threshold off."""
    if top_n is None:
        return detect(spec, image, det).xy
    mask = None
    if spec.remove_border > 0:  # the pipeline's border removal, before the count is taken
        b, (h, w) = spec.remove_border, image.shape[:2]
        mask = np.zeros((h, w), bool)
        mask[b : h - b, b : w - b] = True
    return det.top_n(image, top_n, mask).xy


def _task(name: str, image: np.ndarray, family: str, specs: list[DetectorSpec], quick: bool,
          radius: float, margin: float, seed: int, top_n: int | None = None
          ) -> tuple[list[dict], dict[str, float]]:
    runs = [(s, build_detector(s), s.label, None) for s in specs]
    if top_n is not None:
        runs += [(s, det, top_n_label(s.label, top_n), top_n) for s, det, _, _ in list(runs)]
    secs: dict[str, float] = defaultdict(float)
    refs = []
    for s, det, label, n in runs:
        t0 = time.perf_counter()
        refs.append(_points(s, det, image, n))
        secs[label] += time.perf_counter() - t0
    recs = []
    for tr in family_grid(family, quick):
        timg, a, _ = apply_transform(image, tr, seed=seed)  # once, shared by all detectors
        for (s, det, label, n), ref in zip(runs, refs):
            t0 = time.perf_counter()
            xy = _points(s, det, timg, n)
            secs[label] += time.perf_counter() - t0
            lb, ld, lr, r = pair_repeatability(ref, xy, a, image.shape, radius=radius,
                                               margin=margin)
            recs.append({"image": name, "family": family, "param": tr.param, "label": tr.label,
                         "detector": label, "lb": lb, "ld": ld, "lr": lr, "r": r})
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
    top_n: int | None = None
    #: the spec labels (default-mode rows); with ``top_n`` each also has a ``[top-N]`` row
    specs: list[str] = field(default_factory=list)
    seed: int = 0
    #: :func:`image_digest` of each image, in the order of ``images``
    image_digests: list[str] = field(default_factory=list)
    #: :func:`transforms_digest` of the run
    transforms: str = ""

    def protocol(self) -> dict:
        """Everything a record depends on besides the detector: the test a cached run must share to be reused.

        The grid is spelled out (every transform's label per family), so a
        changed grid, like a changed image, seed or ``top_n``, is a different
        protocol.
        """
        return {"radius": self.radius, "margin": self.margin, "quick": self.quick, "seed": self.seed,
                "top_n": self.top_n, "families": list(self.families),
                "grid": {f: [t.label for t in family_grid(f, self.quick)] for f in self.families},
                "images": [[n, d] for n, d in zip(self.images, self.image_digests)],
                "transforms": self.transforms}

    def merged(self, other: RepeatabilityReport) -> RepeatabilityReport:
        """This run with ``other``'s detectors added (``ValueError`` if the protocols or a label differ)."""
        if self.protocol() != other.protocol():
            raise ValueError("repeatability runs with different protocols cannot be merged")
        clash = set(self.detectors) & set(other.detectors)
        if clash:
            raise ValueError(f"both runs hold {', '.join(sorted(clash))}")
        order = {(n, f): i for i, (n, f) in enumerate((n, f) for n in self.images for f in self.families)}
        recs = sorted(self.records + other.records, key=lambda r: order[(r["image"], r["family"])])
        return RepeatabilityReport(recs, self.detectors + other.detectors, list(self.families),
                                   list(self.images), self.quick, self.radius, self.margin,
                                   self.seconds + other.seconds,
                                   {**self.detector_seconds, **other.detector_seconds},
                                   self.top_n, self.specs + other.specs, self.seed, list(self.image_digests),
                                   self.transforms)

    def to_run_json(self) -> dict:
        """The whole run (protocol, rows, every record, times): :data:`RUN_FILE`, read back by
        :meth:`from_run_json`."""
        return {"format": 1, "protocol": self.protocol(), "specs": self.specs, "detectors": self.detectors,
                "seconds": self.seconds, "detector_seconds": self.detector_seconds, "records": self.records}

    @classmethod
    def from_run_json(cls, obj: dict) -> RepeatabilityReport:
        """The run that :meth:`to_run_json` wrote (``ValueError`` on another format)."""
        if not isinstance(obj, dict) or obj.get("format") != 1:
            raise ValueError("not a repeatability run (format 1)")
        p = obj["protocol"]
        return cls(list(obj["records"]), list(obj["detectors"]), list(p["families"]),
                   [n for n, _ in p["images"]], bool(p["quick"]), float(p["radius"]), float(p["margin"]),
                   float(obj["seconds"]), dict(obj["detector_seconds"]), p["top_n"], list(obj["specs"]),
                   int(p["seed"]), [d for _, d in p["images"]], str(p.get("transforms", "")))

    def family_average(self, detector: str, family: str) -> float:
        rs = [r["r"] for r in self.records if r["detector"] == detector and r["family"] == family]
        return float(np.mean(rs)) if rs else math.nan

    def overall(self, detector: str) -> float:
        """Mean of the paper's family averages present (of all present when none is a paper family)."""
        fams = [f for f in self.families if f in FAMILIES] or list(self.families)
        vals = [self.family_average(detector, f) for f in fams]
        vals = [v for v in vals if math.isfinite(v)]
        return float(np.mean(vals)) if vals else math.nan

    def mean_points(self, detector: str) -> float:
        """Mean number of points per image in the common region, ``(L_b + L_d) / 2`` over all pairs."""
        v = [(r["lb"] + r["ld"]) / 2 for r in self.records if r["detector"] == detector]
        return float(np.mean(v)) if v else math.nan

    def curve(self, detector: str, family: str, kind: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(x, mean R)`` over images. Anisotropic: x is sy, averaged over sx too.

        Blur: x is sigma or the length, for ``kind`` ``"gaussian"`` or ``"motion"`` only.
        """
        acc: dict[float, list[float]] = defaultdict(list)
        for r in self.records:
            if r["detector"] == detector and r["family"] == family:
                p = r["param"]
                if kind is not None and (not isinstance(p, (tuple, list)) or p[0] != kind):
                    continue
                acc[float(p[1] if isinstance(p, (tuple, list)) else p)].append(r["r"])
        xs = np.array(sorted(acc))
        return xs, np.array([np.mean(acc[x]) for x in xs])

    def summary(self) -> dict:
        """Per detector: the average per family and overall (paper families) (the ``--json`` output)."""
        return {d: {**{f: self.family_average(d, f) for f in self.families},
                    "overall": self.overall(d)} for d in self.detectors}

    def points(self) -> dict[str, float]:
        """Per detector: :meth:`mean_points`."""
        return {d: self.mean_points(d) for d in self.detectors}

    def to_json(self) -> dict:
        return {
            "protocol": {"radius": self.radius, "margin": self.margin, "quick": self.quick,
                         "families": self.families, "images": self.images, "top_n": self.top_n,
                         "beyond_paper": [f for f in self.families if f not in FAMILIES]},
            "seconds": self.seconds,
            "detector_seconds": self.detector_seconds,
            "detectors": self.summary(),
            "points": self.points(),
        }

    def write(self, out: str | os.PathLike) -> list[Path]:
        """``repeatability.json`` (summary), ``repeatability_records.csv``, ``repeatability.csv`` and
        :data:`RUN_FILE` (the whole run, for ``sogdd report`` to reuse)."""
        o = Path(out)
        o.mkdir(parents=True, exist_ok=True)
        (o / "repeatability.json").write_text(json.dumps(self.to_json(), indent=1))
        (o / RUN_FILE).write_text(json.dumps(self.to_run_json()))
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
        names = ("repeatability.json", "repeatability_records.csv", "repeatability.csv", RUN_FILE)
        return [o / n for n in names]


def evaluate_repeatability(
    images: list[tuple[str, np.ndarray]],
    specs: list[DetectorSpec],
    *,
    families: tuple[str, ...] | list[str] = ALL_FAMILIES,
    quick: bool = False,
    jobs: int = 1,
    radius: float = 4.0,
    margin: float = 0.0,
    seed: int = 0,
    progress: bool = True,
    top_n: int | None = None,
) -> RepeatabilityReport:
    """Run the Fig. 9 protocol (module doc) on ``images`` for every detector in ``specs``.

    With ``top_n`` the fixed-count mode runs beside the default one (module doc).
    """
    for f in families:
        family_grid(f)  # validates the name
    if not images:
        raise ValueError("no images")
    if top_n is not None and (isinstance(top_n, bool) or not isinstance(top_n, int) or top_n < 1):
        raise ValueError(f"top_n must be a positive integer, got {top_n!r}")
    # seed per image, so results do not depend on the task order
    tasks = [(name, img, fam, specs, quick, radius, margin, seed * 100003 + i, top_n)
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
        with process_pool(jobs) as ex:  # spawned once PyTorch is loaded (a learned detector)
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
    labels = [s.label for s in specs]
    rows = labels + ([top_n_label(x, top_n) for x in labels] if top_n is not None else [])
    return RepeatabilityReport(records, rows, list(families),
                               [n for n, _ in images], quick, radius, margin,
                               time.perf_counter() - t0, dict(secs), top_n, labels, seed,
                               [image_digest(img) for _, img in images],
                               transforms_digest(images, families, quick, seed))
