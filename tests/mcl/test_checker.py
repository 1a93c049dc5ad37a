"""mcl/checker.py on its own: a parsed mission checked against a task library.

What the compiler gets (:class:`Checked`): each call resolved to its task form with its
arguments by formal name (defaults filled in), the per-call timeout, the parameters' values and
kinds. What a user gets: every problem at once, errors before warnings, each at its exact
``file:line:col`` with a stable code (values given on the command line are placed in their
own origin).
"""

from __future__ import annotations

import pytest

from diagnostics import MclError, Source
from mcl import ast, tasklib
from mcl.checker import Checked, check_mission
from mcl.parser import parse, parse_value

LIBRARY = tasklib.load()  # core.tasks + ictineu.tasks


def _check(text: str, overrides: dict[str, tuple[ast.Value, Source]] | None = None,
           require_values: bool = False, library: tasklib.Library = LIBRARY) -> Checked:
    source = Source("m.mcl", text)
    return check_mission(parse(source), library, source, overrides, require_values)


def _problems(text: str, overrides: dict[str, tuple[ast.Value, Source]] | None = None,
              require_values: bool = False) -> list[tuple[str, str, str]]:
    """(severity, code, place) of every diagnostic, raised or kept as warnings."""
    try:
        found = _check(text, overrides, require_values).diagnostics
    except MclError as exc:
        found = exc.diagnostics
    return [(d.severity, d.code, str(d.span)) for d in found]


def _param(name: str, text: str) -> dict[str, tuple[ast.Value, Source]]:
    """``--param name=text`` as :func:`mcl.api.parse_params` makes it."""
    origin = Source(f"--param {name}={text}", f"{name}={text}")
    return {name: (parse_value(text, origin.name, column=len(name) + 2), origin)}


# -- what the compiler gets ------------------------------------------------------------------
def test_each_call_resolves_to_its_form_with_arguments_by_formal_name() -> None:
    checked = _check("MISSION {\n  GoTo((1 m, 2 m, 3 m, 90 deg));\n"
                     "  KeepHeadDist(enable, 10 deg, 2 m);\n  KeepHeadDist(disable)\n}\n")
    assert isinstance(checked.mission.body, ast.Sequence)
    goto, keep_on, keep_off = checked.mission.body.items
    assert isinstance(goto, ast.Call) and isinstance(keep_on, ast.Call)
    assert isinstance(keep_off, ast.Call)
    r = checked.resolved(goto)
    assert (r.form.name, [f.name for f in r.form.formals]) == ("GoTo", ["target", "tolerance"])
    assert r.args == {"target": ast.Point((ast.Number(1, "m"), ast.Number(2, "m"),
                                           ast.Number(3, "m"), ast.Number(90, "deg"))),
                      "tolerance": ast.Number(0.5, "m")}  # the default
    assert r.timeout is None
    # the two forms of KeepHeadDist: the word chooses the form, and is not an argument
    on, off = checked.resolved(keep_on), checked.resolved(keep_off)
    assert (on.form.latch, on.form.unlatch) == ("AchieveHeadDist", None)
    assert (off.form.latch, off.form.unlatch) == (None, "AchieveHeadDist")
    assert on.args == {"heading": ast.Number(10, "deg"), "distance": ast.Number(2, "m")}
    assert off.args == {}
    assert checked.diagnostics == []


def test_a_per_call_timeout_and_named_arguments() -> None:
    checked = _check("MISSION {\n  GoTo(tolerance = 1 m, target = (0, 0, 0, 0), "
                     "timeout = 2 min)\n}\n")
    call = checked.mission.body
    assert isinstance(call, ast.Call)
    r = checked.resolved(call)
    assert r.timeout == ast.Number(2, "min")
    assert r.args["tolerance"] == ast.Number(1, "m")
    assert "timeout" not in r.args


def test_parameters_get_their_values_and_the_kind_of_their_use() -> None:
    checked = _check("PARAM d = 2 m;\nPARAM h;\nPARAM p = (0, 0, 1 m, 0);\n"
                     "MISSION {\n  AchieveHeadDist(h, d);\n  GoTo(p)\n}\n")
    assert checked.params == {"d": ast.Number(2, "m"), "p": ast.Point(
        (ast.Number(0), ast.Number(0), ast.Number(1, "m"), ast.Number(0)))}
    assert checked.param_kinds == {"d": "length", "h": "angle", "p": "point"}
    assert checked.unset == ["h"]
    assert [(d.severity, d.code, str(d.span)) for d in checked.diagnostics] == [
        ("warning", "unset-param", "m.mcl:5:19")]  # its first use


def test_a_parameter_passes_its_kind_on_to_the_one_it_names() -> None:
    checked = _check("PARAM a = 2 m;\nPARAM b = a;\nMISSION {\n  AchieveHeadDist(0 deg, b)\n}\n")
    assert checked.param_kinds == {"a": "length", "b": "length"}
    assert checked.diagnostics == []


def test_a_value_from_the_command_line_replaces_the_declared_one() -> None:
    checked = _check("PARAM d = 2 m;\nMISSION {\n  AchieveHeadDist(0 deg, d)\n}\n",
                     _param("d", "3 m"))
    assert checked.params["d"] == ast.Number(3, "m")


def test_a_point_missing_fields_gets_the_defaults_its_library_declares() -> None:
    library = tasklib.load_sources([Source("lib.tasks", (
        "behaviour Go drives x, y, z, yaw events reached;\n"
        "task Go(target: point(z = 2 m, yaw = 0 deg)) {\n"
        "  start: enable Go(x = target.x, y = target.y, z = target.z, yaw = target.yaw);\n"
        "  ok: Go.reached;\n  stop: disable Go;\n}\n"))])
    checked = _check("MISSION {\n  Go((1 m, 2 m))\n}\n", library=library)
    call = checked.mission.body
    assert isinstance(call, ast.Call)
    assert checked.resolved(call).args["target"] == ast.Point(
        (ast.Number(1, "m"), ast.Number(2, "m"), ast.Number(2, "m"), ast.Number(0, "deg")))


# -- every problem at its place --------------------------------------------------------------
@pytest.mark.parametrize("text,code,where", [
    ("MISSION {\n  Surfce()\n}", "unknown-task", "2:3"),
    ("MISSION {\n  try()\n}", "lower-case-keyword", "2:3"),
    ("MISSION {\n  GoTo()\n}", "bad-arguments", "2:3"),
    ("MISSION {\n  KeepHeadDist(enable)\n}", "bad-arguments", "2:3"),
    ("MISSION {\n  GoTo((0, 0, 0, 0), tolerance = 1 m, tolerance = 2 m)\n}",
     "duplicate-argument", "2:39"),
    ("MISSION {\n  GoTo((0, 0, 0, 0), target = (1, 1, 1, 1))\n}", "duplicate-argument", "2:22"),
    ("MISSION {\n  GoTo(tolerance = 1 m, (0, 0, 0, 0))\n}", "arg-order", "2:25"),
    ("MISSION {\n  GoTo(1 s)\n}", "bad-argument", "2:8"),
    ("MISSION {\n  AchieveHeadDist(1.5 m, 90 deg)\n}", "bad-argument", "2:19"),
    ("MISSION {\n  StartCamera(enable, timeout = 1 s)\n}", "bad-timeout", "2:23"),
    ("MISSION {\n  GoTo((0, 0, 0, 0), timeout = 3 m)\n}", "bad-argument", "2:32"),
    ("PARAM d = 1 m;\nPARAM d = 2 m;\nMISSION {\n  AchieveHeadDist(0 deg, d)\n}",
     "duplicate-param", "2:7"),
    ("PARAM enable = 1;\nMISSION {\n  Surface()\n}", "reserved-word", "1:7"),
    ("PARAM a = b;\nPARAM b = a;\nMISSION {\n  AchieveHeadDist(0 deg, a)\n}",
     "param-cycle", "1:7"),
    ("PARAM d = 90 deg;\nMISSION {\n  AchieveHeadDist(0 deg, d)\n}", "bad-param-value", "1:7"),
    ("PARAM h = 90 deg;\nMISSION {\n  AchieveHeadDist(h, 1 m);\n  GoTo(h)\n}",
     "bad-argument", "4:8"),
    ("MISSION {\n  Wait(-5 s)\n}", "negative-duration", "2:8"),
    ("PARAM t = -3 s;\nMISSION {\n  Wait(t)\n}", "negative-duration", "1:11"),
    ("MISSION {\n  Wait(1e308 h)\n}", "number-out-of-range", "2:8"),
    ("MISSION {\n  AchieveHeadDist(0 deg, -1 m)\n}", "value-out-of-range", "2:26"),
    ("MISSION {\n  GoTo((0, 0))\n}", "missing-field", "2:8"),
    ("MISSION {\n  Wait(1 s)\n} ON STOP {\n  StartCamera(enable); Surface()\n}",
     "stop-handler-latch", "4:3"),
    ("MISSION {\n  Wait(1 s)\n} ON STOP {\n  Surface(); KeepHeadDist(disable)\n}",
     "stop-handler-latch", "4:14"),
    ("MISSION {\n  Wait(1 s)\n} ON STOP {\n  Surfce()\n}", "unknown-task", "4:3"),
])
def test_each_error_at_its_place(text: str, code: str, where: str) -> None:
    with pytest.raises(MclError) as info:
        _check(text)
    first = info.value.errors[0]
    assert (first.code, str(first.span)) == (code, f"m.mcl:{where}")
    assert first.source_line == text.split("\n")[int(where.split(":")[0]) - 1]


def test_an_unknown_task_is_placed_on_its_name_with_a_suggestion() -> None:
    with pytest.raises(MclError) as info:
        _check("MISSION {\n  Surfce(1, 2)\n}\n")
    d = info.value.errors[0]
    assert d.span is not None and (d.span.col, d.span.end_col) == (3, 9)  # "Surfce" only
    assert d.hint == "did you mean Surface?"


def test_every_problem_is_reported_at_once_errors_first_in_source_order() -> None:
    text = ("PARAM unused = 1 m;\nMISSION {\n  Wait(-1 s);\n  Surfce();\n  GoTo()\n}\n")
    assert _problems(text) == [
        ("error", "negative-duration", "m.mcl:3:8"),
        ("error", "unknown-task", "m.mcl:4:3"),
        ("error", "bad-arguments", "m.mcl:5:3"),
        ("warning", "unused-param", "m.mcl:1:7"),
    ]


def test_warnings_do_not_stop_the_check() -> None:
    checked = _check("PARAM u = 1 m;\nMISSION {\n  AchieveHeadDist(0 deg, d)\n}\n")
    assert [(d.severity, d.code, str(d.span)) for d in checked.diagnostics] == [
        ("warning", "unused-param", "m.mcl:1:7"), ("warning", "unset-param", "m.mcl:3:26")]


def test_a_parameter_without_value_is_an_error_when_values_are_required() -> None:
    text = "MISSION {\n  AchieveHeadDist(0 deg, d)\n}\n"
    assert _problems(text) == [("warning", "unset-param", "m.mcl:2:26")]
    assert _problems(text, require_values=True) == [("error", "unset-param", "m.mcl:2:26")]
    assert _problems(text, _param("d", "1 m"), require_values=True) == []


def test_a_value_from_the_command_line_is_placed_in_its_own_origin() -> None:
    text = "MISSION {\n  AchieveHeadDist(0 deg, d)\n}\n"
    assert _problems(text, _param("d", "-3 m")) == [
        ("error", "value-out-of-range", "--param d=-3 m:1:3")]
    assert _problems(text, _param("e", "3 m")) == [
        ("error", "unknown-param", "--param e=3 m:1:1"),
        ("warning", "unset-param", "m.mcl:2:26")]


def test_a_value_checked_through_a_parameter_says_which_parameter() -> None:
    with pytest.raises(MclError) as info:
        _check("PARAM t = -3 s;\nMISSION {\n  Wait(t)\n}\n")
    assert info.value.errors[0].message == ("argument 'duration' of Wait: a duration cannot "
                                            "be negative, got -3 s (the value of parameter 't')")


def test_a_cycle_of_parameters_names_the_chain() -> None:
    with pytest.raises(MclError) as info:
        _check("PARAM a = b;\nPARAM b = c;\nPARAM c = a;\nMISSION {\n"
               "  AchieveHeadDist(0 deg, a)\n}\n")
    assert info.value.errors[0].message == "parameter 'a' refers to itself (a -> b -> c -> a)"
