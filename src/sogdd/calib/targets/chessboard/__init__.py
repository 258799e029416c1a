"""Chessboard detection, stage by stage: X-corners over a pyramid, lattices, refinement, checks, labels.

Each stage is one module; :mod:`.search` runs them in this order for every level
of the pyramid (finest first, until one gives the whole pattern):

===== ========= ====================================================== ============================
stage module    what it does                                           comes out
===== ========= ====================================================== ============================
1     xcorners  saddle points with their edge lines at one level       ``XCorners``
                of the pyramid, above the noise the image shows there
2     lattice   X-corners linked along their edge lines and grown      ``Lattice``: indices, labels
                from seeds by prediction
3     windows   each corner refined at full resolution to its centre   points, quality
                of point symmetry, windows cut at the board's edge
4     mapping   each corner predicted by its neighbours' map           the corners kept
                (the lattice's check)
5     fill      the labels the lattice left free, measured where       more corners
                its map puts them
6     checks    links along edges, no orphans, a 3 x 3 block; a        a board, or none
                proposal that is no part of a larger grid
7     labels    right-handed labels, the same ``(0, 0)`` in every view ``Board``
1b    proposals OpenCV's detectors' board where the own search         a lattice for stages 3-7
                found no complete one
===== ========= ====================================================== ============================

:mod:`.xcorners`: X-corner candidates, the pyramid's levels and the noise-relative threshold.
:mod:`.lattice`: the lattice grown from X-corners by local-homography prediction.
:mod:`.mapping`: the lattice's map (local homographies, curved maps), its predictions and its check.
:mod:`.windows`: a board's corners refined: windows that stop at its edge, shading out, the symmetry test.
:mod:`.fill`: corners at the labels a grown lattice left free, measured where the lattice puts them.
:mod:`.checks`: whether a refined lattice is a board (edges, orphans, a block, a larger grid).
:mod:`.labels`: a board's labels, right-handed, with the same ``(0, 0)`` in every view.
:mod:`.proposals`: OpenCV's chessboard detectors as a second source of board candidates.
:mod:`.search`: the stages in order over the pyramid: :func:`find_boards`, :func:`detect_boards`.
"""

from .search import (
    BoardSearch,
    detect_board,
    detect_boards,
    find_boards,
    parse_spec,
    spec_text,
    view_boards,
)
from .xcorners import XCorners, find_xcorners

__all__ = ["BoardSearch", "XCorners", "detect_board", "detect_boards", "find_boards", "find_xcorners",
           "parse_spec", "spec_text", "view_boards"]
