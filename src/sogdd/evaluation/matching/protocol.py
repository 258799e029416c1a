"""Mean matching accuracy on homography sequences: the D2-Net HPatches protocol.

Protocol (Dusmanu et al., CVPR 2019, ``HPatches-Sequences-Matching-Benchmark``),
reproduced step by step:

1. For each sequence, image 1 is matched against images 2..6.
2. Matches are the **mutual nearest neighbours** of the L2-normalised
   descriptors (largest dot product, i.e. smallest L2 distance, both ways). No
   ratio test.
3. Image 1's matched point is projected by ``H_1_k``; the match is correct at
   threshold ``t`` when the projection lies within ``t`` px (``<=``) of its
   partner, for ``t = 1..10``.
4. A pair scores the fraction of correct matches; a pair with no match scores
   0. MMA(t) is the mean over pairs: overall, and separately over the
   illumination (``i_*``) and viewpoint (``v_*``) sequences.
5. The mean number of features is over every image (6 per sequence), the mean
   number of matches over pairs.

Beside MMA (not in D2-Net's protocol): per pair a homography is estimated from
the matches with MAGSAC++ and scored by the mean error of the reference image's
four corners; the summary gives the AUC of those errors at 1, 3 and 5 px
(:mod:`.homography`).

The paper's own pipeline (a 5-level pyramid, 75 px removed at the borders,
top-k) is expressed with detector specs (:mod:`sogdd.evaluation.specs`), e.g.
``sogdd:levels=5:remove_border=75:top_k=5000``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from ...image.files import read_image
from ..features import FeatureSet, extract_features
from ..specs import DetectorSpec, build_detector
from .budget import map_specs, with_budget
from .data import D2NET_EXCLUDED, HomographySequence
from .homography import AUC_THRESHOLDS, auc_of_errors, corner_error, estimate_homography

__all__ = [
    "SPLITS",
    "THRESHOLDS",
    "MatchingResult",
    "PairRecord",
    "benchmark_info",
    "evaluate_features",
    "evaluate_specs",
    "match_errors",
    "mma_of_errors",
    "mutual_nn",
    "safe_label",
    "project",
]

THRESHOLDS: tuple[int, ...] = tuple(range(1, 11))
SPLITS = ("overall", "illumination", "viewpoint")


def _l2n(d: np.ndarray) -> np.ndarray:
    d = np.asarray(d, dtype=np.float32)
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return d / np.maximum(n, 1e-12)


def mutual_nn(desc_a: np.ndarray, desc_b: np.ndarray, *, chunk: int = 4096) -> np.ndarray:
    """Mutual nearest neighbours of L2-normalised descriptors.

    Parameters
    ----------
    desc_a, desc_b : (Na, D), (Nb, D) arrays
        Descriptors (normalised here).

    Returns
    -------
    (M, 2) int64
        ``(i_a, i_b)`` pairs, sorted by ``i_a``: ``i_b`` is ``i_a``'s nearest
        neighbour in B and ``i_a`` is ``i_b``'s nearest neighbour in A. Ties go
        to the lowest index (``torch.max``/``argmax`` behaviour).
    """
    a, b = _l2n(desc_a), _l2n(desc_b)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((0, 2), np.int64)
    nn12 = np.empty(len(a), np.int64)
    best21 = np.full(len(b), -np.inf, np.float32)
    nn21 = np.zeros(len(b), np.int64)
    # blocks of rows keep the similarity matrix small for 10k x 10k features
    for s in range(0, len(a), chunk):
        sim = a[s : s + chunk] @ b.T
        nn12[s : s + chunk] = np.argmax(sim, axis=1)
        col_arg = np.argmax(sim, axis=0)
        col_max = sim[col_arg, np.arange(len(b))]
        better = col_max > best21  # strict: earlier rows win ties
        best21[better] = col_max[better]
        nn21[better] = col_arg[better] + s
    ids = np.arange(len(a))
    mask = nn21[nn12] == ids
    return np.stack([ids[mask], nn12[mask]], axis=1)


def project(h: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Apply a homography to (N, 2) points."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    ph = np.concatenate([xy, np.ones((len(xy), 1))], axis=1) @ np.asarray(h, dtype=np.float64).T
    with np.errstate(divide="ignore", invalid="ignore"):
        return ph[:, :2] / ph[:, 2:]


def match_errors(xy_a: np.ndarray, xy_b: np.ndarray, matches: np.ndarray, h_ab: np.ndarray) -> np.ndarray:
    """Distance (px) between each matched B point and its A partner projected by ``h_ab``."""
    if len(matches) == 0:
        return np.zeros(0)
    proj = project(h_ab, np.asarray(xy_a)[matches[:, 0], :2])
    d = np.linalg.norm(np.asarray(xy_b)[matches[:, 1], :2] - proj, axis=1)
    return np.where(np.isfinite(d), d, np.inf)


def mma_of_errors(errors: np.ndarray, thresholds: Sequence[float] = THRESHOLDS) -> np.ndarray:
    """Fraction of errors ``<= t`` for each threshold; an empty match set scores 0."""
    e = np.asarray(errors, dtype=np.float64)
    if e.size == 0:
        return np.zeros(len(thresholds))
    return np.array([np.mean(e <= t) for t in thresholds])


@dataclass
class PairRecord:
    """One image pair's outcome."""

    sequence: str
    split: str
    target: str
    n_features_a: int
    n_features_b: int
    n_matches: int
    accuracy: list[float]
    corner_error: float = float("inf")  # homography estimated from the matches (inf: none found)
    inliers: int = 0


@dataclass
class MatchingResult:
    """Per-pair records of one detector on a set of sequences, and their summary."""

    label: str
    pairs: list[PairRecord] = field(default_factory=list)
    features: list[int] = field(default_factory=list)  # one entry per image
    thresholds: tuple[int, ...] = THRESHOLDS
    seconds: float = 0.0
    spec: dict = field(default_factory=dict)

    def mma(self, split: str = "overall") -> list[float] | None:
        """MMA(t) over the pairs of ``split`` (``None`` when it has no pairs)."""
        recs = [p for p in self.pairs if split == "overall" or p.split == split]
        if not recs:
            return None
        return np.mean([p.accuracy for p in recs], axis=0).tolist()

    def homography_auc(self, split: str = "overall") -> list[float] | None:
        """AUC of the pairs' corner errors at :data:`AUC_THRESHOLDS` px (``None`` without pairs)."""
        recs = [p for p in self.pairs if split == "overall" or p.split == split]
        return auc_of_errors([p.corner_error for p in recs], AUC_THRESHOLDS) if recs else None

    def summary(self) -> dict:
        """JSON-ready: ``mma`` per split (list for t = 1..10), ``features``, ``matches``, counts.

        ``homography``: ``auc`` per split (list for :data:`AUC_THRESHOLDS`),
        ``thresholds``, ``median_corner_error`` over all pairs (inf counts as
        largest; ``None`` when most pairs failed), ``failed`` (pairs without a
        model) and per pair ``corner_errors`` (``None`` for a failure).
        """
        errs = [p.corner_error for p in self.pairs]
        med = float(np.median(errs)) if errs else float("inf")
        return {
            "mma": {s: self.mma(s) for s in SPLITS},
            "homography": {
                "auc": {s: self.homography_auc(s) for s in SPLITS},
                "thresholds": list(AUC_THRESHOLDS),
                "median_corner_error": med if np.isfinite(med) else None,
                "failed": int(sum(not np.isfinite(e) for e in errs)),
                "corner_errors": {f"{p.sequence}/{p.target}": (p.corner_error if np.isfinite(p.corner_error)
                                                              else None) for p in self.pairs},
            },
            "pairs": {s: sum(1 for p in self.pairs if s == "overall" or p.split == s) for s in SPLITS},
            "features": float(np.mean(self.features)) if self.features else 0.0,
            "matches": float(np.mean([p.n_matches for p in self.pairs])) if self.pairs else 0.0,
            "thresholds": list(self.thresholds),
            "seconds": round(self.seconds, 3),
            "spec": self.spec,
        }


def evaluate_features(
    sequences: Sequence[HomographySequence],
    features: Callable[[HomographySequence, Path], FeatureSet],
    *,
    label: str = "",
    thresholds: Sequence[int] = THRESHOLDS,
    progress: Callable[[str], None] | None = None,
) -> MatchingResult:
    """Run the protocol with features from ``features(sequence, image_path)``."""
    res = MatchingResult(label, thresholds=tuple(thresholds))
    t0 = time.perf_counter()
    for seq in sequences:
        fa = features(seq, seq.reference)
        res.features.append(len(fa))
        shape_a = _shape(fa, seq.reference)
        for target, h in seq.targets:
            fb = features(seq, target)
            res.features.append(len(fb))
            m = mutual_nn(fa.descriptors, fb.descriptors)
            err = match_errors(fa.keypoints, fb.keypoints, m, h)
            h_est, n_in = estimate_homography(np.asarray(fa.keypoints)[m[:, 0], :2],
                                              np.asarray(fb.keypoints)[m[:, 1], :2])
            res.pairs.append(PairRecord(seq.name, seq.split, target.name, len(fa), len(fb), len(m),
                                        mma_of_errors(err, thresholds).tolist(),
                                        corner_error(h_est, h, shape_a), n_in))
        if progress:
            last = res.pairs[-1]
            progress(f"{label}: {seq.name}: {len(fa)} features, {last.n_matches} matches with {last.target}")
    res.seconds = time.perf_counter() - t0
    return res


def _evaluate_one(spec: DetectorSpec, sequences, thresholds, feature_dir, method_names, progress
                  ) -> MatchingResult:
    det = build_detector(spec)
    method = (method_names or {}).get(spec.label) or safe_label(spec.label)

    def feats(seq: HomographySequence, path: Path) -> FeatureSet:
        fs = extract_features(read_image(path), spec, det)
        if feature_dir is not None:
            d = Path(feature_dir) / seq.name
            d.mkdir(parents=True, exist_ok=True)
            fs.save_npz(d / f"{path.name}.{method}")
        return fs

    r = evaluate_features(sequences, feats, label=spec.label, thresholds=thresholds, progress=progress)
    r.spec = spec.to_json()
    return r


def evaluate_specs(
    sequences: Sequence[HomographySequence],
    specs: Sequence[DetectorSpec],
    *,
    thresholds: Sequence[int] = THRESHOLDS,
    feature_dir: str | Path | None = None,
    method_names: dict[str, str] | None = None,
    progress: Callable[[str], None] | None = None,
    max_features: int | None = None,
    jobs: int = 1,
) -> dict[str, MatchingResult]:
    """Evaluate each detector spec; optionally save every image's features.

    Features go to ``feature_dir/<sequence>/<image>.<method>`` in D2-Net's
    ``.npz`` layout, ``<method>`` being ``method_names[label]`` or the label
    with unsafe characters replaced. ``max_features`` gives every detector the
    same budget (:func:`.budget.with_budget`: labels gain ``:top_k=N``);
    ``jobs`` evaluates the detectors in that many processes (progress messages
    then come only as each detector finishes).
    """
    specs = [with_budget(s, max_features) for s in specs]
    fn = partial(_evaluate_one, sequences=list(sequences), thresholds=tuple(thresholds),
                 feature_dir=feature_dir, method_names=method_names, progress=progress if jobs <= 1 else None)

    def done(spec: DetectorSpec, r: MatchingResult) -> None:
        if progress is not None and jobs > 1:
            progress(f"{spec.label}: done in {r.seconds:.0f} s")

    results = map_specs(fn, specs, jobs, on_result=done)
    return {s.label: r for s, r in zip(specs, results)}


def _shape(fs: FeatureSet, path: Path) -> tuple[int, int]:
    """The reference image's (height, width): from its features, else from the file's header."""
    if fs.image_shape and min(fs.image_shape) > 0:
        return tuple(fs.image_shape)[:2]
    img = read_image(path)
    return img.shape[:2]


def safe_label(label: str) -> str:
    """A method's label as a file or folder name: letters, digits and ``-_=`` kept, the rest ``_``.

    Examples
    --------
    >>> safe_label("sogdd hr (k=8)")
    'sogdd_hr__k=8_'
    """
    return "".join(ch if ch.isalnum() or ch in "-_=" else "_" for ch in label)


def benchmark_info(root: str | Path, layout: str, sequences: Sequence[HomographySequence]) -> dict:
    """What was run, and whether it is the full D2-Net HPatches benchmark (108 sequences)."""
    names = [s.name for s in sequences]
    n_i = sum(s.split == "illumination" for s in sequences)
    n_v = sum(s.split == "viewpoint" for s in sequences)
    full = layout == "hpatches" and len(names) == 108 and not (set(names) & D2NET_EXCLUDED)
    return {
        "root": str(root),
        "layout": layout,
        "sequences": names,
        "n_sequences": len(names),
        "n_illumination": n_i,
        "n_viewpoint": n_v,
        "n_pairs": int(sum(len(s) for s in sequences)),
        "full_hpatches": bool(full),
        "descriptor": "OpenCV SIFT at every detector's points (the paper's SOSNet weights are not available); "
                      "rows with desc=native: the detector's own",
    }
