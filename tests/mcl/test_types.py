"""Types that catch slips (issue 11.4): durations finite and never negative, numbers in the
ranges a task library declares, points with every field (or the library's defaults), degrees
of freedom and behaviours checked against what the library declares.

Each slip is pinned to its exact ``file:line:col``, code and message through the API, and the
main ones through a real ``mclc`` / ``mcl run`` subprocess (exit 2, source line, caret, hint).
Values given by ``PARAM``, ``--param`` and ``--params`` go through the same checks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mcl import tasklib
from mcl.api import compile_file, compile_source, parse_params
from diagnostics import MclError, Source
from tests.support import REPO, cli, write

# A user's library: declared degrees of freedom, a range, point field defaults.
DIVER = """\
dofs x, y, depth, yaw;
behaviour Dive drives depth, yaw events reached;
task Dive(to: length in [0 m, 300 m], where: point(z = 0 m, yaw = 0 deg) = (0, 0)) {
    start: enable Dive(to = to, x = where.x, y = where.y, z = where.z, yaw = where.yaw);
    ok:    Dive.reached;
    stop:  disable Dive;
}
"""

SLIPS = [
    # (mission, library or None (ictineu), code, line, col, message)
    ("MISSION {\n    Wait(-5 s)\n}\n", None, "negative-duration", 2, 10,
     "argument 'duration' of Wait: a duration cannot be negative, got -5 s"),
    ("MISSION {\n    Wait(1 s);\n    Wait(1e308 h)\n}\n", None, "number-out-of-range", 3, 10,
     "argument 'duration' of Wait: 1e+308 h is too large: it is not a finite number of "
     "seconds"),
    ("MISSION {\n    GoTo((0, 0))\n}\n", None, "missing-field", 2, 10,
     "argument 'target' of GoTo: the point (0, 0) has 2 fields: z and yaw are missing "
     "(a point here is (x, y, z, yaw))"),
    ("MISSION {\n    GoTo((0, 0, 1, 0), tolerance = -1 m)\n}\n", None, "value-out-of-range",
     2, 36, "argument 'tolerance' of GoTo: -1 m is out of range: it must be >= 0 m"),
    ("MISSION {\n    Surface(timeout = -2 min)\n}\n", None, "negative-duration", 2, 23,
     "timeout of Surface: a duration cannot be negative, got -2 min"),
    ("PARAM d = -1.5 m;\nMISSION {\n    AchieveHeadDist(0 deg, d)\n}\n", None,
     "value-out-of-range", 1, 11, "argument 'distance' of AchieveHeadDist: -1.5 m is out of "
     "range: it must be >= 0 m (the value of parameter 'd')"),
    ("PARAM p = (1, 2, 3);\nMISSION {\n    GoTo(p)\n}\n", None, "missing-field", 1, 11,
     "the point (1, 2, 3) has 3 fields: yaw is missing"),
    ("PARAM far = 1e308 km;\nMISSION {\n    GoTo((0, far, 1, 0))\n}\n", None,
     "number-out-of-range", 1, 13, "1e+308 km is too large: it is not a finite number of "
     "metres (the value of parameter 'far')"),
    ("MISSION {\n    Dive(301 m)\n}\n", DIVER, "value-out-of-range", 2, 10,
     "argument 'to' of Dive: 301 m is out of range: it must be in [0 m, 300 m]"),
    ("MISSION {\n    Dive(3 m, (1))\n}\n", DIVER, "syntax", 2, 17, "unexpected ')'"),
    ("MISSION {\n    Dive(3 m, [1])\n}\n", DIVER, "bad-argument", 2, 15, "expected a point"),
    ("MISSION {\n    Dive(3 m, (1, 2, 3, 4, 5))\n}\n", DIVER, "bad-argument", 2, 15,
     "expected a point (x, y, z, yaw) of 2 to 4 numbers, got a point of 5"),
]


def _first(text: str, library: str | None, tmp_path: Path) -> MclError:
    path = write(tmp_path, text)
    tasks = [str(write(tmp_path, library, "lib.tasks"))] if library else None
    with pytest.raises(MclError) as info:
        compile_file(str(path), tasks)
    return info.value


@pytest.mark.parametrize("text,library,code,line,col,message", SLIPS,
                         ids=[f"{s[2]}@{s[3]}:{s[4]}" for s in SLIPS])
def test_each_slip_is_refused_at_its_place(text: str, library: str | None, code: str,
                                           line: int, col: int, message: str,
                                           tmp_path: Path) -> None:
    first = _first(text, library, tmp_path).errors[0]
    assert first.code == code, first.format()
    assert first.span is not None
    assert (first.span.line, first.span.col) == (line, col), first.format()
    assert message in first.message, first.format()
    assert first.hint, first.format()
    assert first.source_line == text.split("\n")[line - 1]


@pytest.mark.parametrize("text,location,message,hint", [
    ("MISSION {\n    Wait(-5 s)\n}\n", "2:10",
     "error: argument 'duration' of Wait: a duration cannot be negative, got -5 s",
     "hint: a duration is a time from now: 0 s or more"),
    ("MISSION {\n    Wait(1e308 h)\n}\n", "2:10",
     "error: argument 'duration' of Wait: 1e+308 h is too large",
     "hint: numbers must be finite in metres, degrees and seconds"),
    ("MISSION {\n    GoTo((0, 0))\n}\n", "2:10",
     "error: argument 'target' of GoTo: the point (0, 0) has 2 fields: z and yaw are missing",
     "hint: write every field (x, y, z, yaw)"),
], ids=["negative", "infinite", "point"])
def test_mclc_refuses_each_slip_with_line_caret_and_hint(text: str, location: str,
                                                         message: str, hint: str,
                                                         tmp_path: Path) -> None:
    path = write(tmp_path, text)
    out = tmp_path / "net.json"
    proc = cli("mclc", str(path), "--no-verify", "--net-json", str(out))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert lines[0].startswith(f"{path}:{location}: {message}"), proc.stderr
    assert lines[1] == "    " + text.split("\n")[1]
    col = int(location.split(":")[1])
    assert lines[2].index("^") == 4 + col - 1
    assert lines[3].startswith("  " + hint), proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()  # nothing is written for a refused mission


def test_a_misspelt_degree_of_freedom_is_refused_with_the_closest_declared_one(
        tmp_path: Path) -> None:
    lib = write(tmp_path, DIVER.replace("drives depth, yaw", "drives depht, yaw"), "lib.tasks")
    mission = write(tmp_path, "MISSION {\n    Dive(3 m)\n}\n")
    proc = cli("mclc", str(mission), "--tasks", str(lib), "--no-verify")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.splitlines()
    assert lines[0] == (f"{lib}:2:23: error: behaviour Dive drives 'depht', which is not a "
                        "declared degree of freedom")
    assert lines[1] == "    behaviour Dive drives depht, yaw events reached;"
    assert lines[2] == "    " + " " * 22 + "^~~~~"
    assert lines[3] == "  hint: did you mean depth? the declared ones: x, y, depth, yaw"
    # the same through the API
    with pytest.raises(MclError) as info:
        tasklib.load([str(lib)])
    d = info.value.errors[0]
    assert (d.code, d.span and (d.span.line, d.span.col)) == ("library-dof", (2, 23))


def test_without_a_dofs_declaration_a_behaviour_drives_those_of_a_rigid_body() -> None:
    lib = tasklib.load_sources([Source("a.tasks", "behaviour Arm drives x, roll;\n")])
    assert lib.degrees_of_freedom == tasklib.DEFAULT_DOFS
    with pytest.raises(MclError) as info:
        tasklib.load_sources([Source("b.tasks", "behaviour Dive drives depht;\n")])
    d = info.value.errors[0]
    assert d.span is not None and (d.span.line, d.span.col) == (1, 23)
    assert d.hint == ("no library declares 'dofs NAME, ...;', so they are those of a rigid "
                      "body: x, y, z, roll, pitch, yaw")
    with pytest.raises(MclError) as twice:
        tasklib.load_sources([Source("c.tasks", "behaviour Dive drives z, z;\n")])
    assert twice.value.errors[0].message == "behaviour Dive drives 'z' twice"


def test_declarations_of_several_libraries_add_up_and_may_come_after_the_behaviours() -> None:
    lib = tasklib.load_sources([Source("a.tasks", "behaviour Arm drives grip;\ndofs grip;\n"),
                                Source("b.tasks", "dofs x;\nbehaviour Go drives x, grip;\n")])
    assert lib.degrees_of_freedom == ("grip", "x")


def test_the_shipped_libraries_declare_their_degrees_of_freedom() -> None:
    assert tasklib.load().declared_dofs == ["x", "y", "z", "yaw"]
    both = tasklib.load(["ictineu", str(REPO / "missions" / "seabed.tasks")])
    assert both.declared_dofs == ["x", "y", "z", "yaw"]
    assert all(set(b.dofs) <= {"x", "y", "z", "yaw"} for b in both.behaviours.values())
    assert {f.name: f.range.text for forms in both.tasks.values() for form in forms
            for f in form.formals if f.range} == {
        "tolerance": ">= 0 m", "distance": ">= 0 m", "altitude": ">= 0 m", "speed": ">= 0",
        "length": ">= 0 m", "width": ">= 0 m"}


def test_a_behaviour_named_in_a_task_must_be_declared_with_the_closest_match() -> None:
    text = "behaviour GoTo drives x events reached;\ntask Go() {\n    start: enable Gotoo;\n}\n"
    with pytest.raises(MclError) as info:
        tasklib.load_sources([Source("t.tasks", text)])
    d = info.value.errors[0]
    assert d.span is not None and (d.span.line, d.span.col) == (3, 12)
    assert d.message == "task Go: unknown behaviour 'Gotoo'"
    assert d.hint.startswith("did you mean GoTo?")
    text = "behaviour GoTo events reached;\ntask Go() {\n    ok: GoTo.reachd;\n}\n"
    with pytest.raises(MclError) as event:
        tasklib.load_sources([Source("t.tasks", text)])
    assert event.value.errors[0].hint.startswith("did you mean reached?")


def test_point_defaults_fill_the_fields_a_call_leaves_out(tmp_path: Path) -> None:
    lib = str(write(tmp_path, DIVER, "lib.tasks"))
    compiled = compile_source(Source("m.mcl", "MISSION {\n    Dive(3 m, (1, 2, 3))\n}\n"),
                              [lib])
    (action,) = [a for t in compiled.net.transitions for a in t.actions if a.kind == "enable"]
    assert dict(action.params) == {"to": 3.0, "x": 1.0, "y": 2.0, "z": 3.0, "yaw": 0.0}
    # through a parameter, and the library's own default (0, 0): z and yaw from the defaults
    for text in ("PARAM p = (1, 2);\nMISSION {\n    Dive(3 m, p)\n}\n",
                 "MISSION {\n    Dive(3 m)\n}\n"):
        compiled = compile_source(Source("m.mcl", text), [lib])
        (action,) = [a for t in compiled.net.transitions for a in t.actions
                     if a.kind == "enable"]
        assert dict(action.params)["z"] == 0.0 and dict(action.params)["yaw"] == 0.0
    # a field without a default is still required
    with pytest.raises(MclError) as info:
        compile_source(Source("m.mcl", "MISSION {\n    Dive(3 m, (1))\n}\n"), [lib])
    assert info.value.errors[0].code == "syntax"
    with pytest.raises(MclError) as info:
        compile_source(Source("m.mcl", "PARAM p = [1];\nMISSION {\n    Dive(3 m, p)\n}\n"),
                       [lib])
    assert info.value.errors[0].code == "bad-param-value"


@pytest.mark.parametrize("formal,at,words", [
    ("p: point(x = 1 m)", "x = 1 m", "only the last fields of a point can have defaults"),
    ("p: point(yaw = 2 m)", "2 m", "default of p.yaw: expected a angle"),
    ("p: point(w = 2)", "w = 2", "a point has no field 'w'"),
    ("p: length(yaw = 0)", "length", "only a point has field defaults"),
    ("p: point in [0, 1]", "in [0, 1]", "only a number, length, angle or duration has a range"),
    ("p: length in [2 m, 1 m]", "in [2 m", "range of 'p' is empty"),
    ("p: length in [0 s, 1 m]", "0 s", "range of 'p': expected a length, got a duration"),
    ("p: length in [0 m, 1e308 km]", "1e308", "is too large"),
    ("p: length >= 0 m = -1 m", "-1 m", "default of 'p': -1 m is out of range"),
    ("p: duration = -1 s", "-1 s", "default of 'p': a duration cannot be negative"),
    ("p: lenght", "lenght", "unknown kind 'lenght'"),
])
def test_ranges_and_point_defaults_are_checked_when_the_library_loads(
        formal: str, at: str, words: str) -> None:
    text = f"task Take({formal}) {{ }}\n"
    with pytest.raises(MclError) as info:
        tasklib.load_sources([Source("t.tasks", text)])
    d = info.value.errors[0]
    assert d.span is not None and (d.span.line, d.span.col) == (1, text.index(at) + 1), \
        d.format()
    assert words in d.message, d.format()
    assert d.source_line == text.rstrip("\n")


@pytest.mark.parametrize("literal,words", [("-5 s", "cannot be negative"),
                                           ("1e308 h", "too large")])
def test_a_library_timeout_is_a_finite_duration(literal: str, words: str) -> None:
    text = f"behaviour B events e;\ntask T() {{\n    ok: B.e;\n    timeout: {literal} -> fail;\n}}\n"
    with pytest.raises(MclError) as info:
        tasklib.load_sources([Source("t.tasks", text)])
    d = info.value.errors[0]
    assert d.span is not None and (d.span.line, d.span.col) == (4, 14)
    assert words in d.message


def test_parameters_from_the_command_line_and_files_are_checked_where_they_are_written(
        tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n    Wait(d);\n    GoTo(p)\n}\n")
    # through the API: --param
    with pytest.raises(MclError) as info:
        compile_file(str(path), None, parse_params(["d=-5s", "p=(0, 0, 1, 0)"]))
    d = info.value.errors[0]
    assert d.span is not None and (d.span.file, d.span.line, d.span.col) == (
        "--param d=-5s", 1, 3)
    assert d.message == ("argument 'duration' of Wait: a duration cannot be negative, got "
                         "-5 s (the value of parameter 'd')")
    # a parameter file: the line and column of the value in the file
    params = write(tmp_path, "// values\np = (0, 0, 1, 0)\n  d  =  1e308 h\n", "m.params")
    with pytest.raises(MclError) as info:
        compile_file(str(path), None, parse_params([], [str(params)]))
    d = info.value.errors[0]
    assert d.span is not None and (d.span.file, d.span.line, d.span.col) == (
        str(params), 3, 9)
    assert d.code == "number-out-of-range" and d.source_line == "  d  =  1e308 h"
    # the real mclc, and mcl run (which fills parameters left to run time)
    proc = cli("mclc", str(path), "--no-verify", "--param", "d=1 s", "--param", "p=(1, 2)")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines()[:3] == [
        "--param p=(1, 2):1:3: error: argument 'target' of GoTo: the point (1, 2) has 2 "
        "fields: z and yaw are missing (a point here is (x, y, z, yaw)) (the value of "
        "parameter 'p')",
        "    p=(1, 2)",
        "      ^~~~~~"]
    run = cli("mcl", "run", str(path), "--vehicle",
              f"script:{REPO / 'missions' / 'vehicles' / 'dam.toml'}", "--log",
              str(tmp_path / "run.jsonl"), "--param", "d=-5 s", "--param", "p=(0, 0, 1, 0)")
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("--param d=-5 s:1:3: error: argument 'duration' of Wait: "
                                 "a duration cannot be negative"), run.stderr
    assert "Traceback" not in run.stderr


def test_a_parameter_left_to_run_time_is_checked_when_it_gets_its_value(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n    Wait(d)\n}\n")
    checked = compile_file(str(path))  # only checking: no value yet, a warning
    assert [w.code for w in checked.warnings] == ["unset-param"]
    with pytest.raises(MclError) as info:
        compile_file(str(path), None, parse_params(["d=-1 ms"]), require_values=True)
    assert info.value.errors[0].code == "negative-duration"
    ok = compile_file(str(path), None, parse_params(["d=1 ms"]), require_values=True)
    assert [t.timer for t in ok.net.transitions if t.timer is not None] == [0.001]


def test_net_json_is_strict_json_for_the_largest_values_allowed(tmp_path: Path) -> None:
    big = "1e300 km"  # finite in metres: 1e303
    path = write(tmp_path, f"MISSION {{\n    GoTo(({big}, 0, 0, 1e300 rad));\n"
                           "    Wait(1e300 h)\n}\n")
    out = tmp_path / "net.json"
    proc = cli("mclc", str(path), "--no-verify", "--net-json", str(out))
    assert proc.returncode == 0, proc.stderr

    def refuse(name: str) -> None:
        raise AssertionError(f"{name} in --net-json")

    net = json.loads(out.read_text("utf-8"), parse_constant=refuse)
    assert net  # parsed strictly: no Infinity, -Infinity or NaN anywhere
