"""A CSV feature file and its sidecar: bound by the CSV's SHA-256, and a header even without rows.

The sidecar ``<file>.json`` holds the provenance of the CSV whose bytes have
the SHA-256 it names; a sidecar beside other bytes (the CSV edited, replaced,
or a run interrupted between the two renames) must not lend them its
provenance, even though it has a hash. And a CSV always starts with its header
line, also when no image has a corner, so that any CSV reader takes it.
These tests need no pandas; the one that shows pandas' view skips without it.
"""

import csv
import hashlib
import io
import json

import numpy as np
import pytest

from sogdd.cli.main import main
from sogdd.corners import Corners
from sogdd.formats.features import FeatureRecord, read_features, sidecar_path, write_features

PARAMS = {"preset": "paper", "window": 7}


def _rec(name: str, n: int, seed: int = 0) -> FeatureRecord:
    rng = np.random.default_rng(seed)
    c = Corners(rng.uniform(0, 50, (n, 2)), rng.uniform(1e9, 2e9, n))
    return FeatureRecord(name, c, (60, 80), PARAMS, "9.9", 123, 456, "ab" * 32)


def _write(path, recs):
    write_features(path, recs, "csv")
    return path.read_bytes()


def test_the_sidecar_names_the_sha256_of_its_csv(tmp_path):
    data = _write(tmp_path / "a.csv", [_rec("a.png", 5)])
    side = json.loads(sidecar_path(tmp_path / "a.csv").read_text())
    assert side["csv_sha256"] == hashlib.sha256(data).hexdigest()
    (r,) = read_features(tmp_path / "a.csv")
    assert r.params == PARAMS and r.sogdd_version == "9.9" and r.source_sha256 == "ab" * 32


@pytest.mark.parametrize("edit", ["a row changed", "a row dropped", "another csv", "a byte appended"])
def test_a_sidecar_beside_other_bytes_lends_no_provenance(tmp_path, edit):
    f = tmp_path / "a.csv"
    data = _write(f, [_rec("a.png", 5)])
    lines = data.decode().splitlines(keepends=True)
    if edit == "a row changed":
        lines[1] = lines[1].replace(lines[1].split(",")[0], "1.0000", 1)
        new = "".join(lines).encode()
    elif edit == "a row dropped":
        new = "".join(lines[:-1]).encode()
    elif edit == "another csv":  # another run's CSV moved here, this sidecar left beside it
        other = tmp_path / "b.csv"
        new = _write(other, [_rec("a.png", 3, seed=1)])
    else:
        new = data + b"\n"
    assert new != data
    f.write_bytes(new)
    (r,) = read_features(f)
    assert r.params is None and r.sogdd_version is None and r.source_sha256 is None
    assert len(r.corners) == len(list(csv.DictReader(io.StringIO(new.decode()))))  # the rows as they are


def test_without_a_hash_the_sidecar_lends_nothing_either(tmp_path):
    f = tmp_path / "a.csv"
    _write(f, [_rec("a.png", 2)])
    side = sidecar_path(f)
    obj = json.loads(side.read_text())
    obj["csv_sha256"] = "0" * 64
    side.write_text(json.dumps(obj))
    assert read_features(f)[0].params is None


@pytest.mark.parametrize("names", [["a.png"], ["a.png", "b.png"]])
def test_a_csv_without_corners_has_its_header(tmp_path, names):
    f = tmp_path / "none.csv"
    data = _write(f, [_rec(n, 0) for n in names])
    header = data.decode().splitlines()[0]
    assert header == ("image," if len(names) > 1 else "") + "x,y,response,size"
    assert csv.DictReader(io.StringIO(data.decode())).fieldnames == header.split(",")
    recs = read_features(f)
    assert [r.image for r in recs] == names and all(len(r.corners) == 0 for r in recs)
    assert all(r.params == PARAMS for r in recs)  # the sidecar still binds the header-only CSV


def test_detect_writes_a_header_for_flat_images(tmp_path, capsys):
    import cv2

    for n in ("f1.png", "f2.png"):
        cv2.imwrite(str(tmp_path / n), np.full((40, 50), 90, np.uint8))
    assert main(["detect", str(tmp_path / "f1.png")]) == 0
    assert capsys.readouterr().out == "x,y,response,size\n"
    out = tmp_path / "all.csv"
    assert main(["detect", str(tmp_path / "f1.png"), str(tmp_path / "f2.png"), "-o", str(out)]) == 0
    assert out.read_text() == "image,x,y,response,size\n"


def test_pandas_reads_a_csv_without_corners(tmp_path):
    pd = pytest.importorskip("pandas")
    f = tmp_path / "none.csv"
    _write(f, [_rec("a.png", 0), _rec("b.png", 0)])
    df = pd.read_csv(f)
    assert list(df.columns) == ["image", "x", "y", "response", "size"] and len(df) == 0
