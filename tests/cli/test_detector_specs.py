"""``--detectors`` specs: nothing named is an error, never every detector; a key twice or
without a name is an error, never a silent last value or a blank name."""

import pytest

from sogdd.cli.main import main
from sogdd.evaluation.specs import parse_spec, parse_specs


@pytest.mark.parametrize("items", [[""], [",,"], [" , "], ["", ","]])
def test_specs_that_name_no_detector_are_an_error(items):
    with pytest.raises(ValueError, match="names no detector"):
        parse_specs(items, ["sogdd"])
    assert [s.name for s in parse_specs(None, ["sogdd"])] == ["sogdd"]  # not given: the default


@pytest.mark.parametrize("text, words", [
    ("sogdd:sigma2=1.2:sigma2=2", ["sigma2 is given twice"]),
    ("sogdd:top_k=5:top_k=6", ["top_k is given twice"]),
    ("sogdd:=3", ["has no name"]),
    ("sogdd: =3", ["has no name"]),
])
def test_a_key_twice_or_without_a_name_is_an_error(text, words):
    with pytest.raises(ValueError) as exc:
        parse_spec(text)
    assert all(w in str(exc.value) for w in words) and text in str(exc.value)


def test_an_unknown_blank_parameter_is_shown_quoted():
    from sogdd import baselines

    with pytest.raises(ValueError, match=r"unknown parameter\(s\) ''"):
        baselines.get("harris", **{"": 3})


@pytest.mark.parametrize("spec", ["", ",,", "sogdd:sigma2=1.2:sigma2=2", "sogdd:=3"])
@pytest.mark.parametrize("command", [["eval", "gt"], ["eval", "matching"], ["eval", "repeatability"]])
def test_the_cli_says_so_in_one_line(spec, command, capsys, tmp_path):
    rc = main([*command, "--detectors", spec, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("sogdd: error:") and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists()
