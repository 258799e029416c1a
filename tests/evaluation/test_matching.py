"""HPatches MMA: the D2-Net protocol (exclusions, MNN, thresholds), loaders, a synthetic pair; H AUC."""

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.corners import Corners
from sogdd.descriptors import descriptor_sizes
from sogdd.evaluation.features import FeatureSet
from sogdd.evaluation.matching.data import (
    D2NET_EXCLUDED,
    HomographySequence,
    detect_layout,
    homogr_to_zero_based,
    load_published,
    load_sequences,
)
from sogdd.evaluation.matching.homography import auc_of_errors, corner_error, estimate_homography
from sogdd.evaluation.matching.protocol import (
    THRESHOLDS,
    evaluate_features,
    evaluate_specs,
    match_errors,
    mma_of_errors,
    mutual_nn,
    project,
)
from sogdd.evaluation.specs import parse_spec, select
from sogdd.synthetic import pattern_image as _pattern

# A mild viewpoint change: rotation, scale, a little perspective (maps image 1 to image 2).
H_TEST = np.array([[0.95, -0.12, 30.0], [0.10, 0.97, 12.0], [1.0e-4, -5.0e-5, 1.0]])


# ------------------------------------------------------------------ protocol
def test_exclusion_list_is_d2nets():
    assert len(D2NET_EXCLUDED) == 8
    assert {"i_contruction", "i_crownnight", "i_dc", "i_pencils", "i_whitebuilding",
            "v_artisans", "v_astronautis", "v_talent"} == set(D2NET_EXCLUDED)


def test_mutual_nn_keeps_only_mutual_pairs():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(50, 16)).astype(np.float32)
    perm = rng.permutation(50)
    b = a[perm] + 0.01 * rng.normal(size=(50, 16)).astype(np.float32)
    m = mutual_nn(a, b)
    assert len(m) == 50
    np.testing.assert_array_equal(perm[m[:, 1]], m[:, 0])
    # two A descriptors whose nearest neighbour is the same B descriptor: one survives
    a2 = np.array([[1.0, 0.0], [0.9, 0.1], [0.0, 1.0]])
    b2 = np.array([[1.0, 0.05], [-1.0, 0.0], [0.1, 1.0]])
    m2 = mutual_nn(a2, b2)
    assert {tuple(r) for r in m2} == {(0, 0), (2, 2)}
    assert mutual_nn(np.zeros((0, 8)), b).shape == (0, 2)


def test_mutual_nn_uses_normalised_descriptors():
    # b[1] is closer to a[0] in raw L2 but b[0] has the same direction
    a = np.array([[1.0, 0.0]])
    b = np.array([[10.0, 0.0], [0.8, 0.5]])
    assert mutual_nn(a, b).tolist() == [[0, 0]]


def test_mutual_nn_chunks_agree():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(300, 32)), rng.normal(size=(250, 32))
    np.testing.assert_array_equal(mutual_nn(a, b, chunk=7), mutual_nn(a, b, chunk=10_000))


def test_thresholds_inclusive_and_empty_scores_zero():
    assert THRESHOLDS == tuple(range(1, 11))
    acc = mma_of_errors(np.array([1.0, 2.5, 10.0, 11.0]))
    np.testing.assert_allclose(acc, [0.25, 0.25, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.75])
    np.testing.assert_array_equal(mma_of_errors(np.zeros(0)), np.zeros(10))


def test_errors_project_image1_points():
    xy_a = np.array([[10.0, 20.0], [100.0, 50.0]])
    xy_b = project(H_TEST, xy_a) + np.array([[0.0, 3.0], [4.0, 0.0]])
    err = match_errors(xy_a, xy_b, np.array([[0, 0], [1, 1]]), H_TEST)
    np.testing.assert_allclose(err, [3.0, 4.0])


def _fake_sequence(name: str, n_targets: int = 2) -> HomographySequence:
    return HomographySequence(name, "viewpoint" if name.startswith("v_") else "illumination", Path("1.ppm"),
                              [(Path(f"{k}.ppm"), H_TEST) for k in range(2, 2 + n_targets)])


def test_mma_known_by_construction():
    """Features built so that every MNN pair and its error are known: MMA is exact."""
    rng = np.random.default_rng(7)
    n = 200
    xy_a = rng.uniform(50, 400, (n, 2))
    desc = rng.normal(size=(n, 64)).astype(np.float32)
    # partner errors: a known distribution of offsets in random directions
    err = rng.uniform(0, 12, n)
    ang = rng.uniform(0, 2 * np.pi, n)
    xy_b = project(H_TEST, xy_a) + np.stack([err * np.cos(ang), err * np.sin(ang)], 1)
    fa = FeatureSet(xy_a, np.ones(n), desc, np.ones(n), np.zeros(n, int), (500, 500))
    order = rng.permutation(n)  # the target lists its points in another order
    fb = FeatureSet(xy_b[order], np.ones(n), desc[order] + 1e-3, np.ones(n), np.zeros(n, int), (500, 500))
    empty = FeatureSet(np.zeros((0, 2)), np.zeros(0), np.zeros((0, 64), np.float32), np.zeros(0),
                       np.zeros(0, int), (500, 500))

    def feats(seq, path):
        if path.name == "1.ppm":
            return fa
        return empty if seq.name == "i_empty" else fb

    seqs = [_fake_sequence("v_seq", 2), _fake_sequence("i_empty", 1)]
    res = evaluate_features(seqs, feats, label="x")
    s = res.summary()
    expected = np.array([np.mean(err <= t) for t in THRESHOLDS])
    np.testing.assert_allclose(s["mma"]["viewpoint"], expected)
    np.testing.assert_allclose(s["mma"]["illumination"], 0.0)  # empty match set scores 0
    np.testing.assert_allclose(s["mma"]["overall"], expected * 2 / 3)  # mean over the 3 pairs
    assert s["pairs"] == {"overall": 3, "illumination": 1, "viewpoint": 2}
    assert s["matches"] == pytest.approx((n + n + 0) / 3)
    # features: every image counts once per appearance (image 1, then each target)
    assert s["features"] == pytest.approx((n + n + n + n + 0) / 5)


# ------------------------------------------------------------------ homography accuracy
def test_auc_of_errors_hand_made():
    # sorted errors 0.5, 2, 4, inf: curve through (0,0) (0.5,.25) (2,.5) (4,.75), flat to t, area / t
    e = [4.0, float("inf"), 0.5, 2.0]
    np.testing.assert_allclose(auc_of_errors(e, (1, 3, 5)), [0.1875, 1.125 / 3, 2.625 / 5], rtol=1e-12)
    np.testing.assert_allclose(auc_of_errors([0.0, 0.0, 0.0]), [1.0, 1.0, 1.0])  # exact everywhere
    np.testing.assert_allclose(auc_of_errors([float("nan"), 6.0]), [0.0, 0.0, 0.0])  # NaN = failure
    assert auc_of_errors([]) == [0.0, 0.0, 0.0]


def test_corner_error_of_known_homographies():
    shift = np.array([[1.0, 0, 3], [0, 1, 4], [0, 0, 1]])
    assert corner_error(shift @ H_TEST, H_TEST, (400, 480)) == pytest.approx(5.0)
    # a scaling about the origin: the corners move by 0, 0.1*w, 0.1*|(w,h)|, 0.1*h (pixel centres)
    w, h = 480, 400
    scale = np.diag([1.1, 1.1, 1.0])
    expected = 0.1 * (0 + (w - 1) + np.hypot(w - 1, h - 1) + (h - 1)) / 4
    assert corner_error(scale, np.eye(3), (h, w)) == pytest.approx(expected)
    assert corner_error(None, H_TEST, (h, w)) == float("inf")


def test_estimate_homography_with_outliers_is_deterministic():
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 480, (300, 2))
    dst = project(H_TEST, src) + rng.normal(0, 0.3, (300, 2))
    dst[:150] = rng.uniform(0, 480, (150, 2))  # half of the matches are wrong
    h1, n1 = estimate_homography(src, dst)
    assert corner_error(h1, H_TEST, (400, 480)) < 0.5 and 140 <= n1 <= 170
    cv2.setRNGSeed(12345)  # USAC seeds itself: OpenCV's global RNG does not change the result
    h2, n2 = estimate_homography(src, dst)
    np.testing.assert_array_equal(h1, h2)
    assert n1 == n2
    assert estimate_homography(src[:3], dst[:3]) == (None, 0)
    with pytest.raises(ValueError):
        estimate_homography(src, dst[:10])


# ------------------------------------------------------------------ loaders
def _write_hpatches(root: Path, names, img: np.ndarray, h: np.ndarray) -> None:
    img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR) if img.ndim == 2 else img  # .ppm is colour
    for name in names:
        d = root / name
        d.mkdir(parents=True)
        cv2.imwrite(str(d / "1.ppm"), img)
        warped = cv2.warpPerspective(img, h, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR)
        for k in range(2, 7):
            cv2.imwrite(str(d / f"{k}.ppm"), warped)
            np.savetxt(d / f"H_1_{k}", h)


def test_hpatches_loader_drops_excluded(tmp_path):
    img = np.zeros((40, 50), np.uint8)
    _write_hpatches(tmp_path, ["i_dc", "v_talent", "i_ok", "v_ok"], img, np.eye(3))
    assert detect_layout(tmp_path) == "hpatches"
    seqs = load_sequences(tmp_path)
    assert [s.name for s in seqs] == ["i_ok", "v_ok"]
    assert [s.split for s in seqs] == ["illumination", "viewpoint"]
    assert all(len(s) == 5 for s in seqs)
    assert [p.name for p, _ in seqs[0].targets] == ["2.ppm", "3.ppm", "4.ppm", "5.ppm", "6.ppm"]
    assert len(load_sequences(tmp_path, exclude=None)) == 4
    # a sequence folder itself is a root too
    assert [s.name for s in load_sequences(tmp_path / "v_ok")] == ["v_ok"]


def test_oxford_loader(tmp_path):
    d = tmp_path / "graf"
    d.mkdir()
    for k in range(1, 4):
        cv2.imwrite(str(d / f"img{k}.ppm"), np.zeros((10, 10, 3), np.uint8))
    np.savetxt(d / "H1to2p", 2 * H_TEST)
    np.savetxt(d / "H1to3p", np.eye(3))
    assert detect_layout(tmp_path) == "oxford"
    (s,) = load_sequences(tmp_path, "oxford")
    assert s.split == "viewpoint" and len(s) == 2
    np.testing.assert_allclose(s.targets[0][1], H_TEST)  # normalised to H[2, 2] = 1


def test_homogr_conversion_to_zero_based():
    rng = np.random.default_rng(3)
    h1 = np.array([[1.1, 0.2, -30.0], [-0.1, 0.9, 15.0], [2e-4, 1e-4, 1.0]])  # B -> A, 1-based
    h_ab = homogr_to_zero_based(h1)
    pa0 = rng.uniform(0, 500, (20, 2))
    pb0 = project(h_ab, pa0)
    # back in MATLAB coordinates, the model maps B's points onto A's
    np.testing.assert_allclose(project(h1, pb0 + 1.0) - 1.0, pa0, atol=1e-8)


def test_homogr_real_data_against_annotations(data_dir):
    sio = pytest.importorskip("scipy.io")
    root = data_dir / "homography" / "homogr"
    if not root.is_dir():
        pytest.skip("HOMOGR data not available")
    seqs = load_sequences(root, "homogr")
    assert len(seqs) >= 1
    for s in seqs:
        m = sio.loadmat(str(root / s.name / f"{s.name}_vpts.mat"), squeeze_me=True, struct_as_record=False)
        pts = np.asarray(m["validation"].pts, dtype=float)
        a = (pts[:2] / pts[2]).T - 1.0  # annotated A points, 0-based
        b = (pts[3:5] / pts[5]).T - 1.0
        np.testing.assert_allclose(project(s.targets[0][1], a), b, atol=1e-6)


# ------------------------------------------------------------------ pipeline
def test_pipeline_border_and_top_k():
    c = Corners(np.array([[5.0, 50], [50, 50], [89, 50], [90, 50], [50, 96]]),
                np.array([1.0, 3.0, 2.0, 5.0, 4.0]))
    # 10 px from the last pixel (99) is 89: kept; 90 is 9 px from it: removed
    kept = select(c, (100, 100), remove_border=10, top_k=None)
    assert kept.xy.tolist() == [[50.0, 50.0], [89.0, 50.0]]
    assert select(c, (100, 100), 0, 2).response.tolist() == [5.0, 4.0]
    spec = parse_spec("sogdd:levels=5:remove_border=75:top_k=2000:desc=rootsift")
    assert spec.params == {"levels": 5}
    assert (spec.remove_border, spec.top_k, spec.desc) == (75, 2000, "rootsift")
    with pytest.raises(ValueError):
        parse_spec("sogdd:desc=sosnet")


def test_descriptor_sizes_follow_pyramid_level():
    c = Corners(np.zeros((3, 2)), size=np.array([17.0, 34.0, 68.0]), level=np.array([0, 1, 2]))
    np.testing.assert_allclose(descriptor_sizes(c, "auto"), [8.0, 16.0, 32.0])
    np.testing.assert_allclose(descriptor_sizes(c, 5), [5.0, 10.0, 20.0])
    np.testing.assert_allclose(descriptor_sizes(c, "auto", family="blob"), c.size)


@pytest.fixture(scope="module")
def synthetic_root(tmp_path_factory):
    """One viewpoint sequence: a rendered pattern and its warps by H_TEST.

    A smooth random texture is added so that corner neighbourhoods differ; the
    bare pattern's polygons repeat and their corners are ambiguous to any descriptor.
    """
    root = tmp_path_factory.mktemp("hp")
    img, _ = _pattern((400, 480), seed=11)
    tex = cv2.GaussianBlur(np.random.default_rng(0).normal(0, 1, img.shape), (0, 0), 6)
    img = np.clip(img + 25 * tex / tex.std(), 0, 255).astype(np.uint8)
    _write_hpatches(root, ["v_synth"], img, H_TEST)
    return root


def test_synthetic_pair_end_to_end(synthetic_root, tmp_path):
    seqs = load_sequences(synthetic_root)
    specs = [parse_spec("sogdd")]
    res = evaluate_specs(seqs, specs, feature_dir=tmp_path)["sogdd"].summary()
    curve = res["mma"]["viewpoint"]
    assert res["matches"] >= 10
    assert curve[0] > 0.8  # corners of a warped rendering: most MNN matches within 1 px
    assert all(x <= y + 1e-12 for x, y in zip(curve, curve[1:]))  # monotone in t
    # D2-Net's npz layout, named <image>.<method>
    z = np.load(tmp_path / "v_synth" / "1.ppm.sogdd")
    assert z["keypoints"].shape[1] == 2 and len(z["scores"]) == len(z["descriptors"])
    # the homography from the matches of a rendered, warped pair is near-exact
    hom = res["homography"]
    assert hom["failed"] == 0 and hom["median_corner_error"] < 0.2
    assert min(hom["auc"]["viewpoint"]) > 0.85 and hom["auc"]["illumination"] is None
    assert len(hom["corner_errors"]) == 5
    # the wrong homography gives (almost) nothing, for MMA and for the corner error
    wrong = [HomographySequence(s.name, s.split, s.reference, [(p, np.eye(3)) for p, _ in s.targets])
             for s in seqs]
    bad = evaluate_specs(wrong, specs)["sogdd"].summary()
    assert bad["mma"]["viewpoint"][2] < 0.2
    assert bad["homography"]["auc"]["viewpoint"] == [0.0, 0.0, 0.0]
    assert bad["homography"]["median_corner_error"] > 20


def test_cli_matching_json(synthetic_root, tmp_path, capsys):
    rc = main(["eval", "matching", "--root", str(synthetic_root), "--detectors", "sogdd,sift",
               "--out", str(tmp_path), "--json", "--quiet"])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    assert set(obj) == {"sogdd", "sift"}
    for v in obj.values():
        assert len(v["mma"]["overall"]) == 10 and v["mma"]["illumination"] is None
        assert v["features"] > 0 and v["matches"] > 0
        assert len(v["homography"]["auc"]["overall"]) == 3 and v["homography"]["failed"] == 0
    assert (tmp_path / "mma.png").stat().st_size > 0
    md = (tmp_path / "matching.md").read_text()
    assert "| H AUC@1 | H AUC@3 | H AUC@5 |" in md
    auc1 = obj["sogdd"]["homography"]["auc"]["overall"][0]
    assert f"| {auc1:.3f} |" in next(ln for ln in md.splitlines() if ln.startswith("| `sogdd` |"))
    assert json.loads((tmp_path / "matching.json").read_text()).keys() == obj.keys()


def test_published_reference_loads(data_dir):
    path = data_dir.parent / "reference" / "hpatches_published_mma.csv"
    if not path.is_file():
        pytest.skip("published reference curves not available")
    pub = load_published(path)
    assert "d2-net" in pub and len(pub["d2-net"]["overall"]["mma"]) == 10
