"""mission/exits.py: one table of exit statuses, one meaning per number; docs/EXIT.md
documents exactly that table and each command's statuses by its names; a run's status follows
from how the runner ended it."""

from __future__ import annotations

from app.mcl import COMMANDS
from mission.exits import SIGNAL_BASE, Exit, run_exit, signalled
from tests.support import REPO

DOC = REPO / "docs" / "EXIT.md"


def table_rows(heading: str | None = None) -> list[list[str]]:
    """The cells of the first markdown table after ``heading`` (the first table if None)."""
    text = DOC.read_text("utf-8")
    if heading is not None:
        text = text[text.index(heading):]
    rows, started = [], False
    for line in text.splitlines():
        if line.startswith("|"):
            started = True
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(set(c) <= {"-", ":"} for c in cells):
                rows.append(cells)
        elif started:
            break
    return rows


def test_the_page_documents_exactly_the_table() -> None:
    header, *rows = table_rows()
    assert header[:2] == ["status", "name"]
    numbered = [(r[0], r[1].strip("`")) for r in rows if r[0].isdigit()]
    assert numbered == [(str(int(e)), e.name) for e in Exit]
    assert any(r[0] == f"{SIGNAL_BASE} + N" for r in rows)
    assert len({int(e) for e in Exit}) == len(Exit)  # one meaning per number


def test_each_command_column_is_a_status_of_the_table() -> None:
    header, *rows = table_rows("## What each command means by them")
    named = {f"{int(e)} `{e.name}`" for e in Exit}
    assert header[0] == "command" and set(header[1:-1]) <= named, header
    assert header[-1] == f"{SIGNAL_BASE} + N"
    commands = " ".join(r[0] for r in rows)
    for command in ["mclc", "mcl check", "python -m app.pnml_report", *(f"mcl {c}" for c in
                                                                       COMMANDS)]:
        assert f"`{command}" in commands, f"{command} has no row in docs/EXIT.md"


def test_a_run_exits_as_the_table_says() -> None:
    assert [run_exit(s) for s in ("ok", "fail", "timeout", "stuck", "stopped", "error")] == [
        Exit.OK, Exit.FAILED, Exit.UNDECIDED, Exit.UNDECIDED, Exit.UNDECIDED, Exit.VEHICLE]
    assert run_exit("stopped", 15) == signalled(15) == 143
    assert run_exit("ok", 15) == Exit.OK  # a signal after the end changes nothing
