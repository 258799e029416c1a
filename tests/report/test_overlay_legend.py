"""The overlay's legend never hides a detection: it takes the emptiest corner, and points it
still covers are drawn over it."""

import numpy as np

from sogdd.report.overlays import detections_overlay


def _red(vis: np.ndarray) -> np.ndarray:
    b, g, r = (vis[..., i].astype(int) for i in range(3))
    return (r > 150) & (g < 110) & (b < 110)


def _dark(vis: np.ndarray, y: int, x: int) -> bool:
    return bool(vis[y, x].max() < 100)


def _red_at(vis, x, y, reach=2) -> bool:
    return bool(_red(vis[y - reach: y + reach + 1, x - reach: x + reach + 1]).any())


def test_detections_in_the_top_left_move_the_legend_elsewhere():
    img = np.full((480, 640), 200, np.uint8)
    xy = np.array([[10.0, 10.0], [40.0, 12.0], [25.0, 30.0], [60.0, 20.0]])
    vis = detections_overlay(img, xy, label="paper")
    assert all(_red_at(vis, int(x), int(y)) for x, y in xy)
    assert not _dark(vis, 5, 5)  # the top-left corner shows the picture
    assert _dark(vis, 5, 634)  # the legend went to the next corner (top-right)


def test_with_every_corner_full_the_covered_points_stay_visible():
    img = np.full((480, 640), 200, np.uint8)
    ys, xs = np.mgrid[5:480:20, 5:640:20]
    xy = np.column_stack([xs.ravel(), ys.ravel()]).astype(float)
    vis = detections_overlay(img, xy, gt=xy[::7])
    assert all(_red_at(vis, int(x), int(y)) for x, y in xy)
    assert _dark(vis, 2, 2) or _dark(vis, 2, 637) or _dark(vis, 477, 2) or _dark(vis, 477, 637)  # a legend


def test_without_points_in_it_the_legend_stays_top_left():
    img = np.full((480, 640), 200, np.uint8)
    vis = detections_overlay(img, np.array([[320.0, 240.0]]))
    assert _dark(vis, 5, 5) and not _dark(vis, 5, 634)
