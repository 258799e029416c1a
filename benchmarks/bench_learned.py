"""The learned detectors beside sogdd and SIFT: time per megapixel, and MMA with SIFT and native descriptors.

Needs the ``learned`` extra (``docs/learned.md``). Two parts:

``speed``
    One photo cropped to ``--side`` x ``--side`` px (default: the centre of
    fountain-P11's first image), every detector through the registry's
    ``detect_corners`` in this one process, on ``--threads`` threads
    (PyTorch, numba and OpenCV alike), one warm-up call then ``--repeat``
    timed calls. Reports the median and the quartiles of wall time and of the
    process's CPU time (less sensitive to a loaded machine), per megapixel.
    ALIKED and DISK run with ``max_side=None`` here (the whole crop, no
    scaling), so that per megapixel means what it says.
``matching``
    The D2-Net mutual-NN protocol of :mod:`sogdd.evaluation.matching` on the
    local homography sets (HPatches v_wormhole, Oxford graf, HOMOGR), every
    detector at the same budget (``--budget`` strongest points), described
    once with the common SIFT descriptor and once with each learned method's
    own (``desc=native``).
``repeatability``
    The results page's repeatability test (:mod:`sogdd.evaluation.repeatability`:
    every image of ``--images``, the quick grid or ``--full``, both modes with
    the report's top-N) for each learned detector on its own, written to
    ``--out/<name>/`` (``repeatability_run.json`` among the files), the cached
    runs that ``sogdd report`` reads when their protocol is the one it runs
    (:mod:`sogdd.report.learned_runs`).

Run: ``python benchmarks/bench_learned.py speed [--side 1024] [--repeat 5] [--threads 1]``,
``python benchmarks/bench_learned.py matching [--budget 2000] [--json OUT]`` and
``python benchmarks/bench_learned.py repeatability [--detectors xfeat,aliked,disk]
[--out docs/figures/repeatability_learned]``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

DATA = Path(os.environ.get("SOGDD_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
LEARNED = ("xfeat", "aliked", "disk")


def set_threads(n: int) -> None:
    """One thread count for every backend (before numba's first parallel call)."""
    os.environ["NUMBA_NUM_THREADS"] = str(n)
    os.environ["SOGDD_NUM_THREADS"] = str(n)  # sogdd's tile threads
    os.environ["OMP_NUM_THREADS"] = str(n)
    import cv2
    import torch

    torch.set_num_threads(n)
    cv2.setNumThreads(n)


def crop(path: Path, side: int) -> np.ndarray:
    from sogdd.image.files import read_image

    img = read_image(path)
    h, w = img.shape[:2]
    y0, x0 = max((h - side) // 2, 0), max((w - side) // 2, 0)
    return img[y0 : y0 + side, x0 : x0 + side]


def speed(args: argparse.Namespace) -> dict:
    from sogdd import baselines

    img = crop(Path(args.image), args.side)
    mp = img.shape[0] * img.shape[1] / 1e6
    specs = {"sogdd": {}, "sogdd-hr": {}, "sift": {}, "xfeat": dict(device="cpu"),
             "aliked": dict(device="cpu", max_side=None), "disk": dict(device="cpu", max_side=None)}
    if args.only:
        specs = {k: v for k, v in specs.items() if k in args.only.split(",")}
    rows = {}
    for name, params in specs.items():
        det = baselines.get(name, **params)
        n = len(det.detect_corners(img))  # warm-up: JIT, weights, allocator
        wall, cpu = [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            det.detect_corners(img)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        q = lambda v: [round(float(x) * 1e3 / mp, 1) for x in np.percentile(v, [25, 50, 75])]  # noqa: E731
        rows[name] = {"points": n, "wall_ms_per_mp_q25_med_q75": q(wall), "cpu_ms_per_mp_q25_med_q75": q(cpu),
                      "params": params}
        print(f"{name:10s} {n:6d} pts  wall {q(wall)[1]:9.1f} ms/MP [{q(wall)[0]}, {q(wall)[2]}]  "
              f"cpu {q(cpu)[1]:9.1f} ms/MP [{q(cpu)[0]}, {q(cpu)[2]}]", flush=True)
    return {"image": str(args.image), "shape": list(img.shape), "megapixels": round(mp, 3),
            "threads": args.threads, "repeat": args.repeat, "rows": rows}


class _Detections:
    """Each image's selected points (and native descriptors) once per detector, for both descriptors."""

    def __init__(self, spec, det) -> None:
        self.spec, self.det, self.cache = spec, det, {}

    def get(self, path):
        from sogdd.evaluation.specs import detect
        from sogdd.image.files import read_image

        if path not in self.cache:
            image = read_image(path)
            t0 = time.perf_counter()
            c = detect(self.spec, image, self.det)
            t1 = time.perf_counter()
            native = self.det.describe_native(image, c) if self.det.family == "learned" else None
            self.cache[path] = (image, c, native, t1 - t0)
        return self.cache[path]

    def features(self, desc: str):
        from sogdd.corners import Corners
        from sogdd.descriptors import describe, descriptor_sizes
        from sogdd.evaluation.features import FeatureSet

        def feats(seq, path):
            image, c, native, secs = self.get(path)
            if desc == "native":
                d = native
            else:  # what sogdd.evaluation.features.extract_features does after detection
                sizes = descriptor_sizes(c, self.spec.desc_size, self.det.family)
                d = describe(image, Corners(c.xy, c.response, sizes, c.level), self.spec.desc,
                             upright=self.spec.upright)
            return FeatureSet(c.xy.copy(), c.response.copy(), d, c.size.copy(), c.level.copy(),
                              tuple(image.shape[:2]), secs, 0.0)
        return feats


def matching(args: argparse.Namespace) -> dict:
    from sogdd.evaluation.matching import evaluate_features, load_sequences
    from sogdd.evaluation.specs import build_detector, parse_spec

    sets = {"hpatches": DATA / "homography/hpatches", "oxford": DATA / "homography/oxford",
            "homogr": DATA / "homography/homogr"}
    seqs = [s for root in sets.values() for s in load_sequences(root)]
    out = {"budget": args.budget, "sequences": [s.name for s in seqs], "pairs": sum(len(s) for s in seqs),
           "rows": {}}
    for label in args.detectors.split(","):
        spec = parse_spec(f"{label}:top_k={args.budget}")
        dets = _Detections(spec, build_detector(spec))
        for desc in ("sift", "native") if label.split(":")[0] in LEARNED else ("sift",):
            r = evaluate_features(seqs, dets.features(desc), label=f"{label} desc={desc}")
            s = r.summary()
            row = {"mma1": s["mma"]["overall"][0], "mma3": s["mma"]["overall"][2],
                   "auc1_3_5": s["homography"]["auc"]["overall"], "features": s["features"],
                   "matches": s["matches"], "pairs": s["pairs"]["overall"],
                   "detect_seconds": round(sum(v[3] for v in dets.cache.values()), 1)}
            out["rows"][f"{label} desc={desc}"] = row
            print(f"{label:14s} desc={desc:6s} MMA@1 {row['mma1']:.3f} MMA@3 {row['mma3']:.3f} "
                  f"AUC@1/3/5 {', '.join(f'{a:.3f}' for a in row['auc1_3_5'])}  features {row['features']:.0f} "
                  f"matches {row['matches']:.0f}  detect {row['detect_seconds']:.0f} s", flush=True)
    return out


def repeatability(args: argparse.Namespace) -> dict:
    from sogdd.evaluation.repeatability import evaluate_repeatability, load_images
    from sogdd.evaluation.specs import parse_spec
    from sogdd.report.results_page import REPEATABILITY_TOP_N

    images = load_images(args.images)
    out = {"images": len(images), "full": args.full, "top_n": REPEATABILITY_TOP_N, "rows": {}}
    for label in args.detectors.split(","):
        t0 = time.perf_counter()
        rep = evaluate_repeatability(images, [parse_spec(label)], quick=not args.full, jobs=1,
                                     top_n=REPEATABILITY_TOP_N)
        rep.write(Path(args.out) / label.replace(":", "_"))
        out["rows"][label] = {"seconds": round(time.perf_counter() - t0, 1), "summary": rep.summary(),
                              "points": rep.points()}
        print(f"{label}: {out['rows'][label]['seconds']:.0f} s, overall "
              + ", ".join(f"{d} {v['overall']:.3f}" for d, v in rep.summary().items()), flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="part", required=True)
    sp = sub.add_parser("speed")
    sp.add_argument("--image", default=str(DATA / "multiview/fountain-P11/images/0000.jpg"))
    sp.add_argument("--side", type=int, default=1024)
    sp.add_argument("--repeat", type=int, default=5)
    sp.add_argument("--only", default=None, help="comma-separated names")
    mp = sub.add_parser("matching")
    mp.add_argument("--budget", type=int, default=2000)
    mp.add_argument("--detectors", default="sogdd,sogdd-authors,sogdd-hr,sift,akaze,xfeat,aliked,disk")
    rp = sub.add_parser("repeatability")
    rp.add_argument("--images", default=str(DATA / "repeatability"))
    rp.add_argument("--full", action="store_true", help="the paper's full grid (the report's --full)")
    rp.add_argument("--detectors", default=",".join(LEARNED))
    rp.add_argument("--out", default="docs/figures/repeatability_learned")
    for p in (sp, mp, rp):
        p.add_argument("--threads", type=int, default=1)
        p.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args()
    set_threads(args.threads)
    res = {"speed": speed, "matching": matching, "repeatability": repeatability}[args.part](args)
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, threads {args.threads}")


if __name__ == "__main__":
    main()
