"""mcl/api.py on its own: the pipeline behind a tiny facade, file -> AST -> checked -> net.

``compile_file`` / ``compile_source`` with the task library chosen by ``USES`` (shipped names,
or paths relative to the mission file), by ``tasks``, or given ready-made; ``parse_params``
turns ``--param NAME=VALUE`` and parameter files into values placed where they were written.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from diagnostics import Diagnostic, MclError, Source
from mcl import ast, tasklib
from mcl.api import Compiled, compile_file, compile_source, parse_params
from tests.support import MISSIONS

ROV_TASKS = ("behaviour Sampler events done;\n"
             "task TakeSample(depth: length) {\n"
             "  start: enable Sampler(depth = depth);\n  ok: Sampler.done;\n"
             "  stop: disable Sampler;\n}\n")


def _first_error(exc: pytest.ExceptionInfo[MclError]) -> Diagnostic:
    return exc.value.errors[0]


def test_compile_source_gives_every_stage() -> None:
    source = Source("m.mcl", "PARAM u = 1 m;\nMISSION demo {\n  Wait(2 s)\n}\n")
    compiled = compile_source(source)
    assert isinstance(compiled, Compiled)
    assert compiled.source is source
    assert compiled.mission.name == "demo" and compiled.net.name == "demo"
    assert compiled.checked.mission is compiled.mission
    assert [(d.code, str(d.span)) for d in compiled.warnings] == [("unused-param", "m.mcl:1:7")]
    assert compiled.warnings is compiled.checked.diagnostics
    assert any(t.timer == 2.0 for t in compiled.net.transitions)


def test_compile_file_reads_the_file_and_names_spans_after_it() -> None:
    path = MISSIONS / "dam_inspection.mcl"
    compiled = compile_file(str(path))
    assert compiled.source.name == str(path)
    assert compiled.mission.span.file == str(path)
    origins = {t.origin.file for t in compiled.net.transitions if t.origin}
    assert origins == {str(path)}


def test_without_uses_or_tasks_the_default_library_is_ictineu() -> None:
    compiled = compile_source(Source("m.mcl", "MISSION { Surface() }"))
    assert compiled.checked.library.files == ["<mcl>/tasks/core.tasks",
                                              "<mcl>/tasks/ictineu.tasks"]


def test_tasks_replace_the_vehicle_library_and_keep_the_timers(tmp_path: Path) -> None:
    lib = tmp_path / "rov.tasks"
    lib.write_text(ROV_TASKS, encoding="utf-8")
    compiled = compile_source(Source("m.mcl", "MISSION { TakeSample(3 m); Wait(1 s) }"),
                              tasks=[str(lib)])
    assert set(compiled.checked.library.tasks) >= {"TakeSample", "Wait", "Timeout"}
    with pytest.raises(MclError) as info:
        compile_source(Source("m.mcl", "MISSION { Surface() }"), tasks=[str(lib)])
    assert _first_error(info).code == "unknown-task"


def test_uses_finds_libraries_by_shipped_name_and_relative_to_the_mission(
        tmp_path: Path) -> None:
    (tmp_path / "rov.tasks").write_text(ROV_TASKS, encoding="utf-8")
    mission = tmp_path / "m.mcl"
    mission.write_text('USES "ictineu";\nUSES "rov.tasks";\n'
                       "MISSION {\n  TakeSample(3 m);\n  Surface()\n}\n", encoding="utf-8")
    compiled = compile_file(str(mission))
    assert compiled.checked.library.files == [
        "<mcl>/tasks/core.tasks", "<mcl>/tasks/ictineu.tasks", str(tmp_path / "rov.tasks")]


def test_a_missing_library_is_an_error_at_its_uses(tmp_path: Path) -> None:
    mission = tmp_path / "m.mcl"
    mission.write_text('USES "nowhere.tasks";\nMISSION { Surface() }\n', encoding="utf-8")
    with pytest.raises(MclError) as info:
        compile_file(str(mission))
    d = _first_error(info)
    assert (d.code, str(d.span)) == ("missing-library", f"{mission}:1:6")
    assert str(tmp_path / "nowhere.tasks") in d.message


def test_a_given_library_is_used_as_it_is() -> None:
    library = tasklib.load(["generic"])
    compiled = compile_source(Source("m.mcl", 'USES "nowhere.tasks";\nMISSION { A() }'),
                              library=library)
    assert compiled.checked.library is library


def test_params_on_the_command_line_reach_the_net() -> None:
    text = "MISSION {\n  Wait(t)\n}\n"
    left = compile_source(Source("m.mcl", text))
    assert [t.timer for t in left.net.transitions if t.timer is not None] == ["t"]
    given = compile_source(Source("m.mcl", text), params=parse_params(["t=1.5 min"]),
                           require_values=True)
    assert [t.timer for t in given.net.transitions if t.timer is not None] == [90.0]
    with pytest.raises(MclError) as info:
        compile_source(Source("m.mcl", text), require_values=True)
    assert (_first_error(info).code, str(_first_error(info).span)) == ("unset-param",
                                                                       "m.mcl:2:8")


# -- parse_params --------------------------------------------------------------------------
def test_parse_params_from_the_command_line_placed_in_their_own_origin() -> None:
    params = parse_params(["d=3 m", "p=(1, 2, 3 m, 90 deg)"])
    value, origin = params["d"]
    assert value == ast.Number(3, "m")
    assert (origin.name, origin.text, str(value.span)) == ("--param d=3 m", "d=3 m",
                                                           "--param d=3 m:1:3")
    assert params["p"][0] == ast.Point((ast.Number(1), ast.Number(2), ast.Number(3, "m"),
                                        ast.Number(90, "deg")))
    assert parse_params(["h=1 deg", "h=2 deg"])["h"][0] == ast.Number(2, "deg")  # last wins


def test_parse_params_from_a_file_with_comments_and_blank_lines(tmp_path: Path) -> None:
    path = tmp_path / "p.params"
    path.write_text("// depths\nd = 2 m\n\nh = 90 deg;  // heading\n", encoding="utf-8")
    params = parse_params(["d=5 m"], [str(path)])
    assert params["d"][0] == ast.Number(5, "m")  # the command line comes after the files
    h, origin = params["h"]
    assert h == ast.Number(90, "deg") and origin.name == str(path)
    assert str(h.span) == f"{path}:4:5"


@pytest.mark.parametrize("item,code,message", [
    ("d", "bad-param", "expected --param NAME=VALUE, got 'd'"),
    ("2d=1", "bad-param", "expected --param NAME=VALUE, got '2d=1'"),
    ("d=foo", "bad-param", "--param d=foo: 'foo' is not a value"),
    ("d=(1, x)", "bad-param", "--param d=(1, x): 'x' is not a value"),
    ("d=3 feet", "bad-value", "not a value: '3 feet'"),
])
def test_parse_params_refuses_what_is_not_name_equals_value(item: str, code: str,
                                                            message: str) -> None:
    with pytest.raises(MclError) as info:
        parse_params([item])
    d = _first_error(info)
    assert (d.code, d.message) == (code, message)
    assert d.span is not None and d.span.file == f"--param {item}"


@pytest.mark.parametrize("text,code,where", [
    ("d = 1 m\nbad line\n", "bad-param-file", "2:1"),
    ("d = 1 m\n\nx = (1, \n", "bad-value", "3:4"),
])
def test_parse_params_refuses_a_bad_line_of_a_file_at_its_place(tmp_path: Path, text: str,
                                                                 code: str, where: str) -> None:
    path = tmp_path / "p.params"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(MclError) as info:
        parse_params([], [str(path)])
    d = _first_error(info)
    assert (d.code, str(d.span)) == (code, f"{path}:{where}")


def test_parse_params_of_a_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MclError) as info:
        parse_params([], [str(tmp_path / "none.params")])
    assert _first_error(info).code == "missing-file"
