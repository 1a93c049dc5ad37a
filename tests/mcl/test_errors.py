"""The error table: each classic mistake, its message and its exact line:col.

Every row is a mission text, the problem's code, where it must be reported, and words the
message must contain. Through the API (fast) and, for a sample, through the real ``mclc``."""

from __future__ import annotations

from pathlib import Path

import pytest

from mcl.api import compile_source, parse_params
from diagnostics import MclError, Source
from tests.support import cli, write

DAM_HEAD = "MISSION {\n    StartLogs(enable);\n"

ERRORS = [
    # (text, code, line, col, words in the message)
    ("MISSION {\n    Surface();\n}\n", "trailing-semicolon", 2, 14, "';' before '}'"),
    ("MISSION {\n  TRY {\n    Surface()\n  CATCH {\n    Alarms()\n  } DO {\n    Surface()\n  }\n}\n",
     "missing-brace-before-catch", 4, 3, "'}' missing before CATCH"),
    ("MISSION {\n  try {\n    Surface()\n  } CATCH { Alarms() } DO { Surface() }\n}\n",
     "lower-case-keyword", 2, 3, "write TRY"),
    ("MISSION {\n  Surface();\n  if { Surface() } THEN { Surface() }\n}\n",
     "lower-case-keyword", 3, 3, "write IF"),
    ("MISSION {\n  Surfce()\n}\n", "unknown-task", 2, 3, "did you mean Surface?"),
    ("MISSION {\n  GoTo()\n}\n", "bad-arguments", 2, 3, "GoTo(target: point"),
    ("MISSION {\n  GoTo(1, 2)\n}\n", "bad-argument", 2, 8, "expected a point"),
    ("MISSION {\n  KeepHeadDist(enable)\n}\n", "bad-arguments", 2, 3, "KeepHeadDist"),
    ("MISSION {\n  AchieveHeadDist(1.5 m, 90 deg)\n}\n", "bad-argument", 2, 19, "expected a angle"),
    ("MISSION {\n  PARALLEL { Surface() } AND { Alarms() } OR { Surface() }\n}\n",
     "mixed-and-or", 2, 43, "AND and OR mixed"),
    ("MISSION {\n  Surface() Alarms()\n}\n", "missing-semicolon", 2, 12, "';' missing"),
    ("MISSION {\n}\n", "empty-block", 2, 1, "empty block"),
    ("PARAM h = 1;\n", "missing-mission", 1, 13, "no MISSION"),
    ("MISSION {\n  Surface()\n", "unclosed-block", 2, 12, "'}' is missing"),
    ("MISSION {\n  Wait(3 feet)\n}\n", "unknown-unit", 2, 10, "unknown unit 'feet'"),
    ("MISSION { /* never closed\n  Surface()\n}\n", "unclosed-comment", 1, 11, "never closed"),
    ("MISSION {\n  Surface() $\n}\n", "bad-character", 2, 13, "unexpected character '$'"),
    ("", "empty-file", 1, 1, "empty"),
    ("   \n// only a comment\n", "syntax", 0, 0, ""),  # comments only: see the test below
    ("PARAM d = 90 deg;\nMISSION {\n  AchieveHeadDist(0 deg, d)\n}\n", "bad-param-value", 1, 7,
     "used as a length"),
    ("PARAM d = 1 m;\nPARAM d = 2 m;\nMISSION {\n  AchieveHeadDist(0 deg, d)\n}\n",
     "duplicate-param", 2, 7, "declared twice"),
    ("MISSION {\n  Surface(timeout = 2 min);\n  StartCamera(enable, timeout = 1 s)\n}\n",
     "bad-timeout", 3, 23, "ends at once"),
    ('USES "nowhere.tasks";\nMISSION {\n  Surface()\n}\n', "missing-library", 1, 6,
     "not found"),
    ("MISSION {\n  TRY { Surface() } CATCH { Alarms() DO { Surface() }\n}\n",
     "missing-brace-before-do", 2, 38, "'}' missing before DO"),
    ("MISSION {\n  TRY Surface()\n}\n", "missing-block-after", 2, 7, "block in braces"),
    ("MISSION {\n  Surface;\n  Alarms()\n}\n", "call-needs-parentheses", 2, 3, "parentheses"),
    ("MISSION { Surface() }\nMISSION { Alarms() }\n", "text-after-mission", 2, 1,
     "after the end of the mission"),
    # types that catch slips (more in tests/mcl/test_types.py)
    ("MISSION {\n  Wait(-5 s)\n}\n", "negative-duration", 2, 8, "cannot be negative"),
    ("MISSION {\n  Wait(1e308 h)\n}\n", "number-out-of-range", 2, 8, "not a finite number"),
    ("MISSION {\n  GoTo((0, 0))\n}\n", "missing-field", 2, 8, "z and yaw are missing"),
    ("MISSION {\n  AchieveHeadDist(0 deg, -1 m)\n}\n", "value-out-of-range", 2, 26,
     "must be >= 0 m"),
]


def _compile(text: str, name: str = "m.mcl") -> None:
    compile_source(Source(name, text))


@pytest.mark.parametrize("text,code,line,col,words",
                         [e for e in ERRORS if e[1] != "syntax"],
                         ids=[e[1] + f"@{e[2]}:{e[3]}" for e in ERRORS if e[1] != "syntax"])
def test_error_table(text: str, code: str, line: int, col: int, words: str,
                     tmp_path: Path) -> None:
    path = write(tmp_path, text)
    with pytest.raises(MclError) as info:
        from mcl.api import compile_file
        compile_file(str(path))
    first = info.value.errors[0]
    assert first.code == code, first.format()
    assert first.span is not None
    assert (first.span.line, first.span.col) == (line, col), first.format()
    assert words in first.message + " " + first.hint, first.format()
    text_out = first.format()
    assert text_out.startswith(f"{path}:{line}:{col}: error: ")


def test_comments_only_is_a_missing_mission(tmp_path: Path) -> None:
    path = write(tmp_path, "   \n// only a comment\n")
    with pytest.raises(MclError) as info:
        from mcl.api import compile_file
        compile_file(str(path))
    assert "unexpected end of file" in info.value.format() or \
        "no MISSION" in info.value.format()


def test_every_error_shows_the_source_line_and_a_caret(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n    Surface();\n}\n")
    proc = cli("mclc", str(path))
    assert proc.returncode == 2
    lines = proc.stderr.splitlines()
    assert lines[0] == f"{path}:2:14: error: ';' before '}}': in MCL ';' separates items, " \
                       "so the last item of a block has none"
    assert lines[1] == "        Surface();"
    assert lines[2].index("^") == len("        Surface()")
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("content,words", [
    (None, "no such file"),
    (b"\x00\x01\x02binary", "binary file"),
    (b"MISSION { \xff\xfe }", "not UTF-8"),
    (b"", "the file is empty"),
], ids=["missing", "binary", "not-utf8", "empty"])
def test_bad_files_exit_2_without_traceback(content: bytes | None, words: str,
                                            tmp_path: Path) -> None:
    path = tmp_path / "m.mcl"
    if content is not None:
        path.write_bytes(content)
    proc = cli("mclc", str(path))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith(f"{path}:1:1: error: "), proc.stderr
    assert words in proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_directory_is_refused(tmp_path: Path) -> None:
    proc = cli("mclc", str(tmp_path))
    assert proc.returncode == 2 and "is a directory" in proc.stderr


def test_absurd_nesting_is_refused_at_the_block(tmp_path: Path) -> None:
    body = "Surface()"
    for _ in range(5000):
        body = "WHILE { Surface() } DO { " + body + " }"
    text = "MISSION {\n" + body + "\n}\n"
    path = write(tmp_path, text)
    proc = cli("mclc", str(path))
    assert proc.returncode == 2, proc.stderr[-500:]
    assert "nested more than 100 deep" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_several_errors_are_all_reported(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n  Surfce();\n  GoTo(1)\n}\n")
    proc = cli("mclc", str(path))
    assert proc.returncode == 2
    assert f"{path}:2:3: error: unknown task 'Surfce'" in proc.stderr
    assert f"{path}:3:8: error: argument 'target' of GoTo: expected a point" in proc.stderr


def test_unknown_parameter_on_the_command_line(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n  AchieveHeadDist(h, d)\n}\n")
    proc = cli("mclc", str(path), "--param", "hh=3deg", "--no-verify")
    assert proc.returncode == 2
    assert "unknown parameter 'hh'" in proc.stderr and "did you mean h?" in proc.stderr


def test_parameter_values_from_the_command_line_are_checked(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n  AchieveHeadDist(h, d)\n}\n")
    bad = cli("mclc", str(path), "--param", "h=3 m", "--param", "d=2m", "--no-verify")
    assert bad.returncode == 2 and "parameter 'h' is used as a angle" in bad.stderr
    good = cli("mclc", str(path), "--param", "h=3 deg", "--param", "d=2m", "--no-verify")
    assert good.returncode == 0, good.stderr
    assert "has no value" not in good.stderr


def test_a_parameter_without_value_is_a_warning_when_checking(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n  AchieveHeadDist(h, 1 m)\n}\n")
    proc = cli("mclc", str(path), "--no-verify")
    assert proc.returncode == 0
    assert f"{path}:2:19: warning: parameter 'h' has no value" in proc.stderr


def test_parameter_file(tmp_path: Path) -> None:
    params = write(tmp_path, "// values\nh = 10 deg\nd = 1.5 m\n", "p.params")
    values = parse_params([], [str(params)])
    assert set(values) == {"h", "d"}
    bad = write(tmp_path, "h 10\n", "bad.params")
    with pytest.raises(MclError) as info:
        parse_params([], [str(bad)])
    assert info.value.errors[0].span is not None
    assert (info.value.errors[0].span.line, info.value.errors[0].span.col) == (1, 1)


# -- output files and endpoints (issue 12): one line naming the file or option, exit 2 --------
@pytest.mark.parametrize("option, target, words", [
    ("--dot", "out", "is a directory"),
    ("--pnml", "no/such/dir/x.pnml", "no folder 'no/such/dir'"),
    ("--net-json", "out", "is a directory"),
])
def test_an_output_that_cannot_be_written_is_invalid_input(tmp_path: Path, option: str,
                                                           target: str, words: str) -> None:
    (tmp_path / "out").mkdir()
    path = write(tmp_path, "MISSION {\n  Surface()\n}\n")
    proc = cli("mclc", str(path), option, target, "--no-verify", cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    first = proc.stderr.splitlines()[0]
    assert first.startswith(f"{target}: error: cannot write it ({option}): {words}"), first
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr


def test_a_zenoh_endpoint_that_is_not_one_is_invalid_input(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION {\n  Surface()\n}\n")
    for endpoint, words in (("garbage", "not an endpoint"), ("foo/127.0.0.1:1",
                                                             "unknown protocol 'foo'")):
        proc = cli("mcl", "run", str(path), "--vehicle", f"zenoh:{endpoint}",
                   "--log", str(tmp_path / "x.jsonl"))
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.startswith(f"--vehicle zenoh:{endpoint}: error: {words}"), \
            proc.stderr
        assert ".rs:" not in proc.stderr and "Traceback" not in proc.stderr
