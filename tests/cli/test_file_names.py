"""A file name that is not valid UTF-8 fails that image alone, named with its bad bytes escaped; every
other image of the batch is written."""

import os
import sys

import cv2
import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.collection import run_batch
from sogdd.formats.features import read_features
from sogdd.synthetic import pattern_image

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="file names as bytes: Linux")


@pytest.fixture
def folder(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    img = pattern_image((120, 160), seed=2)[0]
    ok, png = cv2.imencode(".png", img)
    for name in (b"a.png", b"caf\xe9.png", b"z.png"):
        with open(os.path.join(os.fsencode(src), name), "wb") as f:
            f.write(png.tobytes())
    return src


def _errors(err: str) -> list[str]:
    assert "Traceback" not in err
    return [ln for ln in err.splitlines() if "sogdd: error:" in ln]


@pytest.mark.parametrize("fmt", ["csv", "npz", "json"])
def test_a_non_utf8_name_loses_only_its_own_image(folder, tmp_path, capsys, fmt):
    out = tmp_path / f"all.{fmt}"
    assert main(["detect", str(folder), "-o", str(out)]) == 2
    errors = _errors(capsys.readouterr().err)
    assert len(errors) == 1 and "caf\\xe9.png" in errors[0] and "not valid UTF-8" in errors[0]
    assert [r.image for r in read_features(out)] == ["a.png", "z.png"]
    assert all(len(r.corners) > 5 for r in read_features(out))


def test_the_same_in_one_file_per_image(folder, tmp_path):
    items = run_batch(sorted(folder.iterdir()), tmp_path / "feats")
    assert [i.status for i in items] == ["done", "failed", "done"]
    assert "caf\\xe9.png" in items[1].message and "not valid UTF-8" in items[1].message
    assert sorted(p.name for p in (tmp_path / "feats").iterdir()) == ["a.png.npz", "z.png.npz"]


def test_the_error_leaves_the_progress_bar_line(tmp_path, capsys):
    """A per-image error is written above the bar (tqdm.write), never appended to the bar's line."""
    img = pattern_image((120, 160), seed=2)[0]
    good = [tmp_path / n for n in ("a.png", "c.png")]
    for p in good:
        cv2.imwrite(str(p), img)
    (tmp_path / "b.png").write_bytes(b"not an image")
    assert main(["detect", str(tmp_path), "-o", str(tmp_path / "all.json")]) == 2
    err = capsys.readouterr().err
    (line,) = _errors(err)
    before = err[: err.index("sogdd: error:")]
    assert before == "" or before[-1] in "\r\n"  # the message starts a line of its own
    assert "%|" not in line
    assert np.all([len(r.corners) > 5 for r in read_features(tmp_path / "all.json")])
