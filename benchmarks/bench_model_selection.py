"""The lens model chosen by cross-validation against each fixed model, on the rendered mono sequences.

Renders the evaluation's standard sequences (``sogdd.evaluation.calibration.sequences``: true camera
k1, k2, p1, p2, k3 = 0), runs sogdd's detector once per view (one noise draw, as
``sogdd eval calibration``), then calibrates the same boards with each fixed model (``pinhole4``:
k1, k2, p1, p2; ``pinhole``: + k3; ``rational``) and with ``model="auto"``
(:func:`sogdd.calib.model_selection.select_model`), and prints per sequence and overall the mean
projection difference to the true camera (``sogdd.calib.projection_difference``, px, over the
whole frame), the model auto chose and the time of each fit.

    python benchmarks/bench_model_selection.py                       # the five sequences
    python benchmarks/bench_model_selection.py --sequences sharp,blur --cache /tmp/boards.npz
    python benchmarks/bench_model_selection.py --cache /tmp/boards.npz --jobs 2   # detect once, reuse

``--cache`` keeps the detected boards (a later run with the same file skips rendering and
detection). ``--jobs`` renders and detects views in parallel processes. ``--lens HFOV:K1,K2,P1,P2,K3``
replaces every sequence's camera by ``camera_for(width, height, HFOV, (K1, ..., K3))`` (same
principal point offset and aspect), e.g. a lens that needs k3:

    python benchmarks/bench_model_selection.py --lens 90:-0.3,0.12,0.0008,-0.0006,-0.08 --cache /tmp/k3.npz
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
import zlib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

FIXED = ("pinhole4", "pinhole", "rational")


def _seed(*parts: object) -> int:
    # the evaluation's noise seed (protocol._seed): the same draw 0 as ``sogdd eval calibration``
    return zlib.crc32("/".join(str(p) for p in parts).encode())


def sequence(name: str, lens: str | None):
    """The named standard sequence, its camera replaced by ``lens`` (``HFOV:K1,K2,P1,P2,K3``) if given."""
    from sogdd.evaluation.calibration.sequences import SEQUENCES, camera_for

    seq = SEQUENCES[name]
    if lens is None:
        return seq
    hfov, dist = lens.split(":")
    return dataclasses.replace(seq, camera=camera_for(*seq.camera.size, float(hfov),
                                                      tuple(float(d) for d in dist.split(","))))


def _detect(job):
    """One view rendered and detected: ``(points, labels)`` or None."""
    name, lens, v, rvec, tvec = job
    from sogdd.evaluation.calibration.comparators import METHODS
    from sogdd.evaluation.calibration.render import add_noise, render_scene

    seq = sequence(name, lens)
    clean = render_scene(seq.camera, seq.target, rvec, tvec, blur=seq.blur, falloff=seq.falloff)
    image = add_noise(clean, seq.noise, _seed(seq.name, seq.seed, v, 0))
    det = METHODS["sogdd"].detect(image, seq.target.pattern_size)
    return (np.asarray(det.points, float), np.asarray(det.labels, int)) if det.found else None


def detect_all(names: list[str], jobs: int, cache: Path | None, lens: str | None = None) -> dict:
    """``{sequence: [(points, labels) or None per view]}``, from ``cache`` when it holds them."""
    store: dict = {}
    if cache is not None and cache.exists():
        data = np.load(cache, allow_pickle=True)
        store = data["boards"].item()
    todo = [n for n in names if n not in store]
    jobs_list = [(n, lens, v, r, t) for n in todo for v, (r, t) in enumerate(sequence(n, lens).poses())]
    if jobs_list:
        t0 = time.perf_counter()
        if jobs > 1:
            with ProcessPoolExecutor(jobs) as ex:
                found = list(ex.map(_detect, jobs_list))
        else:
            found = [_detect(j) for j in jobs_list]
        for (n, _lens, _v, _r, _t), f in zip(jobs_list, found):
            store.setdefault(n, []).append(f)
        print(f"rendered and detected {len(jobs_list)} views in {time.perf_counter() - t0:.0f} s")
        if cache is not None:
            np.savez(cache, boards=np.array(store, dtype=object))
    return {n: store[n] for n in names}


def evaluate(name: str, boards: list, models: tuple[str, ...], lens: str | None = None) -> dict:
    """Each model's projection difference to the true camera on one sequence's boards."""
    from sogdd.calib import Board, calibrate, projection_difference

    seq = sequence(name, lens)
    cam = seq.camera
    truth = (np.asarray(cam.K), np.asarray(cam.dist))
    usable = [Board(p, lab) for p, lab in (b for b in boards if b is not None) if len(p) >= 6]
    row: dict = {"sequence": name, "views": len(usable)}
    for m in models:
        t0 = time.perf_counter()
        cal = calibrate(usable, cam.size, square=seq.target.square, model=m, cross_validate=False)
        dt = time.perf_counter() - t0
        row[m] = round(float(projection_difference(truth, cal, cam.size).mean), 4)
        row[f"{m}_s"] = round(dt, 2)
        if m == "auto":
            row["chosen"] = cal.model
            row["table"] = [(c.model, round(c.cv_rms, 4), round(c.difference, 4), round(c.difference_se, 4))
                            for c in cal.model_selection.table]
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sequences", default="sharp,dense,6mp,blur,partial")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--cache", type=Path, help="keep the detected boards in this .npz file")
    ap.add_argument("--json", type=Path, help="write the rows as JSON here")
    ap.add_argument("--lens", metavar="HFOV:K1,K2,P1,P2,K3", help="replace the sequences' camera (see above)")
    a = ap.parse_args()
    names = [s.strip() for s in a.sequences.split(",") if s.strip()]
    found = detect_all(names, a.jobs, a.cache, a.lens)
    models = (*FIXED, "auto")
    rows = [evaluate(n, found[n], models, a.lens) for n in names]
    head = f"{'sequence':>9} {'views':>5} " + " ".join(f"{m:>9}" for m in models) + "  chosen   auto_s"
    print(head)
    for r in rows:
        print(f"{r['sequence']:>9} {r['views']:>5} " + " ".join(f"{r[m]:9.3f}" for m in models)
              + f"  {r['chosen']:<8} {r['auto_s']:.1f}")
    means = {m: float(np.mean([r[m] for r in rows])) for m in models}
    print(f"{'mean':>9} {'':>5} " + " ".join(f"{means[m]:9.3f}" for m in models))
    best = min(means[m] for m in FIXED)
    print(f"auto {means['auto']:.3f} px; best fixed {best:.3f} px; auto / best = {means['auto'] / best:.3f}")
    for r in rows:
        print(f"  {r['sequence']}: " + "; ".join(f"{m} cv {cv:.4f} (+{d:.4f} +- {se:.4f})"
                                                  for m, cv, d, se in r["table"]))
    if a.json:
        a.json.write_text(json.dumps({"rows": rows, "means": means}, indent=1) + "\n")


if __name__ == "__main__":
    main()
