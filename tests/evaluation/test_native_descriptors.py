"""``desc=native``: the learned detectors' own descriptors in the matching and SfM features.

The tests that run a network skip, with the reason, where the ``learned`` extra
is not installed; the error paths, the default lists and the worker start
method run everywhere.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from sogdd import baselines
from sogdd.baselines import learned_extra
from sogdd.cli.main import main
from sogdd.collection import processes
from sogdd.evaluation import pools, specs
from sogdd.evaluation.features import extract_features
from sogdd.evaluation.sfm.pipeline import matcher_for
from sogdd.evaluation.specs import (
    DEFAULT_MATCHING,
    DEFAULT_SFM,
    LEARNED_DOWNSTREAM,
    DetectorSpec,
    check_descriptor,
    default_fast_specs,
    default_matching,
    default_sfm,
    parse_spec,
    parse_specs,
)
from sogdd.synthetic import pattern_image

NEEDS_EXTRA = pytest.mark.learned  # skipped with the reason without the extra (tests/conftest.py)


@pytest.fixture(scope="module")
def scene() -> np.ndarray:
    return pattern_image((256, 320), seed=3)[0]


# ------------------------------------------------------------- everywhere
def test_native_is_a_descriptor_choice_and_a_bad_one_names_it():
    assert parse_spec("xfeat:desc=native").desc == "native"
    with pytest.raises(ValueError, match="sift, rootsift, native"):
        DetectorSpec("sift", desc="bogus")


def test_native_on_a_classic_detector_fails_before_any_work(scene):
    with pytest.raises(ValueError, match=r"^harris:desc=native: harris has no descriptor of its own"):
        parse_specs(["harris:desc=native"], [])
    # a detector passed in is checked too, before it detects
    with pytest.raises(ValueError, match="no descriptor of its own"):
        extract_features(scene, parse_spec("sift:desc=native"), baselines.get("sift"))


def test_a_detector_that_says_it_has_no_native_descriptors_is_refused():
    class Onnx:  # aliked/disk on an ONNX file: the method exists, the descriptors do not
        native_descriptors = False

        def describe_native(self, image, corners):
            raise AssertionError("not to be called")

    with pytest.raises(ValueError, match="no descriptor of its own"):
        check_descriptor(parse_spec("aliked:desc=native"), Onnx())
    det = Onnx()
    det.native_descriptors = True
    assert check_descriptor(parse_spec("aliked:desc=native"), det) is det


def test_cli_native_on_a_classic_detector_is_one_line_and_exit_2(capsys, tmp_path):
    pytest.importorskip("pycolmap", reason="sogdd eval sfm needs the 'sfm' extra (pycolmap)")
    # the specs are checked before any image is read: an empty folder is enough
    rc = main(["eval", "sfm", "--images", str(tmp_path), "--detectors", "orb:desc=native", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.startswith("sogdd: error: orb:desc=native: orb has no descriptor of its own")
    assert err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize("installed", [False, True])
def test_default_lists_add_the_learned_rows_only_with_the_extra(monkeypatch, installed):
    monkeypatch.setattr(learned_extra, "installed", lambda: installed)
    learned = list(LEARNED_DOWNSTREAM) if installed else []
    assert default_matching() == [*DEFAULT_MATCHING, *learned]
    assert default_sfm() == [*DEFAULT_SFM, *learned]
    assert LEARNED_DOWNSTREAM == ("xfeat", "xfeat:desc=native", "aliked", "aliked:desc=native",
                                  "disk", "disk:desc=native")


def test_repeatability_default_has_the_learned_entries_exactly_where_they_run():
    labels = [s.label for s in default_fast_specs()]
    for name in ("xfeat", "aliked", "disk"):
        assert (name in labels) == learned_extra.installed()


def test_sfm_matches_native_descriptors_with_mnn():
    assert matcher_for(parse_spec("sift"), "colmap") == "colmap"
    assert matcher_for(parse_spec("sift"), "mnn") == "mnn"
    assert matcher_for(parse_spec("disk:desc=native"), "colmap") == "mnn"


def test_workers_are_spawned_once_torch_is_loaded(monkeypatch):
    import numba

    monkeypatch.setattr(numba, "threading_layer", lambda: "workqueue")
    monkeypatch.delitem(sys.modules, "torch", raising=False)
    assert processes.safe_start_method() == "fork"  # Linux: the workers inherit numba's compiled code
    monkeypatch.setitem(sys.modules, "torch", object())
    assert processes.safe_start_method() == "spawn"
    with pools.process_pool(1) as ex:  # the evaluations' pool follows the rule
        assert ex._mp_context.get_start_method() == "spawn"


def test_workers_come_from_a_forkserver_once_numba_ran_on_gnu_openmp(monkeypatch):
    """A child forked from a parent whose numba parallel code ran on GNU OpenMP dies at its own."""
    import numba

    monkeypatch.delitem(sys.modules, "torch", raising=False)
    monkeypatch.setattr(numba, "threading_layer", lambda: "omp")
    assert processes.safe_start_method() == "forkserver"

    def never_ran():
        raise ValueError("no threading layer")

    monkeypatch.setattr(numba, "threading_layer", never_ran)
    assert processes.safe_start_method() == "fork"


# ---------------------------------------------------- with the learned extra
@NEEDS_EXTRA
@pytest.mark.parametrize("name,dim", [("xfeat", 64), ("aliked", 128), ("disk", 128)])
def test_native_features_are_the_networks_own(scene, name, dim):
    det = baselines.get(name, device="cpu")
    corners, own = det.detect_and_describe(scene)
    fs = extract_features(scene, parse_spec(f"{name}:desc=native:top_k=40"), det)
    assert 0 < len(fs) <= 40 and fs.descriptors.shape == (len(fs), dim)
    assert fs.descriptors.dtype == np.float32
    # the selected points are the strongest 40, described as detect_and_describe describes them
    np.testing.assert_array_equal(fs.keypoints, corners.xy[: len(fs)])
    np.testing.assert_array_equal(fs.descriptors, own[: len(fs)])
    np.testing.assert_allclose(np.linalg.norm(fs.descriptors, axis=1), 1.0, atol=1e-5)
    sift = extract_features(scene, parse_spec(f"{name}:top_k=40"), det)
    np.testing.assert_array_equal(sift.keypoints, fs.keypoints)
    assert sift.descriptors.shape == (len(fs), 128) and float(sift.descriptors.max()) > 1.0  # SIFT's scale


@NEEDS_EXTRA
def test_native_features_with_no_point_left(scene):
    fs = extract_features(scene, parse_spec("xfeat:desc=native:remove_border=500"))
    assert len(fs) == 0 and fs.descriptors.shape[0] == 0


@NEEDS_EXTRA
def test_native_matching_finds_the_identity(scene):
    from sogdd.evaluation.matching.protocol import mutual_nn

    fs = extract_features(scene, parse_spec("aliked:desc=native:top_k=60"))
    m = mutual_nn(fs.descriptors, fs.descriptors)
    np.testing.assert_array_equal(m[:, 0], m[:, 1])
    assert len(m) == len(fs)


@NEEDS_EXTRA
def test_repeatability_with_two_workers_and_a_learned_detector_finishes():
    # forked from a process whose PyTorch runs, a worker hung for ever (10 min here before the fix)
    code = textwrap.dedent("""
        from sogdd.evaluation.repeatability import evaluate_repeatability
        from sogdd.evaluation.specs import parse_specs
        from sogdd.synthetic import pattern_image
        specs = parse_specs(["xfeat:device=cpu", "harris"], [])
        imgs = [("a", pattern_image((160, 200), seed=1)[0]), ("b", pattern_image((160, 200), seed=2)[0])]
        rep = evaluate_repeatability(imgs, specs, families=("rotation",), quick=True, jobs=2, progress=False)
        print(rep.summary()["xfeat:device=cpu"]["rotation"])
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=240)
    assert out.returncode == 0, out.stderr[-2000:]
    assert 0.0 < float(out.stdout.split()[-1]) <= 1.0


@NEEDS_EXTRA
def test_sfm_with_native_descriptors_reconstructs(tmp_path):
    pytest.importorskip("pycolmap", reason="SfM needs the 'sfm' extra (pycolmap)")
    import cv2

    from sogdd.evaluation.sfm import run_sfm

    # three views of one textured plane, rendered: a rotation about the vertical axis between them
    rng = np.random.default_rng(0)
    tex = cv2.GaussianBlur(rng.uniform(0, 255, (480, 640)).astype(np.float32), (0, 0), 2.0)
    tex = cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    img_dir = tmp_path / "images"
    img_dir.mkdir()
    for i, dx in enumerate((0.0, 12.0, 24.0)):
        h = np.array([[1.0, 0.02 * i, dx], [0.0, 1.0, 0.5 * dx], [1e-5 * i, 0.0, 1.0]])
        cv2.imwrite(str(img_dir / f"{i:04d}.png"), cv2.warpPerspective(tex, h, (640, 480)))
    r = run_sfm(img_dir, parse_spec("xfeat:desc=native:top_k=800:device=cpu"), tmp_path / "work",
                dense=False, num_threads=1)
    assert r["matcher"] == "mnn" and r["features"] > 100
    assert r["matches"] > 200 and r["inlier_matches"] > 100


def test_spec_module_lists_its_new_names():
    for name in ("NATIVE", "DESCRIPTORS", "LEARNED", "LEARNED_DOWNSTREAM", "check_descriptor",
                 "default_matching", "default_sfm"):
        assert name in specs.__all__ and hasattr(specs, name)
