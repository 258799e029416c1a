import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from sogdd.measure import soddc
from sogdd.synthetic import pattern_image as _pattern


def shared_data() -> Path | None:
    """The shared benchmark data folder, from SOGDD_DATA or ../shared/data."""
    env = os.environ.get("SOGDD_DATA")
    cands = [Path(env)] if env else []
    here = Path(__file__).resolve().parents[1]
    cands += [here.parent / "shared" / "data", Path.cwd().parent / "shared" / "data"]
    for c in cands:
        if c.is_dir():
            return c
    return None


@pytest.fixture(scope="session")
def data_dir() -> Path:
    d = shared_data()
    if d is None:
        pytest.skip("shared benchmark data not available (set SOGDD_DATA)")
    return d


@pytest.fixture(scope="session")
def pattern():
    return _pattern((240, 320), seed=1)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True)
def _prune_small_maps(monkeypatch):
    """Small test images take the pruned path that photos take (``soddc.PRUNE_MIN_PIXELS``).

    Pruning never changes a result, so without this the tests of the bound's exactness on small
    images would compare the full map with itself. ``tests/measure/test_bound.py`` checks the real
    pixel rule.
    """
    monkeypatch.setattr(soddc, "PRUNE_MIN_PIXELS", 0)


def pytest_configure(config):
    config.addinivalue_line("markers", "learned: needs the 'learned' extra; skipped with the reason without it")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``learned`` skip, saying what is missing and how to install it, where the extra is not."""
    from sogdd.baselines import learned_extra

    if learned_extra.installed():
        return
    skip = pytest.mark.skip(reason=f"the 'learned' extra is not installed (missing: "
                                   f"{', '.join(learned_extra.missing())}); install: {learned_extra.INSTALL}")
    for item in items:
        if item.get_closest_marker("learned") is not None:
            item.add_marker(skip)


#: the rendered frames' camera (fx = fy = 560 at 640 x 480)
RENDER_K = np.array([[560.0, 0, 322.0], [0, 560.0, 236.0], [0, 0, 1]])
RENDER_DIST = (-0.2, 0.06, 0.001, -0.0005, 0.0)


@pytest.fixture(scope="session")
def rendered_frames(tmp_path_factory):
    """Eight rendered 640 x 480 views of a 9 x 6 board (blur 0.8 px, noise 2 grey levels), f0.png ... f7.png.

    Read only: a test that changes the set copies it.
    """
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    cam = render.Camera(RENDER_K, RENDER_DIST, (640, 480))
    target = render.ChessboardTarget(9, 6, 1.0)
    folder = tmp_path_factory.mktemp("frames")
    for k, (rv, tv) in enumerate(render.random_sequence(cam, target, 8, seed=3)):
        view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
        assert cv2.imwrite(str(folder / f"f{k}.png"), view.image)
    return folder
