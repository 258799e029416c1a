"""The GPU path against the CPU path and against plain PyTorch, on one CUDA device, in one run.

One prepared script for a session that is lent a GPU: first the
agreement of ``device="cuda"`` with the CPU path on a 1 MP image (the map's
relative error where it is well conditioned, the corners), then timings at 1, 6
and 24 MP:

- ``map (device in)``: :func:`sogdd.gpu.corner_response` on a grey uint8 image
  already on the device, the map left there (one fused kernel plus the grey
  conversion);
- ``detect (device in)``: :func:`sogdd.gpu.detect_corners` from the same device
  image, corners back on the host (peaks on the device, refinement on the host);
- ``detect (host in)``: from a numpy uint8 image, upload included;
- ``torch anchor``: the same measure as plain PyTorch float64 operations,
  unfused (2-D convolutions with the three basis kernels, steering, |.|, the
  K(K+1)/2 product maps, box sums, ``torch.linalg.det``), as the issue's anchor,
  if torch with CUDA is installed; its peak memory too.

Every time is the median of ``--repeat`` runs after one warm-up (JIT
compilation), with ``cuda.synchronize()`` before the clock stops, in ms and
ms/MP. Images are rendered test patterns with noise (the device machine cannot
reach the shared data), tiled to size. Paper preset (K = 8, sigma^2 = 1.2, 7 x 7).

Run: ``python benchmarks/bench_gpu.py [--sizes 1,6,24] [--repeat 5] [--json out.json]``
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

import sogdd
from sogdd.synthetic import pattern_image


def make_image(mp: float, seed: int = 0) -> np.ndarray:
    """A grey uint8 image of about ``mp`` megapixels: test-pattern tiles plus noise."""
    tile, _ = pattern_image((480, 640), seed=seed)
    tile = tile * 255.0 if tile.max() <= 1.0 else tile
    h = int(round(np.sqrt(mp * 1e6 * 3 / 4)))
    w = int(round(mp * 1e6 / h))
    reps = (-(-h // tile.shape[0]), -(-w // tile.shape[1]))
    img = np.tile(tile, reps)[:h, :w]
    noise = np.random.default_rng(seed).normal(0.0, 3.0, img.shape)
    return np.clip(np.round(img + noise), 0, 255).astype(np.uint8)


def timed(fn, repeat: int, sync) -> float:
    """Median wall time of fn() in ms, after one warm-up run."""
    fn()
    sync()
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        sync()
        ts.append((time.perf_counter() - t) * 1e3)
    return float(np.median(ts))


def torch_anchor(img_u8, torch, K: int = 8, sigma2: float = 1.2, window: int = 7):
    """Upsilon by plain float64 PyTorch operations, unfused (the issue's anchor). Returns a device tensor."""
    import torch.nn.functional as F

    from sogdd.measure.filters import kernel_radius, orientations, steerable_basis, steering_coefficients

    rk = kernel_radius(sigma2)
    b = steerable_basis(sigma2, rk)
    kern = np.stack([np.outer(b.gauss, b.d2), np.outer(b.d1, b.d1), np.outer(b.d2, b.gauss)])
    dev = "cuda"
    x = torch.as_tensor(img_u8, device=dev).to(torch.float64)[None, None]
    # scipy mode="reflect" is half-sample symmetric: torch's "reflect" is whole-sample, so pad by hand
    def sym_pad(t, p):
        t = torch.cat([t[..., :p, :].flip(-2), t, t[..., -p:, :].flip(-2)], dim=-2)
        return torch.cat([t[..., :p].flip(-1), t, t[..., -p:].flip(-1)], dim=-1)

    g = F.conv2d(sym_pad(x, rk), torch.as_tensor(kern, device=dev)[:, None])  # (1, 3, H, W)
    coef = torch.as_tensor(steering_coefficients(orientations(K)), device=dev)
    la = torch.einsum("kp,phw->khw", coef, g[0]).abs()
    R = window // 2
    la = sym_pad(la[None], R)[0]
    iu, ju = np.triu_indices(K)
    prod = la[iu] * la[ju]  # (K(K+1)/2, H + 2R, W + 2R): the product maps
    ones = torch.ones((1, 1, window, window), dtype=torch.float64, device=dev)
    S = F.conv2d(prod[:, None], ones)[:, 0]  # window sums
    H, W = S.shape[1:]
    M = torch.empty((H, W, K, K), dtype=torch.float64, device=dev)
    M[:, :, iu, ju] = S.permute(1, 2, 0)
    M[:, :, ju, iu] = S.permute(1, 2, 0)
    det = torch.linalg.det(M)
    tr = torch.diagonal(M, dim1=-2, dim2=-1).sum(-1)
    return det / (tr + 2.22e-16)


def agreement(gpu_map: np.ndarray, cpu_map: np.ndarray) -> dict:
    """Relative error of a map where the CPU map is above 1e-6 of its maximum (well conditioned)."""
    big = np.abs(cpu_map) > 1e-6 * np.abs(cpu_map).max()
    rel = np.abs(gpu_map - cpu_map)[big] / np.abs(cpu_map)[big]
    return {"p50": float(np.median(rel)), "p99": float(np.quantile(rel, 0.99)), "max": float(rel.max()),
            "max_abs_over_map_max": float(np.abs(gpu_map - cpu_map).max() / np.abs(cpu_map).max())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,6,24", help="megapixels, comma-separated")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", default=os.path.join(os.environ.get("OUT", "."), "bench_gpu.json"))
    ap.add_argument("--no-torch", action="store_true", help="skip the PyTorch anchor")
    ap.add_argument("--agree-mp", type=float, default=1.0, help="image size of the agreement check")
    args = ap.parse_args()

    from numba import cuda

    from sogdd import gpu

    if not gpu.available():
        print("bench_gpu: no CUDA device (numba.cuda.is_available() is False)", file=sys.stderr)
        return 2
    try:
        import torch

        torch = torch if (torch.cuda.is_available() and not args.no_torch) else None
    except ImportError:
        torch = None
    name = cuda.get_current_device().name if hasattr(cuda, "get_current_device") else "simulator"
    res: dict = {"device": name.decode() if isinstance(name, bytes) else str(name),
                 "numba": __import__("numba").__version__,
                 "torch": None if torch is None else torch.__version__, "agreement": {}, "timings": []}
    print(f"device: {res['device']}; numba {res['numba']}; torch {res['torch']}", flush=True)

    # 1. agreement with the CPU path
    img = make_image(args.agree_mp)
    cpu_map = sogdd.corner_response(img)
    gpu_map = gpu.corner_response(img)
    res["agreement"]["gpu_vs_cpu"] = agreement(gpu_map, cpu_map)
    c_cpu, c_gpu = sogdd.detect_corners(img), gpu.detect_corners(cuda.to_device(img))
    same = len(c_cpu) == len(c_gpu) and np.allclose(c_cpu.response, c_gpu.response, rtol=1e-9, atol=0)
    res["agreement"]["corners"] = {"cpu": len(c_cpu), "gpu": len(c_gpu), "same_peaks": bool(same),
                                   "max_dxy": float(np.abs(c_cpu.xy - c_gpu.xy).max()) if same and len(c_cpu)
                                   else None}
    h_cpu, h_gpu = sogdd.detect_corners(img, preset="hr"), gpu.detect_corners(img, preset="hr")
    same = len(h_cpu) == len(h_gpu) and np.allclose(h_cpu.response, h_gpu.response, rtol=1e-9, atol=0)
    res["agreement"]["hr_corners"] = {"cpu": len(h_cpu), "gpu": len(h_gpu), "same_peaks": bool(same),
                                      "max_dxy": float(np.abs(h_cpu.xy - h_gpu.xy).max()) if same and len(h_cpu)
                                      else None}
    if torch is not None:
        res["agreement"]["torch_vs_cpu"] = agreement(torch_anchor(img, torch).cpu().numpy(), cpu_map)
    print(json.dumps(res["agreement"], indent=1), flush=True)

    # 2. timings
    print("| MP | what | ms | ms/MP |\n|---|---|---|---|", flush=True)
    for mp in (float(s) for s in args.sizes.split(",")):
        img = make_image(mp, seed=1)
        d_img = cuda.to_device(img)
        n_mp = img.size / 1e6
        cases = {
            "map (device in)": lambda d=d_img: gpu.corner_response(d),
            "detect (device in)": lambda d=d_img: gpu.detect_corners(d),
            "detect (host in)": lambda h=img: gpu.detect_corners(h),
            "hr detect (host in)": lambda h=img: gpu.detect_corners(h, preset="hr"),
            "cpu hr detect": lambda h=img: sogdd.detect_corners(h, preset="hr"),
        }
        if torch is not None:
            cases["torch anchor"] = lambda h=img: torch_anchor(h, torch)
        row = {"mp": n_mp, "corners": len(gpu.detect_corners(d_img))}
        for name, fn in cases.items():
            ms = timed(fn, args.repeat, cuda.synchronize if "torch" not in name else torch.cuda.synchronize)
            row[name] = ms
            print(f"| {n_mp:.1f} | {name} | {ms:.2f} | {ms / n_mp:.3f} |", flush=True)
        if torch is not None:
            torch.cuda.reset_peak_memory_stats()
            torch_anchor(img, torch)
            torch.cuda.synchronize()
            row["torch_peak_gib"] = torch.cuda.max_memory_allocated() / 2**30
            print(f"| {n_mp:.1f} | torch anchor peak memory | {row['torch_peak_gib']:.2f} GiB | |", flush=True)
        res["timings"].append(row)
    with open(args.json, "w") as f:
        json.dump(res, f, indent=1)
    print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
