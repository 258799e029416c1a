import json

import cv2
import numpy as np

from sogdd.cli.main import main
from sogdd.synthetic import pattern_image as make_pattern


def _write(path, img):
    assert cv2.imwrite(str(path), img)
    return str(path)


def test_detect_csv_json_npz_overlay(tmp_path, capsys):
    img, gt = make_pattern((120, 160), seed=2)
    f = _write(tmp_path / "a.png", img)
    assert main(["detect", f]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "x,y,response,size"
    rows = np.array([[float(v) for v in ln.split(",")] for ln in out[1:]])
    assert len(rows) >= 0.9 * len(gt) and np.all(rows[:, 2] > 1e9)
    assert main(["detect", f, "--format", "json", "--max-corners", "5"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["n"] == 5 and len(obj["x"]) == 5
    npz = tmp_path / "c.npz"
    assert main(["detect", f, "--format", "npz", "-o", str(npz), "--overlay",
                 str(tmp_path / "o.png")]) == 0
    assert np.load(npz)["corners"].shape[1] == 4
    assert cv2.imread(str(tmp_path / "o.png")) is not None


def test_detect_batch_with_one_bad_file(tmp_path, capsys):
    img, _ = make_pattern((100, 120), seed=4)
    good1 = _write(tmp_path / "g1.png", img)
    good2 = _write(tmp_path / "g2.png", np.rot90(img).copy())
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"nope")
    code = main(["detect", good1, str(bad), good2, "-o", str(tmp_path / "all.csv")])
    assert code == 2
    lines = (tmp_path / "all.csv").read_text().splitlines()
    assert lines[0] == "image,x,y,response,size"
    images = {ln.split(",")[0] for ln in lines[1:]}
    assert images == {good1, good2}
    assert "bad.png" in capsys.readouterr().err


def test_detect_folder_json(tmp_path, capsys):
    img, _ = make_pattern((100, 120), seed=5)
    _write(tmp_path / "x.png", img)
    _write(tmp_path / "y.png", img)
    assert main(["detect", str(tmp_path), "--format", "json", "--preset", "authors"]) == 0
    objs = json.loads(capsys.readouterr().out)
    assert [o["image"].endswith(n) for o, n in zip(objs, ["x.png", "y.png"])] == [True, True]


def test_response_command(tmp_path):
    img, _ = make_pattern((80, 90), seed=6)
    f = _write(tmp_path / "a.png", img)
    out = tmp_path / "r.npy"
    assert main(["response", f, "--output", str(out), "--sigma2", "1.5"]) == 0
    r = np.load(out)
    assert r.shape == img.shape and r.dtype == np.float64


def test_demo(tmp_path, capsys):
    out = tmp_path / "demo.png"
    assert main(["demo", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "recall" in text and cv2.imread(str(out)) is not None
