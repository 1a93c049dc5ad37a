"""The README's quoted ``mclc`` output is what ``mclc`` prints now (issue 21: the dam figures
had drifted to 216 transitions and 49 dead where mclc printed 210 and 43).

Each ```` ```sh ```` block of README.md that starts ``$ .venv/bin/mclc FILE...`` on files of the
repository is run; every line it quotes must be a line of the real output, in order, once
durations (``0.052 s``) are set aside. A line ``...`` (or one ending in ``...``) stands for
what the README leaves out.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator

import pytest

from tests.support import REPO

SECONDS = re.compile(r"\d+(\.\d+)? s\b")


def quoted_runs(text: str) -> Iterator[tuple[int, list[str], list[str]]]:
    """(line, mclc's arguments, the output lines quoted) of each quoted mclc run of ``text``."""
    lines = text.split("\n")
    for i, line in enumerate(lines):
        if line.strip() != "```sh" or i + 1 >= len(lines):
            continue
        command = lines[i + 1].split()
        if command[:2] != ["$", ".venv/bin/mclc"]:
            continue
        out: list[str] = []
        for body in lines[i + 2:]:
            if body.startswith("```"):
                break
            out.append(body)
        yield i + 2, command[2:], out


def shown_in(quoted: list[str], printed: list[str]) -> list[str]:
    """The quoted lines that are not lines of ``printed`` in order (durations aside)."""
    normal = [SECONDS.sub("T s", p) for p in printed]
    missing, at = [], 0
    for q in quoted:
        if q.strip() == "..." or q.endswith("...") or not q.strip():
            continue
        want = SECONDS.sub("T s", q)
        try:
            at = normal.index(want, at) + 1
        except ValueError:
            missing.append(q)
    return missing


def test_the_scanner_finds_the_dam_run_and_catches_a_drifted_figure() -> None:
    runs = list(quoted_runs((REPO / "README.md").read_text(encoding="utf-8")))
    assert any(args == ["missions/dam_inspection.mcl"] for _, args, _ in runs)
    printed = ["m.mcl: mission m: 1 task calls, 9 places, 210 transitions", "  done, 0.1 s"]
    assert shown_in(["m.mcl: mission m: 1 task calls, 9 places, 216 transitions"], printed)
    assert not shown_in(["m.mcl: mission m: 1 task calls, 9 places, 210 transitions", "...",
                         "  done, 0.052 s"], printed)


@pytest.mark.parametrize("line,args,quoted", [
    run for run in quoted_runs((REPO / "README.md").read_text(encoding="utf-8"))
    if all((REPO / a).exists() for a in run[1] if not a.startswith("-"))])
def test_the_readme_quotes_what_mclc_prints(line: int, args: list[str], quoted: list[str]) -> None:
    done = subprocess.run([sys.executable, "-m", "app.mclc", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=300, check=False)
    missing = shown_in(quoted, (done.stdout + done.stderr).splitlines())
    assert not missing, f"README.md:{line}: not what mclc prints now: {missing}"


def broken_tables(text: str) -> list[int]:
    """Lines of ``text`` where a table row follows a blank line that follows a table row (a
    Markdown table ends at a blank line: the rows after it are no longer a table)."""
    lines = text.split("\n")
    return [i + 1 for i in range(2, len(lines)) if lines[i].startswith("|")
            and not lines[i - 1].strip() and lines[i - 2].startswith("|")
            and not lines[i + 1 if i + 1 < len(lines) else i].startswith("|---")]


def test_no_table_of_the_readme_is_cut_by_a_blank_line() -> None:
    assert broken_tables("| a | b |\n|---|---|\n| 1 | 2 |\n\n| 3 | 4 |\n") == [5]
    assert broken_tables("| a | b |\n|---|---|\n| 1 | 2 |\n\n| c | d |\n|---|---|\n") == []
    assert broken_tables((REPO / "README.md").read_text(encoding="utf-8")) == []
