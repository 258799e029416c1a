import json

import cv2
import numpy as np
import pytest

import sogdd
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
    assert out[0] == "x,y,response,size"  # stdout: the header, then the rows, nothing else
    rows = np.array([[float(v) for v in ln.split(",")] for ln in out[1:]])
    assert len(rows) >= 0.9 * len(gt) and np.all(rows[:, 2] > 1e9)
    assert main(["detect", f, "--format", "json", "--max-corners", "5"]) == 0
    (obj,) = json.loads(capsys.readouterr().out)  # always a list, one object per image
    assert obj["n"] == 5 and len(obj["x"]) == 5
    npz = tmp_path / "c.npz"
    assert main(["detect", f, "--format", "npz", "-o", str(npz), "--overlay",
                 str(tmp_path / "o.png")]) == 0
    assert sogdd.load_features(npz).xy.shape == (len(rows), 2)
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
    assert images == {"g1.png", "g2.png"}  # relative to the inputs' common folder
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


@pytest.mark.parametrize("name", ["notes.md", "missing/demo.png"])
def test_demo_refuses_an_overlay_it_cannot_write_before_any_work(tmp_path, capsys, name):
    """Not an image name, or a missing folder: one line naming --out, and nothing written."""
    (tmp_path / "notes.md").write_text("keep")
    assert main(["demo", "--out", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sogdd: error: --out ") and err.count("\n") == 1 and "Traceback" not in err
    assert (tmp_path / "notes.md").read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.md"]


def test_demo(tmp_path, capsys):
    import re

    out = tmp_path / "demo.png"
    assert main(["demo", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    # the printed figures are a working detector's: 187 of 188 corners, recall 0.995, RMS 0.19 px
    # (integer peaks would give an RMS of ~1.5 px, a broken threshold a count far from 188)
    found = int(re.search(r"(\d+) corners detected", text).group(1))
    true = int(re.search(r"(\d+) true corners", text).group(1))
    recall = float(re.search(r"recall within 2 px: ([\d.]+)", text).group(1))
    rms = float(re.search(r"\(RMS\): ([\d.]+) px", text).group(1))
    assert true == 188 and 180 <= found <= 196
    assert recall >= 0.98 and 0.05 < rms < 0.3
    overlay = cv2.imread(str(out))
    assert overlay is not None and overlay.shape[:2] == (480, 640)


def test_version_and_python_m(capsys):
    import subprocess
    import sys

    import sogdd

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"sogdd {sogdd.__version__}"
    r = subprocess.run([sys.executable, "-m", "sogdd", "--version"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == f"sogdd {sogdd.__version__}"


def test_help_imports_no_command_module():
    import subprocess
    import sys

    code = ("import sys, contextlib, io\nfrom sogdd.cli.main import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
            "    try:\n        main(['--help'])\n    except SystemExit:\n        pass\n"
            "assert 'COMMAND' in out.getvalue() and 'report' in out.getvalue()\n"
            "print(sorted(m for m in sys.modules if m.startswith(('sogdd.cli.', 'sogdd.evaluation', "
            "'sogdd.report', 'matplotlib'))))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "['sogdd.cli._common', 'sogdd.cli.main']"


def test_help_shows_defaults_without_markup(capsys):
    for argv, want in ((["eval", "gt", "--help"], "match radius in px [default: 2.0]"),
                       (["eval", "repeatability", "--help"], "[default: $SOGDD_DATA/repeatability]"),
                       (["demo", "--help"], "overlay PNG [default: sogdd_demo.png]"),
                       (["colmap", "export", "--help"], "[default: auto]")):
        with pytest.raises(SystemExit):
            main(argv)
        text = " ".join(capsys.readouterr().out.split())
        assert want in text, argv
        assert "``" not in text and ":mod:" not in text and ":func:" not in text


def test_eval_without_subcommand_and_unknown_command(capsys):
    assert main(["eval"]) == 2
    assert "EVALUATION" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["nope"])
    assert e.value.code == 2
