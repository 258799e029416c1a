"""End-to-end runs of the ``sogdd eval`` commands and the GT data format."""

import csv
import json

import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.evaluation.gt import find_gt_sets, read_corners_csv, write_corners_csv
from sogdd.evaluation.resolution import Config, render_configuration, score_configuration
from sogdd.evaluation.specs import DetectorSpec, parse_spec, permissive_detections
from sogdd.synthetic import pattern_image as make_pattern


@pytest.fixture
def gt_root(tmp_path):
    import cv2

    for i, seed in enumerate((1, 2)):
        img, corners = make_pattern((160, 240), seed=seed)
        d = tmp_path / f"set{i}"
        d.mkdir()
        cv2.imwrite(str(d / "image.png"), img)
        write_corners_csv(d / "corners.csv", corners, "synthetic\nx,y 0-based")
    return tmp_path


def test_corners_csv_roundtrip(tmp_path, rng):
    xy = rng.uniform(0, 100, (7, 2))
    write_corners_csv(tmp_path / "c.csv", xy, "a comment")
    assert np.allclose(read_corners_csv(tmp_path / "c.csv"), xy, atol=1e-4)
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError):
        read_corners_csv(tmp_path / "bad.csv")


def test_parse_spec():
    s = parse_spec("sogdd:subpixel=false:sigma2=2")
    assert s.name == "sogdd" and s.params == {"subpixel": False, "sigma2": 2}
    assert s.label == "sogdd:subpixel=false:sigma2=2"
    with pytest.raises(ValueError):
        parse_spec("sogdd:subpixel")


def test_permissive_run_contains_default(pattern):
    img, _ = pattern
    default, perm, over = permissive_detections(DetectorSpec("sogdd"), img)
    assert over is not None and len(perm) > len(default)
    # the paper preset thresholds after NMS: its output is the top of the permissive run
    top = perm.xy[: len(default)]
    assert np.allclose(np.sort(top, axis=0), np.sort(default.xy, axis=0))


def test_eval_gt_json(gt_root, capsys):
    assert len(find_gt_sets(gt_root)) == 2
    rc = main(["eval", "gt", "--data", str(gt_root), "--detectors", "sogdd,sogdd:subpixel=false",
               "--json", "--no-progress", "--out", str(gt_root / "out")])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    for d in ("sogdd", "sogdd:subpixel=false"):
        m = obj["detectors"][d]
        # the counts add up over the 2 x 25 GT corners, and the rates are those of the counts
        assert m["n_gt"] == 50 and m["matched"] + m["missed"] == 50 and m["matched"] + m["false"] == m["n_det"]
        assert m["recall"] == pytest.approx(m["matched"] / 50)
        assert m["precision"] == pytest.approx(m["matched"] / m["n_det"])
        assert m["f1"] == pytest.approx(2 * m["matched"] / (50 + m["n_det"]))
        assert 0 < m["le"] <= 2.0 and m["threshold"] > 0  # matched within delta = 2 px
        # rendered polygons with exact vertices: SOGDD finds nearly all of them
        assert m["recall"] > 0.8
        assert m["tuned"]["missed"] + m["tuned"]["false"] <= m["missed"] + m["false"]
    # sub-pixel refinement: every vertex, 0.19 px RMS; integer peaks ~1.5 px inside the corners
    assert obj["detectors"]["sogdd"]["recall"] == 1.0 and obj["detectors"]["sogdd"]["le"] < 0.3
    assert obj["detectors"]["sogdd:subpixel=false"]["le"] > 1.0
    assert (gt_root / "out" / "gt.csv").exists() and (gt_root / "out" / "overlays").is_dir()


def test_eval_gt_errors(tmp_path, capsys):
    assert main(["eval", "gt", "--data", str(tmp_path)]) == 2
    assert main(["eval", "gt", "--data", str(tmp_path), "--detectors", "nope"]) == 2


def test_eval_repeatability_quick(tmp_path, capsys):
    import cv2

    for seed in (1, 2):
        img, _ = make_pattern((120, 160), seed=seed, noise=2.0)
        cv2.imwrite(str(tmp_path / f"im{seed}.png"), img)
    rc = main(["eval", "repeatability", "--images", str(tmp_path), "--quick", "--jobs", "1",
               "--families", "rotation,noise", "--detectors", "sogdd", "--json",
               "--no-progress", "--out", str(tmp_path / "out")])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    fam = obj["detectors"]["sogdd"]
    assert set(fam) == {"rotation", "noise", "overall"}
    assert 0.3 < fam["rotation"] <= 1 and 0.3 < fam["noise"] <= 1
    assert (tmp_path / "out" / "repeatability.csv").exists()
    # the per-pair records agree with eq. 27 and with the JSON averages
    with open(tmp_path / "out" / "repeatability_records.csv", newline="") as fh:
        recs = list(csv.DictReader(fh))
    assert len(recs) == 2 * (5 + 4)  # 2 images x (5 rotations + 4 noise levels) in the quick grid
    for r in recs:
        lb, ld, lr = int(r["lb"]), int(r["ld"]), int(r["lr"])
        assert lr <= min(lb, ld)
        assert float(r["r"]) == pytest.approx(0.5 * lr * (1 / lb + 1 / ld), abs=1e-6)
    for f in ("rotation", "noise"):
        assert fam[f] == pytest.approx(np.mean([float(r["r"]) for r in recs if r["family"] == f]), abs=1e-5)
    assert fam["overall"] == pytest.approx((fam["rotation"] + fam["noise"]) / 2)
    by = {(r["image"], r["family"], r["param"]): r for r in recs}
    for im in ("im1.png", "im2.png"):
        # a quarter turn maps pixel centres onto pixel centres and K = 8 orientations onto
        # themselves: every corner comes back, and nothing else
        q = by[(im, "rotation", "90")]
        assert int(q["lb"]) == int(q["ld"]) == int(q["lr"]) > 0
        # more noise, more false corners: repeatability falls
        assert float(by[(im, "noise", "15")]["r"]) < float(by[(im, "noise", "2")]["r"])


def test_eval_resolution_quick(tmp_path, capsys):
    rc = main(["eval", "resolution", "--quick", "--detectors", "sogdd", "--json",
               "--no-progress", "--out", str(tmp_path)])
    assert rc == 0
    obj = json.loads(capsys.readouterr().out)
    rate = obj["detectors"]["sogdd"]["rate"]
    assert set(rate) == {"2", "3", "4", "6", "8", "12"}
    # corners d px apart: resolved more often the farther apart (0, 0, 0.125, 0.375, 0.375, 0.5 today)
    r = [rate[k] for k in ("2", "3", "4", "6", "8", "12")]
    assert r == sorted(r) and r[0] <= 0.125 and r[-1] >= 0.5
    # 8 configurations per d in the quick grid (2 kinds x 2 noise levels x 2 poses)
    assert all(v * 8 == pytest.approx(round(v * 8)) for v in rate.values())
    assert obj["detectors"]["sogdd"]["mean_rate"] == pytest.approx(np.mean(list(rate.values())))
    row = (tmp_path / "resolution.csv").read_text().splitlines()[1].split(",")
    assert row[0] == "sogdd" and [float(v) for v in row[1:7]] == pytest.approx(list(rate.values()), abs=1e-3)

    assert main(["eval", "resolution", "--quick", "--detectors", "sogdd", "--mode", "oracle", "--json",
                 "--quiet"]) == 0
    oracle = json.loads(capsys.readouterr().out)["detectors"]["sogdd"]
    # at the best threshold per configuration, a clean pair 12 px apart is always resolved,
    # and no threshold does worse than the default one on average
    assert oracle["rate"]["12"] == 1.0
    assert oracle["mean_rate"] >= obj["detectors"]["sogdd"]["mean_rate"]


def test_resolution_scoring():
    cfg = Config("END", 8.0, 0.3, 0.5, 0.0, 0.7, (0.1, -0.2), 0)
    img, corners = render_configuration(cfg)
    assert img.dtype == np.uint8 and np.hypot(*(corners[1] - corners[0])) == pytest.approx(8)
    assert score_configuration(corners, corners + 0.5, 1.5)[0]
    mid = corners.mean(axis=0, keepdims=True)
    assert not score_configuration(corners, np.concatenate([corners, mid]), 1.5)[0]
    assert not score_configuration(corners, corners[:1], 1.5)[0]
    assert not score_configuration(corners, corners + 2.0, 1.5)[0]


def test_gt_on_shared_data(data_dir, capsys):
    d = data_dir / "corners_gt" / "shape_a"
    if not d.is_dir():
        pytest.skip("corners_gt/shape_a not in the shared data")
    assert main(["eval", "gt", "--data", str(d), "--detectors", "sogdd", "--json",
                 "--no-progress"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["n_gt"]["shape_a"] == len(read_corners_csv(d / "corners.csv"))
