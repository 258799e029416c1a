"""The GPU path (sogdd.gpu) against the CPU path, run on numba's CUDA simulator.

CI has no GPU. numba's CUDA simulator runs the same kernel source (shared memory,
barriers, atomics) in Python threads; it must be switched on before numba.cuda
is first imported, so the GPU side runs in one subprocess with
NUMBA_ENABLE_CUDASIM=1 that saves its results, and the tests compare them with
the CPU path here. The simulator is slow: images are tiny, and the tests that read its results are
marked ``slow`` (the one subprocess takes about a minute on two cores).
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import sogdd
from sogdd.synthetic import Polygon, regular_polygon, render_polygons


def shapes_image(shape=(24, 31), seed=0) -> np.ndarray:
    """Two polygons with sub-pixel vertices plus mild noise, float on [0, 1]."""
    rng = np.random.default_rng(seed)
    h, w = shape
    polys = [Polygon(regular_polygon((w * 0.3, h * 0.4), h * 0.3, 3, 0.3), 210.0),
             Polygon(regular_polygon((w * 0.72, h * 0.6), h * 0.3, 4, 0.2), 140.0)]
    img = render_polygons(shape, polys, background=30.0) + rng.normal(0, 2.0, shape)
    return np.clip(img, 0, 255) / 255.0


# (name, image shape, preset, overrides): the kernel's specialisations (K, window
# shape and size, kernel radius, zero-mean kernels, both border paddings, tile edges)
RESPONSE_CASES = [
    ("paper_k8", (24, 31), "paper", {}),
    ("k4_s2_w5", (24, 31), "paper", {"n_orientations": 4, "sigma2": 2.0, "window": 5}),
    ("image_pad_zero_mean", (20, 18), "paper", {"sigma2": 0.8, "window": 3, "padding": "image",
                                                "zero_mean": True}),
    ("authors_disk", (21, 23), "authors", {}),
    ("tiny_reflect", (5, 7), "paper", {"n_orientations": 4}),
    ("hr_gaussian_window", (24, 31), "hr", {}),
]


def junction_image(shape=(36, 40)) -> np.ndarray:
    """Two squares meeting at an X-junction (16.3, 17.6) beside a polygon's L-corners, uint8 with noise."""
    h, w = shape
    q = np.array([[16.3, 17.6], [40, 17.6], [40, 40], [16.3, 40]])
    polys = [Polygon(q, 200.0), Polygon(2 * q[0] - q, 200.0),
             Polygon(regular_polygon((w * 0.75, h * 0.3), h * 0.2, 4, 0.3), 140.0)]
    img = render_polygons(shape, polys, background=40.0) + np.random.default_rng(2).normal(0, 1.5, shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)

def edge_triangle_image() -> np.ndarray:
    """A triangle whose vertex lies 2 px below the top edge: two peaks of the measure refine onto it
    (as in tests/select/test_coincident.py), uint8."""
    q = np.array([[5.3, 14.4], [24.3, 29.0], [24.3, 2.02]])
    return np.round(render_polygons((24, 32), [Polygon(q, 200.0)], background=40.0)).astype(np.uint8)


_SCRIPT = textwrap.dedent(
    """
    import sys, numpy as np
    from numba import cuda
    from sogdd import gpu
    sys.path.insert(0, sys.argv[2])
    from test_gpu import RESPONSE_CASES, shapes_image
    out = {}
    for name, shape, preset, kw in RESPONSE_CASES:
        out["resp_" + name] = gpu.corner_response(shapes_image(shape), preset=preset, **kw)
    img = shapes_image((24, 31))
    c = gpu.detect_corners(img, threshold=1e8)  # host input: refinement reads the host image
    out["det_xy"], out["det_resp"] = c.xy, c.response
    u8 = np.round(img * 255).astype(np.uint8)
    c = gpu.detect_corners(cuda.to_device(u8), threshold=1e8)  # device input: patches from the device
    out["dev_xy"], out["dev_resp"] = c.xy, c.response
    c = gpu.detect_corners(img, threshold=1.0, border=5, nms_radius=2, subpixel=False)
    out["border_xy"] = c.xy  # maxima of the valid area alone, as the CPU path finds them
    b = gpu.corner_response_batch(cuda.to_device(np.stack([u8[:, :16], u8[:, 15:]])), preset="paper",
                                  n_orientations=2, window=3)
    out["batch"] = b.copy_to_host()
    from test_gpu import junction_image
    xim = junction_image()
    for key, im in (("hr", xim), ("hr_dev", cuda.to_device(xim))):  # X-junctions and refinement on the host
        c = gpu.detect_corners(im, preset="hr")
        out[key + "_xy"], out[key + "_resp"] = c.xy, c.response
    u8p = np.round(shapes_image((40, 50)) * 255).astype(np.uint8)  # level 1 holds a keypoint (17 px)
    c = gpu.detect_corners(cuda.to_device(u8p), threshold=1e7, levels=2, border=3)  # the pyramid
    out["lev_xy"], out["lev_resp"], out["lev_level"] = c.xy, c.response, c.level
    from test_gpu import edge_triangle_image
    tri = edge_triangle_image()
    for key, im in (("tri", tri), ("tri_dev", cuda.to_device(tri))):  # merged, cut, refilled
        c = gpu.detect_corners(im, max_corners=3)
        out[key + "_xy"], out[key + "_resp"] = c.xy, c.response
    np.savez(sys.argv[1], **out)
    """
)


_SIM_ENV = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")


@functools.cache
def simulator_missing() -> str | None:
    """Why numba's CUDA simulator cannot be imported here, or None when it can.

    Only this is a reason to skip: once the simulator imports, any failure of the
    GPU script (a kernel that indexes out of range, a wrong result) fails the tests.
    """
    code = "from numba import cuda; from numba.cuda import simulator; assert cuda.simulator is simulator"
    proc = subprocess.run([sys.executable, "-c", code], env=_SIM_ENV, capture_output=True, text=True,
                          timeout=120)
    if proc.returncode == 0:
        return None
    return (proc.stderr.strip().splitlines() or ["no message"])[-1]


def run_on_simulator(args: list[str]) -> subprocess.CompletedProcess:
    """Run ``python ARGS`` with the simulator switched on; skip only where it cannot be imported."""
    if (why := simulator_missing()) is not None:
        pytest.skip("numba's CUDA simulator is unavailable: " + why)
    return subprocess.run([sys.executable, *args], env=_SIM_ENV, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    path = tmp_path_factory.mktemp("gpu") / "sim.npz"
    proc = run_on_simulator(["-c", _SCRIPT, str(path), os.path.dirname(__file__)])
    assert proc.returncode == 0, proc.stderr[-3000:]
    return dict(np.load(path))


def _rel_err(gpu: np.ndarray, cpu: np.ndarray) -> np.ndarray:
    """|gpu - cpu| relative to |cpu|, where the measure is well conditioned (above 1e-6 of its maximum)."""
    big = np.abs(cpu) > 1e-6 * np.abs(cpu).max()
    return np.abs(gpu - cpu)[big] / np.abs(cpu)[big]


@pytest.mark.slow
@pytest.mark.parametrize("name,shape,preset,kw", RESPONSE_CASES, ids=[c[0] for c in RESPONSE_CASES])
def test_response_matches_cpu(sim, name, shape, preset, kw):
    cpu = sogdd.corner_response(shapes_image(shape), preset=preset, **kw)
    gpu = sim["resp_" + name]
    assert gpu.shape == cpu.shape and gpu.dtype == np.float64
    fin = np.isfinite(cpu)
    assert np.array_equal(np.isfinite(gpu), fin)
    rel = _rel_err(gpu[fin], cpu[fin])
    assert rel.size >= 10
    assert np.quantile(rel, 0.99) < 1e-9 and rel.max() < 1e-7
    # below the well-conditioned range the map agrees to rounding of its largest values
    assert np.abs(gpu[fin] - cpu[fin]).max() <= 1e-10 * np.abs(cpu[fin]).max()


@pytest.mark.slow
def test_detection_matches_cpu(sim):
    img = shapes_image((24, 31))
    for key, im in (("det", img), ("dev", np.round(img * 255).astype(np.uint8))):
        cpu = sogdd.detect_corners(im, threshold=1e8)
        assert len(cpu) >= 3  # the vertices are found at all
        xy, resp = sim[key + "_xy"], sim[key + "_resp"]
        assert len(resp) == len(cpu)
        # the same peaks (same order, strongest first) with the same values to rounding
        assert np.allclose(resp, cpu.response, rtol=1e-10, atol=0)
        # host refinement is identical; refinement on device patches differs in float32 coordinates only
        assert np.abs(xy - cpu.xy).max() < (1e-6 if key == "det" else 1e-3)


@pytest.mark.slow
def test_hr_detection_matches_cpu(sim):
    """hr on the device: Gaussian window in the kernel, grey units, the X-junction and adaptive refinement."""
    cpu = sogdd.detect_corners(junction_image(), preset="hr")
    d = np.hypot(*(cpu.xy - [16.3, 17.6]).T)
    assert len(cpu) >= 4 and d.min() < 0.1  # the junction on its saddle, and the square's corners
    for key in ("hr", "hr_dev"):
        assert len(sim[key + "_resp"]) == len(cpu)
        np.testing.assert_allclose(sim[key + "_resp"], cpu.response, rtol=1e-9)
        assert np.abs(sim[key + "_xy"] - cpu.xy).max() < 1e-6


@pytest.mark.slow
def test_pyramid_matches_cpu(sim):
    u8 = np.round(shapes_image((40, 50)) * 255).astype(np.uint8)  # level 1 holds a keypoint (17 px)
    cpu = sogdd.detect_corners(u8, threshold=1e7, levels=2, border=3)
    assert len(cpu) >= 3 and set(cpu.level.tolist()) == {0, 1}
    np.testing.assert_array_equal(sim["lev_level"], cpu.level)
    np.testing.assert_allclose(sim["lev_resp"], cpu.response, rtol=1e-9)
    assert np.abs(sim["lev_xy"] - cpu.xy).max() < 1e-6


@pytest.mark.slow
def test_coincident_points_merged_before_the_cut_as_on_cpu(sim):
    """Two peaks refined onto one point are one corner on the device too, and max_corners is refilled."""
    img = edge_triangle_image()
    cpu = sogdd.detect_corners(img, max_corners=3)
    assert len(cpu) == 3
    for key in ("tri", "tri_dev"):
        xy = sim[key + "_xy"]
        gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))[~np.eye(len(xy), dtype=bool)]
        assert len(xy) == 3 and gaps.min() > 0.1
        np.testing.assert_allclose(sim[key + "_resp"], cpu.response, rtol=1e-10)
        # host refinement is identical; on device patches, float32 coordinates
        assert np.abs(xy - cpu.xy).max() < (1e-6 if key == "tri" else 1e-3)


@pytest.mark.slow
def test_detection_with_border_matches_cpu(sim):
    """Maxima on the last valid row or column are judged within the valid area, as on the CPU."""
    cpu = sogdd.detect_corners(shapes_image((24, 31)), threshold=1.0, border=5, nms_radius=2, subpixel=False)
    assert len(cpu) >= 3
    np.testing.assert_array_equal(sim["border_xy"], cpu.xy)


@pytest.mark.slow
def test_device_stack_batch(sim):
    u8 = np.round(shapes_image((24, 31)) * 255).astype(np.uint8)
    for j, part in enumerate([u8[:, :16], u8[:, 15:]]):
        cpu = sogdd.corner_response(part, n_orientations=2, window=3)
        assert np.abs(sim["batch"][j] - cpu).max() <= 1e-10 * np.abs(cpu).max()


def test_cuda_absent_is_a_clear_error():
    from sogdd.gpu.input import cuda_runtime_available

    if cuda_runtime_available():
        pytest.skip("a CUDA device is present")
    img = shapes_image((12, 12))
    for f in (sogdd.corner_response, sogdd.detect_corners):
        with pytest.raises(ValueError, match="device='cuda' needs an NVIDIA GPU"):
            f(img, device="cuda")
    with pytest.raises(ValueError, match="device must be"):
        sogdd.corner_response(img, device="tpu")


def test_cpu_users_never_import_the_gpu_module():
    code = ("import sys, numpy as np, sogdd; sogdd.detect_corners(np.zeros((16, 16), np.uint8)); "
            "print('sogdd.gpu' in sys.modules, 'numba.cuda' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["False", "False"], out.stderr[-2000:]


def test_cli_device_cuda_without_cuda(tmp_path, capsys):
    from sogdd.cli.main import main
    from sogdd.gpu.input import cuda_runtime_available

    if cuda_runtime_available():
        pytest.skip("a CUDA device is present")
    import cv2

    f = str(tmp_path / "img.png")
    cv2.imwrite(f, np.round(shapes_image((24, 31)) * 255).astype(np.uint8))
    npy = str(tmp_path / "r.npy")
    for args in (["detect", f, "--device", "cuda"], ["response", f, "-o", npy, "--device", "cuda"]):
        capsys.readouterr()
        assert main(args) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("sogdd: error:") and "device='cuda'" in err[0]


def test_cli_batch_on_the_device_writes_the_cpu_corners(tmp_path):
    """``sogdd detect DIR --device cuda --out OUT`` (simulator): a feature file per image, the CPU's corners."""
    import cv2

    from sogdd.formats.features import read_features

    for i in range(2):
        u8 = np.round(shapes_image((24, 31), seed=i) * 255).astype(np.uint8)
        cv2.imwrite(str(tmp_path / f"im{i}.png"), u8)
    proc = run_on_simulator(["-m", "sogdd", "detect", str(tmp_path), "--device", "cuda", "--threshold", "1e8",
                             "--out", str(tmp_path / "out")])
    assert proc.returncode == 0, proc.stderr[-3000:]
    for i in range(2):
        rec = read_features(tmp_path / "out" / f"im{i}.png.npz")[0]
        img = cv2.imread(str(tmp_path / f"im{i}.png"), cv2.IMREAD_UNCHANGED)
        cpu = sogdd.detect_corners(img, threshold=1e8)
        assert len(cpu) >= 3 and len(rec.corners) == len(cpu)
        assert np.abs(rec.corners.xy - cpu.xy).max() < 1e-6


def test_batch_on_a_missing_gpu_fails_once_before_any_work(tmp_path):
    from sogdd.collection import run_batch
    from sogdd.gpu.input import cuda_runtime_available

    if cuda_runtime_available():
        pytest.skip("a CUDA device is present")
    with pytest.raises(ValueError, match="device='cuda' needs an NVIDIA GPU"):
        run_batch([str(tmp_path / "none.png")], tmp_path / "out", device="cuda")
    with pytest.raises(ValueError, match="device must be"):
        run_batch([str(tmp_path / "none.png")], tmp_path / "out", device="tpu")
