"""The fill's label bookkeeping (calib.targets.chessboard.fill): the labels it tries, the squares it reads;
and the checks that keep a candidate from being filled, each on a rendered view where it alone rejects one."""

from functools import cache

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.chessboard.fill import _fill, _fill_labels, _frame, _on_lattice
from sogdd.calib.targets.chessboard.windows import refine_board


def reference_fill_labels(labels, pattern):
    """``_fill_labels`` label by label: the free 4-neighbours, sorted, within the pattern or the box."""
    have = {tuple(q) for q in labels.tolist()}
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    out = []
    for q in sorted({(i + a, j + b) for i, j in have for a, b in ((1, 0), (-1, 0), (0, 1), (0, -1))} - have):
        ext = np.sort(np.maximum(hi, q) - np.minimum(lo, q) + 1)
        if (np.all(ext <= sorted(pattern)) if pattern is not None
                else bool(np.all((np.array(q) >= lo) & (np.array(q) <= hi)))):
            out.append(q)
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def reference_frame(p, at, xy, labels, P):
    """``_frame`` corner by corner, axis by axis, side by side."""
    pos = {tuple(q): k for k, q in enumerate(labels.tolist())}
    steps = np.zeros((len(p), 2, 2, 2))
    for k, (i, j) in enumerate(at.tolist()):
        for ax, e in enumerate((np.array([1, 0]), np.array([0, 1]))):
            got = {}
            for side, sg in ((0, 1), (1, -1)):
                m = pos.get((i + sg * e[0], j + sg * e[1]))
                if m is not None:
                    got[side] = sg * (xy[m] - p[k])
            for side, sg in ((0, 1), (1, -1)):
                if side in got:
                    steps[k, ax, side] = got[side]
                elif 1 - side in got:
                    o = got[1 - side]
                    m2 = pos.get((i - 2 * sg * e[0], j - 2 * sg * e[1]))
                    m1 = pos.get((i - sg * e[0], j - sg * e[1]))
                    ratio = 1.0
                    if m2 is not None and m1 is not None:
                        ratio = float(np.clip(np.hypot(*o) / max(np.hypot(*(xy[m1] - xy[m2])), 1e-9), 0.3, 1.5))
                    steps[k, ax, side] = o * ratio
                else:
                    steps[k, ax, side] = P[k, 1 + 2 * ax] - P[k, 2 + 2 * ax]
    d = np.stack([(si * steps[:, 0, (1 - si) // 2] + sj * steps[:, 1, (1 - sj) // 2]) / 2
                  for si, sj in ((1, 1), (-1, -1), (1, -1), (-1, 1))], axis=1)
    return d, np.min(np.hypot(steps[..., 0], steps[..., 1]), axis=(1, 2))


def ragged_board(seed):
    """The labels of a board with holes and a ragged edge, and positions that curve a little."""
    rng = np.random.default_rng(seed)
    lab = np.array([(i, j) for j in range(-2, 5) for i in range(-3, 6)])
    lab = lab[rng.random(len(lab)) > 0.25]
    xy = 20.0 * lab + 0.4 * lab ** 2 + rng.normal(0, 0.3, lab.shape) + 100.0
    return lab, xy


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("pattern", [None, (9, 7), (4, 12), (3, 3)])
def test_fill_labels_are_the_free_neighbours_within_the_pattern(seed, pattern):
    lab, _ = ragged_board(seed)
    got = _fill_labels(lab, pattern)
    assert got.dtype == np.int64 and np.array_equal(got, reference_fill_labels(lab, pattern))


@pytest.mark.parametrize("seed", range(6))
def test_frame_reads_the_steps_to_the_neighbours_to_the_bit(seed):
    lab, xy = ragged_board(seed)
    rng = np.random.default_rng(seed + 10)
    at = np.r_[_fill_labels(lab, None), _fill_labels(lab, (12, 12))[:5], lab[:4]]
    p = 20.0 * at + 100.0 + rng.normal(0, 0.5, at.shape)
    P = np.repeat(p[:, None], 5, axis=1) + rng.normal(0, 10.0, (len(at), 5, 2))
    got, want = _frame(p, at, xy, lab, P), reference_frame(p, at, xy, lab, P)
    for g, w in zip(got, want):
        assert g.shape == w.shape and np.array_equal(g, w)
    assert [a.shape for a in _frame(p[:0], at[:0], xy, lab, P[:0])] == [(0, 4, 2), (0,)]


# --------------------------------------------------------------------------------------------------
# _fill's checks on rendered views: a 9 x 6 board, cells of about 25 px, blur 0.8 px, noise 2 grey levels.
# The lattice handed to the fill is the board's true corners (refined as the search refines them) less the
# free labels H and G; the image around H is altered (its four squares taken from another rendering of the
# board) so that exactly one check must reject H's candidate, while G, untouched, is filled at its corner.

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))
SQ = 0.03
#: the 9 x 6 board's labels and its inner corners' board coordinates (OpenCV's order)
LABELS = np.array([(i, j) for j in range(6) for i in range(9)])
OBJ = np.c_[LABELS * SQ, np.zeros(len(LABELS))]
POSE = (np.array([0.15, -0.1, 0.05]), np.array([0.0, 0.0, 0.62]))
H, G = (2, 2), (6, 3)
#: the label offset of the lattice's second copy of the board (the island tests)
ISLAND = np.array([20, 0])


def _pose(shift=(0.0, 0.0)):
    """The board's pose, moved ``shift`` squares along its own i and j (its corners' image positions then
    lie where labels ``(i + shift_i, j + shift_j)`` lay)."""
    R = cv2.Rodrigues(POSE[0])[0]
    centre = np.array([4 * SQ, 2.5 * SQ, 0.0])
    return POSE[0], POSE[1] - R @ centre + R @ np.array([shift[0] * SQ, shift[1] * SQ, 0.0])


def _truth():
    return LABELS, CAM.project(OBJ, *_pose())


def _index(label) -> int:
    return int(np.flatnonzero((LABELS == label).all(axis=1))[0])


@cache
def _view(render, alter: str = "", shift: float = 0.0) -> np.ndarray:
    """The rendered view, the four squares around H replaced by ``alter``'s: "parity" (the board moved one
    square along i: its squares the other way round), "faint" (a third of the contrast), "shift" (the board
    moved ``shift`` of a square along i: its X-junction there off the lattice)."""
    target = render.Board(9, 6, SQ)
    img = render.render_scene(CAM, target, *_pose())
    if alter:
        other = {"parity": lambda: render.render_scene(CAM, target, *_pose((1.0, 0.0))),
                 "faint": lambda: render.render_scene(CAM, target, *_pose(), levels=(95.0, 155.0, 110.0)),
                 "shift": lambda: render.render_scene(CAM, target, *_pose((shift, 0.0)))}[alter]()
        i, j = H
        quad = np.array([[i - 1, j - 1, 0], [i + 1, j - 1, 0], [i + 1, j + 1, 0], [i - 1, j + 1, 0]]) * SQ
        mask = np.zeros(img.shape, np.uint8)
        cv2.fillPoly(mask, [np.rint(CAM.project(quad, *_pose()) * 16).astype(np.int32)], 1, shift=4)
        img = np.where(mask.astype(bool), other, img)
    return render.add_noise(cv2.GaussianBlur(img, (0, 0), 0.8), 2.0, 7)


def _filled(img: np.ndarray, free=(H, G), island_free=None) -> dict:
    """The corners :func:`_fill` adds to the board's true corners less the ``free`` labels, ``{label: xy}``.

    With ``island_free``, the lattice holds the board a second time at the same points, labelled
    ``ISLAND`` further along i, less those labels (a lattice with one board under two labellings)."""
    labels, xy = _truth()
    keep = ~np.isin(np.arange(len(labels)), [_index(f) for f in free])
    lab, pts = labels[keep], xy[keep]
    if island_free is not None:
        kept = ~np.isin(np.arange(len(labels)), [_index(f) for f in island_free])
        lab, pts = np.r_[lab, labels[kept] + ISLAND], np.r_[pts, xy[kept]]
    grey = img.astype(np.float64)
    pts, quality = refine_board(grey, pts, lab)
    out, out_lab, _, _ = _fill(grey, pts, lab, quality, np.zeros(len(pts)), None)
    return {tuple(q): p for q, p in zip(out_lab[len(pts):].tolist(), out[len(pts):])}


def _at_truth(new: dict, label) -> bool:
    return label in new and float(np.hypot(*(new[label] - _truth()[1][_index(label)]))) < 0.05


def test_the_fill_measures_the_free_labels_at_their_true_corners(render):
    """The premise of the tests below: unaltered, both free labels are filled, each at its true corner."""
    new = _filled(_view(render))
    assert set(new) == {H, G} and _at_truth(new, H) and _at_truth(new, G)


def test_a_candidate_whose_light_squares_lie_the_wrong_way_round_is_not_filled(render):
    """H's squares the other way round: a perfect X-junction at H, symmetric, of the board's contrast and on
    the lattice, but its light diagonal is not where H's parity puts it."""
    new = _filled(_view(render, "parity"))
    assert H not in new, new[H]
    assert set(new) == {G} and _at_truth(new, G)


def test_a_candidate_of_a_faint_x_junction_is_not_filled(render):
    """H's squares at a third of the board's contrast (under FILL_CONTRAST of the board's median): the right
    parity, symmetric and on the lattice, but too faint to be one of the board's corners."""
    new = _filled(_view(render, "faint"))
    assert H not in new, new[H]
    assert set(new) == {G} and _at_truth(new, G)


def test_a_candidate_off_the_lattice_is_not_filled_by_the_check_of_its_neighbours(render):
    """H's X-junction moved 0.35 of a square along i: symmetric, of the right parity and contrast and more
    than half a cell from every corner, but its neighbours' map puts H 0.35 of a cell away (FILL_TOL: 0.2)."""
    new = _filled(_view(render, "shift", 0.35))
    assert H not in new, new[H]
    assert set(new) == {G} and _at_truth(new, G)


def test_a_candidate_on_a_corner_the_board_already_holds_is_not_filled(render):
    """The lattice holds every corner a second time, ISLAND further along i; H is free in the first copy only,
    so its candidate, H's true corner, is already the board's corner H + ISLAND: not half a cell away."""
    new = _filled(_view(render), free=(H,), island_free=())
    assert new == {}


def test_two_candidates_on_one_point_are_neither_filled(render):
    """The lattice holds every corner twice, H free in both copies: H and H + ISLAND, of one parity, each on
    its copy's lattice, both converge on H's true corner; one point cannot take two labels."""
    new = _filled(_view(render), free=(H,), island_free=(H,))
    assert new == {}


# --------------------------------------------------------------------------------------------------
# _on_lattice: the check of a filled corner, within CHECK_TOL, or within FILL_TOL when it is as symmetric as
# the board's corners (a curved rim moves the map, not the corner's symmetry; an occluder moves both)


def _lattice_with_new(off_cells: float):
    """A 7 x 6 lattice of 20 px cells, bent slightly, and one more corner at label (7, 3) (next to the board's
    side) ``off_cells`` of a cell along i from where the lattice continues."""
    lab = np.array([(i, j) for j in range(6) for i in range(7)] + [(7, 3)])
    xy = 20.0 * lab + 0.02 * (lab[:, :1] - 3.0) ** 2 + 5.0
    xy[-1, 0] += 20.0 * off_cells
    return xy, lab


@pytest.mark.parametrize("off, asym, board, kept", [
    (0.05, 0.08, 0.01, True),    # within CHECK_TOL: kept whatever its symmetry (the asymmetry test is another)
    (0.16, 0.005, 0.01, True),   # beyond CHECK_TOL, within FILL_TOL, as symmetric as the board's: kept
    (0.16, 0.05, 0.01, False),   # the same point, five times the board's asymmetry: an occluder moved it
    (0.16, 0.019, 0.001, True),  # 19 times a clean board's, but under FILL_SYMMETRY_FLOOR: kept
    (0.16, 0.025, 0.001, False),  # ... over it: dropped
    (0.25, 0.0, 0.01, False),    # beyond FILL_TOL: never
])
def test_a_filled_corner_beyond_the_grown_corners_tolerance_must_be_as_symmetric_as_the_board(off, asym, board,
                                                                                               kept):
    xy, lab = _lattice_with_new(off)
    quality = np.r_[np.full(len(xy) - 1, 1 - board), 1 - asym]
    assert _on_lattice(xy, lab, quality, len(xy) - 1, board).tolist() == [kept]
