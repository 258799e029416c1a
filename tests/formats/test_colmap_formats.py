"""``sogdd colmap export`` reads every format ``sogdd detect --out`` writes: npz, CSV and JSON.

The same detections give the same keypoints whatever the format; a CSV's
sidecar is not a feature file; one image in two formats is refused; a file
named ``.npz`` that is not one is said to be so.
"""

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.synthetic import pattern_image

pycolmap = pytest.importorskip("pycolmap")


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    d = tmp_path_factory.mktemp("img")
    for i in range(2):
        cv2.imwrite(str(d / f"im{i}.png"), pattern_image((120, 160), seed=i)[0])
    return d


def _keypoints(db) -> dict[str, np.ndarray]:
    with pycolmap.Database.open(str(db)) as d:
        return {im.name: np.asarray(d.read_keypoints(im.image_id)) for im in d.read_all_images()}


def _one_error(capfd) -> str:
    err = capfd.readouterr().err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("sogdd: error: ") and "Traceback" not in err, err
    return lines[0]


def test_every_detect_format_exports_the_same_keypoints(images, tmp_path, capfd):
    got = {}
    for fmt in ("npz", "csv", "json"):
        feat = tmp_path / fmt
        assert main(["detect", str(images), "--out", str(feat), "--format", fmt]) == 0
        db = tmp_path / f"{fmt}.db"
        assert main(["colmap", "export", str(feat), "--database", str(db), "--images", str(images),
                     "--describe", "none", "--quiet"]) == 0
        got[fmt] = _keypoints(db)
    capfd.readouterr()
    assert sorted(got["npz"]) == ["im0.png", "im1.png"] and all(len(k) > 5 for k in got["npz"].values())
    for fmt in ("csv", "json"):  # CSV and JSON keep 4 decimals of x and y
        assert sorted(got[fmt]) == sorted(got["npz"])
        for name, kp in got["npz"].items():
            np.testing.assert_allclose(got[fmt][name], kp, atol=1e-4)


def test_one_image_in_two_formats_is_refused(images, tmp_path, capfd):
    feat = tmp_path / "feat"
    assert main(["detect", str(images / "im0.png"), "--out", str(feat), "--format", "npz"]) == 0
    assert main(["detect", str(images / "im0.png"), "--out", str(feat), "--format", "csv"]) == 0
    capfd.readouterr()
    assert main(["colmap", "export", str(feat), "--database", str(tmp_path / "x.db"), "--images",
                 str(images), "--quiet"]) == 2
    line = _one_error(capfd)
    assert "im0.png.npz" in line and "im0.png.csv" in line and not (tmp_path / "x.db").exists()


def test_a_text_file_named_npz_is_said_not_to_be_one(images, tmp_path, capfd):
    feat = tmp_path / "feat"
    feat.mkdir()
    (feat / "junk.npz").write_text("hello\n")
    assert main(["colmap", "export", str(feat), "--database", str(tmp_path / "x.db"), "--quiet"]) == 2
    line = _one_error(capfd)
    assert "junk.npz: not an npz file" in line and "pickle" not in line


def test_an_empty_folder_names_the_formats(tmp_path, capfd):
    (tmp_path / "feat").mkdir()
    (tmp_path / "feat" / "notes.txt").write_text("x")
    assert main(["colmap", "export", str(tmp_path / "feat"), "--database", str(tmp_path / "x.db")]) == 2
    assert ".npz, .csv or .json" in _one_error(capfd)


def test_colmap_help_does_not_repeat_the_export_text(capsys):
    with pytest.raises(SystemExit):
        main(["colmap", "--help"])
    out = capsys.readouterr().out
    assert "export" in out and "FEATDIR holds" not in out


def test_a_database_that_is_an_input_is_refused(images, tmp_path, capfd):
    import os

    feat = tmp_path / "feat"
    assert main(["detect", str(images / "im0.png"), "--out", str(feat), "--format", "csv"]) == 0
    os.symlink(images / "im0.png", tmp_path / "link.db")
    capfd.readouterr()
    for db in (feat / "im0.png.csv", tmp_path / "link.db"):
        before = db.read_bytes()
        assert main(["colmap", "export", str(feat), "--database", str(db), "--images", str(images),
                     "--quiet"]) == 2
        assert "that is the input" in _one_error(capfd) and db.read_bytes() == before
