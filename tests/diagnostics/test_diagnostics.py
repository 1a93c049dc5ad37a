"""One error root (issue 13): every user-facing exception of the tree derives from
``diagnostics.MclError``, and each error of a file a user gives says where the problem is
(``file:line:col: error: message``, the line, a hint) when it has a place."""

from __future__ import annotations

import ast
import importlib
import inspect
import json
from pathlib import Path

import pytest

from diagnostics import Diagnostic, MclError, Source, Span, error
from tests.support import REPO
from tests.test_layers import LAYERS, module_files

# Exceptions that never reach a user: raised and caught inside the library, as control flow.
INTERNAL = {
    "petri.verification.symbolic.SymbolicLimit": "the symbolic search's time budget ran out: the caller "
                                    "falls back to the explicit search or reports the limit",
    "petri.verification.symbolic.NotOneSafe": "the net is not 1-safe: the caller falls back to the explicit "
                                 "search (or the report says the method does not apply)",
    "mcl.values.Unresolved": "a value that names a parameter not yet bound: the compiler and "
                             "the duration bounds catch it and go on symbolically",
    "app.streams.StdoutLost": "a write to standard output that failed: every command's "
                              "closed-pipe path ends it (quietly, or one line for a full disk)",
    "app.safe_exit.ReportCut": "a signal after mcl run's end record: it cuts the report short "
                               "and the exit status stays the end record's",
    "app.replay.Refused": "mcl replay's refusal of a log, caught in the command itself: one "
                          "line at the log's line, exit 1 or 2",
    "app.view.command.Refused": "mcl view's refusal of a log, caught in the command itself: "
                                "one line, exit 2",
    "mcl.analysis.fleet_replay.ReplayError": "a fleet counterexample the players cannot "
                                             "follow: a bug of the verifier, raised to the "
                                             "test that replays it, never to a user",
    "vehicle.sensors.image_worker.WorkerError": "the camera's worker failed (an OSError): "
                                                "mcl run's mosaic report tells it in one line "
                                                "('mosaic: not made: ...'), the mission runs on",
    "petri.execution.runlog._Refused": "a value json's reader must not take (a duplicate key, "
                                       "a number out of range), caught by the reader of the "
                                       "line and told as a LogError at its line",
}


def _modules() -> dict[str, Path]:
    return module_files(REPO, LAYERS)


def _exception_classes() -> dict[str, type[BaseException]]:
    """Every exception class defined in a first-party module, by its dotted name."""
    found: dict[str, type[BaseException]] = {}
    for name in sorted(_modules()):
        module = importlib.import_module(name)
        for attr, value in vars(module).items():
            if inspect.isclass(value) and issubclass(value, BaseException) \
                    and value.__module__ == name:
                found[f"{name}.{attr}"] = value
    return found


def test_every_user_facing_exception_derives_from_mcl_error() -> None:
    classes = _exception_classes()
    assert "diagnostics.MclError" in classes and "petri.formats.pnml.PnmlError" in classes
    stray = sorted(name for name, cls in classes.items()
                   if not issubclass(cls, MclError) and name not in INTERNAL)
    assert not stray, ("exceptions a user can see that do not derive from diagnostics.MclError "
                       f"(or are not listed in INTERNAL with a reason): {stray}")


def test_the_internal_list_is_not_stale() -> None:
    classes = _exception_classes()
    for name, reason in INTERNAL.items():
        assert name in classes, f"{name} is no longer defined: drop it from INTERNAL"
        assert not issubclass(classes[name], MclError), f"{name} is an MclError now"
        assert reason


def test_no_exception_class_hides_from_the_walk() -> None:
    """Exception classes defined inside functions or classes are not seen by importing the
    modules: there must be none (each is a class in its module, so the walk above sees it)."""
    known = {name.rpartition(".")[2] for name in _exception_classes()}
    hidden = []
    for path in _modules().values():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        top = {id(node) for node in tree.body}
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef) and id(node) not in top:
                bases = [ast.unparse(b).rpartition(".")[2] for b in node.bases]
                if any(b in known or b.endswith(("Error", "Exception", "Exit", "Interrupt"))
                       for b in bases):
                    hidden.append(f"{path.relative_to(REPO)}:{node.lineno}: {node.name}{bases}")
    assert not hidden, hidden


# -- the root's API ---------------------------------------------------------------------------

def test_a_plain_message_with_a_place_and_a_hint() -> None:
    exc = MclError("the thing is wrong", span=Span("f.mcl", 3, 7), hint="do this instead",
                   code="thing")
    assert exc.format() == "f.mcl:3:7: error: the thing is wrong\n  hint: do this instead"
    assert str(exc) == exc.format()
    assert exc.span == Span("f.mcl", 3, 7)
    assert exc.errors[0].code == "thing"


def test_a_plain_message_without_a_place_and_for_a_whole_file() -> None:
    assert MclError("no place").format() == "error: no place"
    assert MclError("gone", span=Span.of_file("x.toml")).format() == "x.toml: error: gone"
    assert MclError("gone").span is None


def test_historic_text_and_the_source_line() -> None:
    exc = MclError("bad", span=Span("f", 2, 3), source_line="ab cd", text="f:2: bad")
    assert str(exc) == "f:2: bad"
    assert exc.format() == "f:2:3: error: bad\n    ab cd\n      ^"


def test_diagnostics_as_before() -> None:
    source = Source("m.mcl", "a\nbb;\n")
    exc = error(source, "trailing", source.span(2, 3, 2, 4), "drop it", "trailing-semicolon")
    assert exc.format() == "m.mcl:2:3: error: trailing\n    bb;\n      ^\n  hint: drop it"
    both = MclError([Diagnostic("warning", "w"), Diagnostic("error", "e")])
    assert [d.message for d in both.errors] == ["e"]
    with pytest.raises(TypeError):
        MclError(Diagnostic("error", "e"), hint="a hint goes with a message")


# -- each error, from real bad input, says where ------------------------------------------------

def test_a_broken_pnml_file(tmp_path: Path) -> None:
    from petri.formats.pnml import PnmlError, read_pnml

    path = tmp_path / "broken.pnml"
    path.write_text('<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">\n'
                    '  <net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet">\n'
                    "    <place id='p'>\n  </net>\n</pnml>\n", encoding="utf-8")
    with pytest.raises(MclError) as info:
        read_pnml(path)
    assert isinstance(info.value, PnmlError)
    assert info.value.span == Span(str(path), 4, 5)
    assert info.value.format() == f"{path}:4:5: error: invalid XML: mismatched tag"
    with pytest.raises(MclError) as missing:
        read_pnml(tmp_path / "absent.pnml")
    assert missing.value.format() == f"{tmp_path / 'absent.pnml'}: error: no such file"


def _run_log(path: Path) -> None:
    from petri.execution.player import Record
    from petri.execution.runlog import RunLog

    with RunLog(path, {"mission": "m.mcl", "net": "0" * 16}) as log:
        log(Record(0.5, "fire", {"transition": "t0"}))
        log.end(1.0, "ok")


def test_a_truncated_run_log(tmp_path: Path) -> None:
    from petri.execution.runlog import LogError, read_log

    path = tmp_path / "run.jsonl"
    _run_log(path)
    text = path.read_text(encoding="utf-8")
    assert len(read_log(path)) == 3  # the log as written reads
    cut = text[:-10]  # the end record loses its tail
    path.write_text(cut, encoding="utf-8")
    with pytest.raises(LogError) as info:
        read_log(path)
    assert isinstance(info.value, MclError) and isinstance(info.value, ValueError)
    last = cut.split("\n")[-1]
    assert str(info.value) == f"{path}:3: the last record is cut off (the log is truncated)"
    assert info.value.format() == (f"{path}:3:{len(last) + 1}: error: the last record is cut "
                                   "off (the log is truncated)")


def test_a_run_log_record_that_is_not_json(tmp_path: Path) -> None:
    from petri.execution.runlog import LogError, read_log

    path = tmp_path / "run.jsonl"
    _run_log(path)
    lines = path.read_text(encoding="utf-8").split("\n")
    lines[1] = lines[1].replace(',"kind"', ',,"kind"', 1)
    path.write_text("\n".join(lines), encoding="utf-8")
    with pytest.raises(LogError) as info:
        read_log(path)
    col = lines[1].index(",,") + 2
    assert info.value.span == Span(str(path), 2, col)
    assert info.value.format().startswith(f"{path}:2:{col}: error: not a JSON record (")


def test_an_unreadable_run_log_names_the_file(tmp_path: Path) -> None:
    from petri.execution.runlog import LogError, read_log

    with pytest.raises(LogError) as info:
        read_log(tmp_path)
    assert info.value.line is None
    assert info.value.format() == f"{tmp_path}: error: is a directory, not a run log"


def test_a_bad_toml_script(tmp_path: Path) -> None:
    from vehicle.scripted import ScriptError, load_script

    path = tmp_path / "v.toml"
    path.write_text('tasks = ["ictineu"]\n[behaviours.GoTo]\n'
                    'on_enable = { after = , event = "reached" }\n', encoding="utf-8")
    with pytest.raises(ScriptError) as info:
        load_script(str(path))
    assert isinstance(info.value, MclError)
    assert str(info.value).startswith(f"{path}: not valid TOML: ")  # as before
    first, quoted, caret, hint = info.value.format().split("\n")
    assert first == f"{path}:3:23: error: not valid TOML: Invalid value"
    assert quoted == '    on_enable = { after = , event = "reached" }'
    assert caret.index("^") == quoted.index(", event")  # column 23: the comma
    assert hint.startswith("  hint: ")


def test_a_bad_value_in_a_valid_toml_script(tmp_path: Path) -> None:
    from vehicle.scripted import ScriptError, load_script

    path = tmp_path / "v.toml"
    path.write_text('[[at]]\ntime = 1\nevent = "Alarms.leak"\n\n[[at]]\n  time = -2\n'
                    'event = "Alarms.leak"\n', encoding="utf-8")
    with pytest.raises(ScriptError) as info:
        load_script(str(path))
    assert str(info.value) == f"{path}: at[1].time: must be a number of seconds >= 0, got -2"
    assert info.value.format().split("\n")[0] == (
        f"{path}:6:3: error: at[1].time: must be a number of seconds >= 0, got -2")


def test_a_script_naming_an_undeclared_behaviour(tmp_path: Path) -> None:
    from vehicle.scripted import ScriptError, check_script, load_script

    path = tmp_path / "v.toml"
    path.write_text('tasks = ["ictineu"]\n\n[behaviours.Hover]\n'
                    'on_enable = { after = 1, event = "done" }\n', encoding="utf-8")
    script = load_script(str(path))
    with pytest.raises(ScriptError) as info:
        check_script(script, {"GoTo": ["reached"]})
    assert info.value.place == (str(path), 3, 1)
    lines = info.value.format().split("\n")
    assert lines[0] == (f"{path}:3:1: error: behaviour 'Hover' is not declared by this "
                        "vehicle's task libraries (ictineu)")
    assert lines[1:3] == ["    [behaviours.Hover]", "    ^"]
    assert lines[3].startswith("  hint: declared behaviours: GoTo")


def test_a_bad_signing_key_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from aal.signing import SigningError, load_key

    key = tmp_path / "key"
    key.write_text("  \n", encoding="utf-8")
    with pytest.raises(SigningError) as info:
        load_key(str(key))
    assert isinstance(info.value, MclError) and isinstance(info.value, ValueError)
    assert str(info.value) == f"{key}: the signing key is empty"
    first, hint = info.value.format().split("\n")
    assert first == f"{key}: error: the signing key is empty"
    assert "64 hexadecimal digits" in hint
    monkeypatch.setenv("MCL_MAVLINK_KEY", "")
    with pytest.raises(SigningError) as env:
        load_key(None)
    assert env.value.span == Span.of_file("$MCL_MAVLINK_KEY")


@pytest.mark.parametrize(("text", "place", "message"), [
    ('{"v": 1, "seq": 1,, "t": 0}', "<message>:1:19", "not JSON: Expecting property name"),
    ('{"v": 1, "seq": -3, "t": 0.5, "source": "GoTo", "name": "reached", "data": {}}',
     "<message>:1:10", "field 'seq' is negative"),
    ('{"v": 1,\n "seq": 2, "t": 0.5, "source": "GoTo", "name": 7, "data": {}}',
     "<message>:2:40", "field 'name' has the wrong type (int)"),
    ('{"v": 2, "seq": 2}', "<message>:1:2", "schema version 2, expected 1"),
])
def test_an_invalid_message(text: str, place: str, message: str) -> None:
    from aal.messages import EventMessage, InvalidMessage

    with pytest.raises(InvalidMessage) as info:
        EventMessage.from_json(text)
    assert isinstance(info.value, MclError) and isinstance(info.value, ValueError)
    assert info.value.format().startswith(f"{place}: error: {message}")
    assert str(info.value).startswith(message)  # receivers log str(): unchanged
    where = str(info.value.span).split(":")
    line, col = int(where[1]), int(where[2])
    assert text.split("\n")[line - 1][col - 1] in '",'  # it points at the field (or the fault)


def test_a_folder_without_images(tmp_path: Path) -> None:
    from mosaic.images import SurveyError, find, read

    with pytest.raises(SurveyError) as info:
        read(tmp_path)
    assert isinstance(info.value, MclError)
    assert str(info.value) == f"{tmp_path}: not a run's images (camera.json and index.csv missing)"
    assert info.value.format() == (f"{tmp_path}: error: not a run's images (camera.json and "
                                   "index.csv missing)")
    log = tmp_path / "run.jsonl"
    log.write_text("", encoding="utf-8")
    with pytest.raises(SurveyError) as beside:
        find(log)
    assert beside.value.span == Span.of_file(str(log))


def test_a_bad_index_line_of_a_run_s_images(tmp_path: Path) -> None:
    from mosaic.images import SurveyError, read

    (tmp_path / "camera.json").write_text(json.dumps(
        {"intrinsics": {"fx": 100, "fy": 100, "cx": 50, "cy": 40, "width": 100, "height": 80}}),
        encoding="utf-8")
    (tmp_path / "index.csv").write_text("index,t,file,nav_x\n0,0.0,a.png,oops\n",
                                        encoding="utf-8")
    with pytest.raises(SurveyError) as info:
        read(tmp_path)
    index = tmp_path / "index.csv"
    assert str(info.value).startswith(f"{index}:2: error: bad index line (")
    assert info.value.format().startswith(f"{index}:2:1: error: bad index line (")
    (tmp_path / "camera.json").write_text('{"intrinsics": \n  [}', encoding="utf-8")
    with pytest.raises(SurveyError) as meta:
        read(tmp_path)
    assert meta.value.format().startswith(
        f"{tmp_path / 'camera.json'}:2:4: error: unreadable camera description (")
