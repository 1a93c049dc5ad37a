"""The task library is text: the shipped one, a user's own, and clear errors in either."""

from __future__ import annotations

import os
from pathlib import Path

import lark
import pytest

from mcl import grammars, tasklib
from diagnostics import MclError, Source
from tests.support import cli, write

ROV_TASKS = """
// A user's vehicle: a sampling arm, added without writing Python.
behaviour Arm drives x events closed, jammed;
task TakeSample(depth: length) {
    start:   enable Arm(depth = depth);
    ok:      Arm.closed;
    fail:    Arm.jammed;
    timeout: 90 s -> fail;
    stop:    disable Arm;
}
"""


def test_the_shipped_library_declares_the_papers_nine_tasks_and_timers() -> None:
    lib = tasklib.load()
    assert {"Alarms", "StartLogs", "GoTo", "AchieveHeadDist", "KeepHeadDist",
            "KeepHeadDistException", "StartCamera", "WallInspect", "Surface"} <= set(lib.tasks)
    assert {"Wait", "Timeout"} <= set(lib.tasks)
    assert lib.dofs() == {"GoTo": ("x", "y", "z", "yaw"), "WallInspection": ("y", "z"),
                          "AchieveHeadDist": ("x", "yaw"), "Surface": ("z",),
                          "StartCamera": (), "Alarms": (), "StartLogs": ()}
    keep = {tuple(f.name for f in form.formals) for form in lib.tasks["KeepHeadDist"]}
    assert keep == {("enable", "heading", "distance"), ("disable",)}
    # tasks are not behaviours: the AchieveHeadDist behaviour serves three tasks
    users = {name for name, forms in lib.tasks.items() for f in forms
             if any(a.behaviour == "AchieveHeadDist" for a in f.start)
             or any(e.startswith("AchieveHeadDist.") for e in f.ok + f.fail)}
    assert users == {"AchieveHeadDist", "KeepHeadDist", "KeepHeadDistException"}


def test_a_users_library_on_the_command_line(tmp_path: Path) -> None:
    lib = write(tmp_path, ROV_TASKS, "rov.tasks")
    mission = write(tmp_path, "MISSION {\n  TakeSample(3 m)\n}\n")
    proc = cli("mclc", str(mission), "--tasks", str(lib))
    assert proc.returncode == 0, proc.stderr
    assert "verified" in proc.stdout
    # the user's library replaces the default vehicle library (timers stay)
    other = write(tmp_path, "MISSION {\n  Surface()\n}\n", "other.mcl")
    proc = cli("mclc", str(other), "--tasks", str(lib))
    assert proc.returncode == 2 and "unknown task 'Surface'" in proc.stderr


def test_uses_in_the_mission_file(tmp_path: Path) -> None:
    write(tmp_path, ROV_TASKS, "rov.tasks")
    mission = write(tmp_path, 'USES "ictineu";\nUSES "rov.tasks";\n'
                    "MISSION {\n  TakeSample(3 m);\n  Surface()\n}\n")
    proc = cli("mclc", str(mission))
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("text,line,col,words", [
    ("task T() { start: enable Nope; }", 1, 19, "unknown behaviour 'Nope'"),
    ("behaviour B events e;\ntask T() { ok: B.f; }", 2, 6, "behaviour B has no event 'f'"),
    ("task T(x: banana) { }", 1, 11, "unknown kind 'banana'"),
    ("task T(x) { }", 1, 8, "parameter 'x' has no kind"),
    ("behaviour B;\ntask T() { start: enable B; latch: B; timeout: 3 s -> ok; }", 2, 6,
     "must end at once"),
    ("task T() { timeout: 3 s -> maybe; }", 1, 28, "'ok' or 'fail'"),
    ("task T() { start: switch B; }", 1, 19, "unknown action 'switch'"),
    ("task T( { }", 1, 9, "unexpected"),
    ("behaviour B;\nbehaviour B;", 2, 11, "declared twice"),
    ("task T() { }\ntask T() { }", 2, 6, "same as the one at"),
    ("behaviour B;\ntask T(p: point) { start: enable B(v = q.x); }", 2, 40,
     "'q' is not a parameter"),
])
def test_library_errors_name_the_place(text: str, line: int, col: int, words: str) -> None:
    with pytest.raises(MclError) as info:
        tasklib.load_sources([Source("lib.tasks", text)])
    d = info.value.errors[0]
    assert d.span is not None
    assert (d.span.file, d.span.line, d.span.col) == ("lib.tasks", line, col), d.format()
    assert words in d.message + d.hint, d.format()


def test_a_broken_library_on_the_command_line_exits_2(tmp_path: Path) -> None:
    lib = write(tmp_path, "task T() { start: enable Nope; }\n", "bad.tasks")
    mission = write(tmp_path, "MISSION {\n  T()\n}\n")
    proc = cli("mclc", str(mission), "--tasks", str(lib))
    assert proc.returncode == 2
    assert f"{lib}:1:19: error: task T: unknown behaviour 'Nope'" in proc.stderr
    assert "Traceback" not in proc.stderr


# -- the shipped libraries come from the cache after their first load (issue 27) -------------

def shipped(*names: str) -> list[Source]:
    return [tasklib.shipped_source(f"{n}.tasks") for n in names]


def test_the_shipped_library_is_parsed_once_then_loaded(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", str(tmp_path))
    first = tasklib.load()
    assert first == tasklib.build_library(shipped("core", "ictineu"))
    assert [p.name.rsplit("-", 1)[0] for p in tmp_path.glob("library-*")] == [
        "library-core+ictineu"]

    def no_parse(sources: list[Source]) -> tasklib.Library:
        raise AssertionError("the shipped library was parsed again")

    monkeypatch.setattr(tasklib, "build_library", no_parse)
    again = tasklib.load()
    assert again == first and again is not first  # a copy of its own, free to change


def test_an_edited_library_text_is_never_answered_from_the_cache(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", str(tmp_path))
    core, ictineu = shipped("core", "ictineu")
    tasklib.load_sources([core, ictineu])
    edited = Source(ictineu.name, ictineu.text + "\nbehaviour Arm events closed;\n")
    library = tasklib.load_sources([core, edited])
    assert "Arm" in library.behaviours
    assert "Arm" not in tasklib.load_sources([core, ictineu]).behaviours
    broken = Source(ictineu.name, ictineu.text + "\ntask T() { start: enable Nope; }\n")
    with pytest.raises(MclError, match="unknown behaviour 'Nope'"):
        tasklib.load_sources([core, broken])


def test_a_users_library_is_not_cached(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", str(tmp_path / "cache"))
    library = tasklib.load_sources([*shipped("core"), Source("rov.tasks", ROV_TASKS)])
    assert "TakeSample" in library.tasks
    assert not list((tmp_path / "cache").glob("library-*"))


def test_an_edited_grammar_or_another_lark_is_another_library_entry(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", str(tmp_path))
    tasklib.load()
    (first,) = tmp_path.glob("library-*")
    shipped_grammar = grammars.grammar_text("tasks.lark")
    monkeypatch.setattr(grammars, "grammar_text", lambda name: shipped_grammar + "\n// edit\n")
    tasklib.load()
    (second,) = tmp_path.glob("library-*")
    assert second != first
    monkeypatch.setattr(lark, "__version__", "0.0.0")
    tasklib.load()
    (third,) = tmp_path.glob("library-*")
    assert third not in (first, second)


# -- a file that is not a task library is never read as one, nor quoted (issue 22) ---------------
SECRET = "root:x:0:0:root:/root:/bin/bash\n"


@pytest.mark.parametrize("how", ["USES", "--tasks"])
def test_a_file_that_is_not_a_task_library_is_named_not_quoted(tmp_path: Path, how: str) -> None:
    secret = write(tmp_path, SECRET, "passwd")
    if how == "USES":
        mission = write(tmp_path, f'USES "{secret}";\nMISSION m {{ Surface() }}\n')
        proc = cli("mclc", str(mission))
        where = f"{mission}:1:6: error: '{secret}' is not a task library"
    else:
        mission = write(tmp_path, "MISSION m { Surface() }\n")
        proc = cli("mclc", str(mission), "--tasks", str(secret))
        where = f"{secret}:1:1: error: is not a task library"
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith(where), proc.stderr
    assert "ends in .tasks" in proc.stderr
    assert "root" not in proc.stderr.replace(str(tmp_path), ""), proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_tasks_file_with_a_mistake_is_still_quoted(tmp_path: Path) -> None:
    lib = write(tmp_path, "behaviour Arm events done\n", "arm.tasks")
    mission = write(tmp_path, f'USES "{lib.name}";\nMISSION m {{ Wait(1 s) }}\n')
    proc = cli("mclc", str(mission))
    assert proc.returncode == 2 and f"{lib}:1:22: error: task library" in proc.stderr, \
        proc.stderr
    assert "behaviour Arm events done" in proc.stderr


@pytest.mark.parametrize("how", ["USES", "--tasks"])
def test_a_tasks_link_to_a_file_that_is_not_a_task_library_is_not_read(
        tmp_path: Path, how: str) -> None:
    # found rerunning issue 22 from a fresh clone: evil.tasks -> /etc/shadow was read, and
    # its syntax error quoted the file's first line
    secret = write(tmp_path, SECRET, "shadow")
    link = tmp_path / "evil.tasks"
    link.symlink_to(secret)
    if how == "USES":
        mission = write(tmp_path, 'USES "evil.tasks";\nMISSION m { Surface() }\n')
        proc = cli("mclc", str(mission))
        where = f"{mission}:1:6: error: 'evil.tasks' is not a task library"
    else:
        mission = write(tmp_path, "MISSION m { Surface() }\n")
        proc = cli("mclc", str(mission), "--tasks", str(link))
        where = f"{link}:1:1: error: is not a task library"
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith(where), proc.stderr
    assert f"this is a link to '{secret}'" in proc.stderr, proc.stderr
    assert "root" not in proc.stderr.replace(str(tmp_path), ""), proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_tasks_link_to_a_task_library_is_read(tmp_path: Path) -> None:
    lib = write(tmp_path, "behaviour Arm events done\n", "real.tasks")
    (tmp_path / "link.tasks").symlink_to(lib)
    mission = write(tmp_path, 'USES "link.tasks";\nMISSION m { Wait(1 s) }\n')
    proc = cli("mclc", str(mission))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert f"{tmp_path / 'link.tasks'}:1:22: error: task library" in proc.stderr, proc.stderr
    assert "behaviour Arm events done" in proc.stderr  # a library's mistake is still quoted


def test_a_fifo_named_by_uses_is_refused_unread(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.tasks")
    mission = write(tmp_path, 'USES "pipe.tasks";\nMISSION m { Surface() }\n')
    proc = cli("mclc", str(mission))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "task library 'pipe.tasks' is not a regular file" in proc.stderr, proc.stderr


@pytest.mark.parametrize("text", ["behaviour X events a", "task T() { ok: X.a; "])
def test_a_library_cut_short_says_where_it_ends(tmp_path: Path, text: str) -> None:
    # was "unexpected ''": the token lark gives for the end of the file
    lib = write(tmp_path, text, "cut.tasks")
    mission = write(tmp_path, 'USES "cut.tasks";\nMISSION m { Surface() }\n')
    proc = cli("mclc", str(mission))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    first = proc.stderr.splitlines()[0]
    assert first.startswith(f"{lib}:1:") and "the file ends inside a declaration" in first, \
        proc.stderr
