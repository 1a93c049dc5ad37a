"""``python -m app.pnml_report`` (app/pnml_report.py): each way it ends maps to the table of
exit statuses (mission/exits.py, docs/EXIT.md): an option out of range or a file that is not a
P/T net is invalid input, ``--method symbolic`` on a net it cannot decide is no verdict, and a
bug of ours is an internal error said in one line, not a traceback. The report itself is
tests/petri/formats/test_pnml.py's."""

from __future__ import annotations

from pathlib import Path

import pytest

import app.pnml_report
from mission.exits import Exit
from petri.formats.pnml import write_pnml
from petri.net import Net


def net_file(tmp_path: Path, tokens: int = 1) -> str:
    """a -> t -> b, with ``tokens`` in a (2: not 1-safe, which the BDD search refuses)."""
    net = Net("small")
    a, b = net.add_place("a"), net.add_place("b")
    net.initial = {a: tokens}
    net.add_transition("t", [a], [b])
    path = tmp_path / "small.pnml"
    write_pnml(net, path)
    return str(path)


def test_a_report_is_ok(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert app.pnml_report.main([net_file(tmp_path), "--method", "explicit"]) == Exit.OK
    assert "markings" in capsys.readouterr().out


@pytest.mark.parametrize("value", ["0", "-5", str(2**31)])
def test_a_limit_out_of_range_is_invalid_input(tmp_path: Path, value: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stopped:
        app.pnml_report.main([net_file(tmp_path), "--max-markings", value])
    assert stopped.value.code == Exit.INVALID
    assert f"--max-markings: must lie between 1 and 2**31 - 1, got {value}" in \
        capsys.readouterr().err


def test_a_file_that_is_not_a_net_is_invalid_input(tmp_path: Path) -> None:
    (tmp_path / "x.pnml").write_text("<html/>", encoding="utf-8")
    assert app.pnml_report.main([str(tmp_path / "x.pnml")]) == Exit.INVALID


def test_symbolic_on_a_net_that_is_not_one_safe_is_no_verdict(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("dd")
    status = app.pnml_report.main([net_file(tmp_path, tokens=2), "--method", "symbolic"])
    assert status == Exit.UNDECIDED
    assert "error:" in capsys.readouterr().err


def test_a_bug_is_an_internal_error_in_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    def broken(*args: object, **kwargs: object) -> None:
        raise ValueError("a bug")

    monkeypatch.setattr(app.pnml_report, "analyse", broken)
    path = net_file(tmp_path)
    assert app.pnml_report.main([path]) == Exit.INTERNAL
    err = capsys.readouterr().err
    assert err.startswith(f"{path}: internal error: ValueError: a bug\n")
    assert "Traceback" not in err
