"""Board specifications and the registry of board kinds: a new kind is one module and one row."""

import numpy as np
import pytest

from sogdd.calib.targets.board import Board, ViewBoards
from sogdd.calib.targets.spec import KINDS, BoardSpec, Kind, parse_board, view_boards


@pytest.mark.parametrize("text", ["chessboard:9x6", "chessboard:auto", "charuco:5x7:0.7:DICT_5X5_100"])
def test_every_kind_reads_back_what_it_writes(text):
    spec = parse_board(text)
    assert str(spec) == text and parse_board(str(spec)) == spec and spec.kind in KINDS


@pytest.mark.parametrize("bad, words", [
    ("chessboard:9", "is not COLSxROWS"), ("chessboard:1x6", "at least 2x2"),
    ("charuco:5x7:1.5:DICT_5X5_100", "MARKER"), ("dots:3x3", "expected"), ("chessboard", "expected")])
def test_a_bad_specification_is_one_line_naming_it(bad, words):
    with pytest.raises(ValueError, match=words) as e:
        parse_board(bad)
    assert repr(bad) in str(e.value) and "\n" not in str(e.value)


def test_a_new_kind_is_one_row(monkeypatch):
    found = Board(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([[0, 0], [1, 0]]))

    def parse(parts, text):
        return {"pattern": (int(parts[0]), 1)} if len(parts) == 1 else None

    row = Kind("dots", "dots:N", parse, lambda s: f"dots:{s.pattern[0]}",
               lambda img, s, view_only: ViewBoards((found,)))
    monkeypatch.setitem(KINDS, "dots", row)
    s = parse_board("dots:4")
    assert s == BoardSpec("dots", pattern=(4, 1)) and str(s) == "dots:4"  # type: ignore[arg-type]
    assert view_boards(np.zeros((8, 8)), s).boards == (found,)
