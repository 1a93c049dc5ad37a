"""The VS Code extension (editors/vscode/): its manifest names what it ships, the test cases
of its grammars come from the parser's own lexer, and (where its Node packages are installed:
``make vscode-test``, which ``make vsix`` and CI run) the grammars pass them on every shipped
mission (fleets included) and task library, and on every word of a fleet, and fail a case
that expects a wrong colour."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.editors.grammar_cases import (library_scopes, mission_scopes, with_assertions,
                                         write_cases)
from tests.support import REPO

VSCODE = REPO / "editors" / "vscode"
RUNNER = VSCODE / "node_modules" / ".bin" / "vscode-tmgrammar-test"


def test_the_manifest_names_what_the_extension_ships() -> None:
    manifest = json.loads((VSCODE / "package.json").read_text("utf-8"))
    languages = {lang["id"]: lang for lang in manifest["contributes"]["languages"]}
    assert languages["mcl"]["extensions"] == [".mcl"]
    assert languages["mcl-tasks"]["extensions"] == [".tasks"]
    for grammar in manifest["contributes"]["grammars"]:
        data = json.loads((VSCODE / grammar["path"]).read_text("utf-8"))
        assert data["scopeName"] == grammar["scopeName"]
    for lang in languages.values():
        config = json.loads((VSCODE / lang["configuration"]).read_text("utf-8"))
        assert config["comments"] == {"lineComment": "//", "blockComment": ["/*", "*/"]}
        assert ["{", "}"] in config["brackets"]
    assert manifest["contributes"]["configuration"]["properties"]["mcl.server.command"][
        "default"] == ["mcl", "lsp"]
    assert manifest["devDependencies"]["@vscode/vsce"].startswith("3.")  # 4.x needs Node 22
    assert "vscode-languageclient/node" in (VSCODE / manifest["main"]).read_text("utf-8")
    assert "node_modules/" in (VSCODE / ".gitignore").read_text("utf-8").split()


def test_the_oracle_reads_a_mission_as_the_parser_does() -> None:
    text = 'USES "ictineu";\nPARAM p = 5 m;  // five\nMISSION m { GoTo(p, timeout = 1 min) }\n'
    got = [(t.value, scope) for t, scope in mission_scopes(text)]
    assert got == [
        ("USES", "keyword.other.mcl"), ('"ictineu"', "string.quoted.double.mcl"),
        ("PARAM", "keyword.other.mcl"), ("p", "variable.other.constant.mcl"),
        ("5", "constant.numeric.mcl"), ("m", "keyword.other.unit.mcl"),
        ("// five", "comment.line.double-slash.mcl"),
        ("MISSION", "keyword.other.mcl"), ("m", "entity.name.section.mcl"),
        ("GoTo", "entity.name.function.mcl"), ("p", "variable.other.mcl"),
        ("timeout", "variable.parameter.mcl"), ("1", "constant.numeric.mcl"),
        ("min", "keyword.other.unit.mcl")]


# every fleet word, three links, two receivers and a DELAY written without blanks round ".."
FLEET = """FLEET f {
    CHANNEL a FROM x TO y, z ACOUSTIC DELAY 1 s..4 s EVERY 2 s LOSSY MESSAGES go, stop;
    CHANNEL b FROM y TO x RADIO DELAY 0.5 s .. 1 s MESSAGES done;
    CHANNEL c FROM z TO x TETHER DELAY 0 s .. 0.1 s MESSAGES done;
    VEHICLE x { MISSION { Send(a, go); Receive(b, done, timeout = 1 min) } }
    VEHICLE y { MISSION { Receive(a, go, timeout = 1 min); Send(b, done) } }
    VEHICLE z { MISSION m { Receive(a, go, timeout = 1 min); Send(c, done) } ON STOP { Surface() } }
}
"""


def test_the_oracle_reads_a_fleet_as_the_parser_does() -> None:
    got = [(t.value, scope) for t, scope in mission_scopes(FLEET)]
    assert got[:14] == [
        ("FLEET", "keyword.other.fleet.mcl"), ("f", "entity.name.section.mcl"),
        ("CHANNEL", "keyword.other.fleet.mcl"), ("a", "variable.other.constant.mcl"),
        ("FROM", "keyword.other.fleet.mcl"), ("x", "variable.other.mcl"),
        ("TO", "keyword.other.fleet.mcl"), ("y", "variable.other.mcl"),
        ("z", "variable.other.mcl"), ("ACOUSTIC", "constant.language.link.mcl"),
        ("DELAY", "keyword.other.fleet.mcl"), ("1", "constant.numeric.mcl"),
        ("s", "keyword.other.unit.mcl"), ("4", "constant.numeric.mcl")]
    scopes = dict(got)
    for word in ("EVERY", "LOSSY", "MESSAGES", "VEHICLE"):
        assert scopes[word] == "keyword.other.fleet.mcl"
    assert scopes["RADIO"] == scopes["TETHER"] == "constant.language.link.mcl"
    assert scopes["Send"] == scopes["Receive"] == "entity.name.function.mcl"
    assert ("m", "entity.name.section.mcl") in got and ("go", "variable.other.mcl") in got


def test_the_oracle_reads_a_library_as_the_parser_does() -> None:
    text = "dofs z;\nbehaviour Dive drives z power 5 W;\ntask Dive() {\n    start: enable Dive;\n}\n"
    got = [(t.value, scope) for t, scope in library_scopes(text)]
    assert ("behaviour", "keyword.other.behaviour.mcl-tasks") in got
    assert ("Dive", "entity.name.type.mcl-tasks") in got
    assert ("Dive", "entity.name.function.mcl-tasks") in got
    assert ("start", "keyword.control.clause.mcl-tasks") in got
    assert ("5", "constant.numeric.mcl") in got and ("drives", "keyword.other.mcl-tasks") in got


def test_assertions_point_at_each_token() -> None:
    text = "MISSION {\n    Surface()\n}\n"
    case = with_assertions(text, "source.mcl", "t", mission_scopes(text))
    assert case.splitlines() == [
        '// SYNTAX TEST "source.mcl" "t"',
        "MISSION {",
        "// <------- keyword.other.mcl",
        "    Surface()",
        "//  ^^^^^^^ entity.name.function.mcl",
        "}",
    ]


def run_grammar_tests(folder: Path) -> subprocess.CompletedProcess[str]:
    if not RUNNER.exists() or shutil.which("node") is None:
        pytest.skip("the extension's Node packages are not installed: make vscode-test")
    return subprocess.run([str(RUNNER), "--config", "package.json", f"{folder}/*"],
                          cwd=VSCODE, capture_output=True, text=True, timeout=300)


def test_the_grammars_colour_the_shipped_files_as_the_parser_reads_them(tmp_path: Path) -> None:
    cases = write_cases(tmp_path)
    assert {c.suffix for c in cases} == {".mcl", ".tasks"}
    proc = run_grammar_tests(tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.count("run successfuly") == len(cases)


def test_the_shipped_cases_hold_a_fleet(tmp_path: Path) -> None:
    names = {c.name for c in write_cases(tmp_path)}
    assert "fleet_relay.mcl" in names and "dam_inspection.mcl" in names


def test_the_grammar_colours_every_fleet_word(tmp_path: Path) -> None:
    (tmp_path / "fleet.mcl").write_text(
        with_assertions(FLEET, "source.mcl", "fleet", mission_scopes(FLEET)), "utf-8")
    proc = run_grammar_tests(tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_a_wrong_colour_fails(tmp_path: Path) -> None:
    (tmp_path / "wrong.mcl").write_text(
        '// SYNTAX TEST "source.mcl" "wrong"\nMISSION {\n    Surface()\n'
        "//  ^^^^^^^ keyword.control.mcl\n}\n", "utf-8")
    proc = run_grammar_tests(tmp_path)
    assert proc.returncode != 0 and "missing required scopes" in proc.stdout
