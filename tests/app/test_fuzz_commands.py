"""A Hypothesis fuzz of the inputs of every command that tests/app/test_bad_input.py and
tests/app/test_hostile_input.py do not reach (issue 22, deliverable 5): bad input is exit 2
and one line, never a traceback, exit 3 nor a hang.

- ``mcl replay`` on run logs mutated line by line (a byte flipped, a line dropped, duplicated
  or swapped, a key renamed or repeated, a number made huge), half of them with the digest
  chain recomputed so that the mutation reaches the checks behind the chain;
- ``mcl mosaic`` on an images folder whose ``index.csv``, ``camera.json`` or an image is
  mutated, and hostile ``--scale``, ``--max-memory``, ``--out``;
- ``mcl export`` on mutated logs and hostile ``--mcap`` paths;
- ``mcl view`` on mutated logs and missions (the server it would start raises
  :class:`Accepted` instead: no server is left running);
- ``mcl fmt`` on mutated missions, ``--check`` and ``--diff``;
- ``python -m app.pnml_report`` on mutated PNML and on contest archives whose entries are
  mutated (names with ``../``, links, devices, FIFOs, junk bytes);
- the environment the commands read (``MCL_STATE_DIR``, ``MCL_CACHE_DIR``,
  ``XDG_CACHE_HOME``, ``MCL_MAVLINK_KEY``, ``MCL_ZENOH_PASSWORD``, ``MCL_DOCS_URI``): empty,
  huge, not UTF-8 (a surrogate escape, which is how Python holds such bytes);
- ``mcl vehicle`` and ``mcl monitor`` as real subprocesses on loopback, each on a port of
  its own and stopped at the end of its example, with hostile options and
  ``MCL_ZENOH_LEASE_MS`` (read once, when the module is imported: a subprocess is the only
  way to give it a value).

Everything but the last runs the command's ``main(argv)`` in process (tests/app/
test_bad_input.py's :func:`call`): a subprocess per example costs a second of start-up, and
the in-process fuzz runs a hundred examples in that time. The subprocesses run a few examples
each. Examples are derandomized, so CI sees the same ones.
"""

from __future__ import annotations

import io
import re
import signal
import tarfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from app import mcl, pnml_report
from petri.execution.runlog import GENESIS, chain
from tests.app.test_bad_input import (  # noqa: F401 - fuzz_folder is a fixture
    PARAMS, SMALL, Accepted, accepted, assert_clear, call, fuzz_folder, inside, mutated)
from tests.support import REPO

FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow, HealthCheck.data_too_large])
FEW = settings(FUZZ, max_examples=6)
DOCUMENTED = {  # docs/EXIT.md, without 3 (an internal error)
    "replay": {0, 1, 2}, "mosaic": {0, 2}, "export": {0, 2}, "view": {0, 2},
    "fmt": {0, 1, 2}, "pnml_report": {0, 2, 4}, "mclc": {0, 1, 2, 4}, "run": {0, 1, 2, 4, 5},
    "vehicle": {0, 2}, "monitor": {0, 1, 2, 4},
}
HUGE_NUMBERS = ["9" * 5000, "1e400", "-1e400", "1" + "0" * 400, "NaN", "Infinity",
                "-0", "18446744073709551616", "1e-400", "0.1"]


def assert_one_line(command: str, argv: list[str], code: int, err: str) -> None:
    """The status is one ``command`` documents; on 2, one line naming the file or option
    (tests/app/test_bad_input.py's :func:`assert_clear`) and no usage: the lines under it
    are indented (a mission's source line and its caret, a hint)."""
    assert code in DOCUMENTED[command], (argv, code, err)
    assert "Traceback" not in err and "internal error" not in err, (argv, err)
    if code != 2:
        return
    lines = [line for line in err.splitlines() if line.strip() and not line[0].isspace()]
    assert len(lines) == 1, (argv, err)
    # its line check is the same for every command, but knows mclc's and mcl's names only
    assert_clear("vehicle", argv, code, err.replace("python -m app.pnml_report:", "mclc:", 1))


def mutated_lines(draw: st.DrawFn, data: bytes) -> bytes:
    """A run log with one or two edits of its lines or bytes; half the time its digest chain
    recomputed afterwards, as a forger would."""
    lines = data.splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 2))):
        how = draw(st.sampled_from(["flip", "drop", "duplicate", "swap", "key", "repeat",
                                    "number", "cut"]))
        i = draw(st.integers(0, len(lines) - 1))
        line = lines[i]
        if how == "flip":
            at = draw(st.integers(0, len(line) - 1))
            line = line[:at] + bytes([line[at] ^ (1 << draw(st.integers(0, 7)))]) + \
                line[at + 1:]
        elif how == "drop" and len(lines) > 1:
            del lines[i]
            continue
        elif how == "duplicate":
            lines.insert(i, line)
            continue
        elif how == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
            continue
        elif how in ("key", "repeat"):
            keys = re.findall(rb'"(\w+)":', line)
            if keys:
                old = draw(st.sampled_from(keys))
                new = draw(st.sampled_from([b"kind", b"t", b"event", b"how", b"exit", b"x",
                                            b"", b"tasks", b"params", b"net", b"key"]))
                if how == "key":
                    line = line.replace(b'"%s":' % old, b'"%s":' % new, 1)
                else:  # the same key twice: a parser that keeps the last would be fooled
                    line = line.replace(b"{", b'{"%s":%s,' % (old, draw(st.sampled_from(
                        [b"1", b'"x"', b"null", b"[]", b'"Alarms.leak"']))), 1)
        elif how == "number":
            numbers = list(re.finditer(rb"(?<=[:\[,])-?\d+(\.\d+)?([eE][-+]?\d+)?", line))
            if numbers:
                m = draw(st.sampled_from(numbers))
                line = line[:m.start()] + draw(st.sampled_from(HUGE_NUMBERS)).encode() + \
                    line[m.end():]
        elif how == "cut":
            line = line[:draw(st.integers(0, len(line)))]
        lines[i] = line
    text = b"".join(lines)
    return rechained(text) if draw(st.booleans()) else text


def rechained(text: bytes) -> bytes:
    """``text`` with every line's digest recomputed over its bytes before the digest."""
    out, previous = [], GENESIS
    for line in text.splitlines(keepends=True):
        cut = line.find(b',"digest":"')
        end = line.find(b'"', cut + 11) if cut >= 0 else -1
        try:
            body = (line[:cut] + b"}").decode("ascii")
        except UnicodeDecodeError:
            cut = -1
        if cut < 0 or end < 0:
            out.append(line)
            continue
        previous = chain(previous, body)
        out.append(line[:cut + 11] + previous.encode() + line[end:])
    return b"".join(out)


# -- mcl replay, mcl export, mcl view: mutated run logs --------------------------------------
@st.composite
def log_argv(draw: st.DrawFn, folder: Path, command: str) -> list[str]:
    log = folder / "edited.jsonl"
    log.write_bytes(mutated_lines(draw, (folder / "seed.jsonl").read_bytes()))
    mission = str(folder / "seed.mcl")
    if command == "export":
        out = draw(st.sampled_from(["out.mcap", "", str(folder), "/dev/full", "/proc/version",
                                    "no/such/dir/x.mcap", str(log)]))
        return ["export", str(log), "--mcap", out]
    return [command, str(log), mission]


@contextmanager
def no_server() -> Iterator[None]:
    """``mcl view``'s server raises Accepted instead of serving (and no signal handler)."""
    from app.view import server

    with mock.patch.object(server, "ViewServer", accepted), \
            mock.patch.object(signal, "signal", lambda *_: None):
        yield


def fuzz_log_command(folder: Path, data: st.DataObject, command: str) -> int:
    for name in ("seed.jsonl", "seed.mcl"):
        (folder / name).write_bytes((fuzz_folder_path(folder) / name).read_bytes())
    argv = data.draw(log_argv(folder, command))
    with no_server():
        code, _, err = call(mcl.main, argv)
    assert_one_line(command, argv, code, err)
    event(f"exit {code}")
    return code


def fuzz_folder_path(folder: Path) -> Path:
    return folder.parent  # inside(fuzz_folder) makes a folder in it


@pytest.mark.slow
@settings(FUZZ, max_examples=150)
@given(data=st.data())
def test_fuzz_mcl_replay_on_logs_mutated_line_by_line(fuzz_folder: Path,  # noqa: F811
                                                      data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        fuzz_log_command(folder, data, "replay")


@pytest.mark.slow
@settings(FUZZ, max_examples=80)
@given(data=st.data())
def test_fuzz_mcl_export_on_mutated_logs(fuzz_folder: Path,  # noqa: F811
                                         data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        fuzz_log_command(folder, data, "export")


@pytest.mark.slow
@settings(FUZZ, max_examples=80)
@given(data=st.data())
def test_fuzz_mcl_view_on_mutated_logs(fuzz_folder: Path,  # noqa: F811
                                       data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        fuzz_log_command(folder, data, "view")


def test_the_log_fuzz_tells_a_good_log_from_a_bad_one(fuzz_folder: Path) -> None:  # noqa: F811
    """Not vacuous: the seed replays, a rechained edit still answers, a flipped byte does not
    conform."""
    seed = fuzz_folder / "seed.jsonl"
    assert rechained(seed.read_bytes()) == seed.read_bytes()
    argv = ["replay", str(seed), str(fuzz_folder / "seed.mcl")]
    assert call(mcl.main, argv)[0] == 0
    with inside(fuzz_folder) as folder:
        bad = folder / "bad.jsonl"
        bad.write_bytes(seed.read_bytes().replace(b'"kind":"fire"', b'"kind":"fira"', 1))
        code, _, err = call(mcl.main, ["replay", str(bad), str(fuzz_folder / "seed.mcl")])
        assert code in (1, 2), err
        with no_server():
            assert call(mcl.main, ["view", str(seed), str(fuzz_folder / "seed.mcl")])[0] == 0


# -- mcl fmt: mutated missions ----------------------------------------------------------------
DAM = (REPO / "missions" / "dam_inspection.mcl").read_text("utf-8")


@pytest.mark.slow
@settings(FUZZ, max_examples=100)
@given(data=st.data())
def test_fuzz_mcl_fmt_on_mutated_missions(tmp_path: Path, data: st.DataObject) -> None:
    mission = tmp_path / "m.mcl"
    text = data.draw(mutated(data.draw(st.sampled_from([SMALL, PARAMS, DAM]))))
    if data.draw(st.integers(0, 9)) == 0:
        mission.write_bytes(data.draw(st.binary(max_size=64)))
    else:
        mission.write_bytes(text.encode("utf-8", errors="surrogateescape"
                                        if data.draw(st.booleans()) else "replace"))
    argv = ["fmt", str(mission), *data.draw(st.sampled_from([[], ["--check"], ["--diff"],
                                                              ["--nope"], ["--check", "--diff"],
                                                              [str(tmp_path / "none.mcl")]]))]
    code, _, err = call(mcl.main, argv)
    assert_one_line("fmt", argv, code, err)
    event(f"exit {code}")


# -- python -m app.pnml_report: mutated PNML and archives -------------------------------------
@st.composite
def archive(draw: st.DrawFn, folder: Path, pnml: bytes) -> Path:
    """A contest archive ``MODEL/model.pnml``, its entry mutated or joined by a hostile one."""
    path = folder / "model.tgz"
    with tarfile.open(path, "w:gz") as tar:
        def add(name: str, kind: bytes = tarfile.REGTYPE, data: bytes = b"",
                link: str = "") -> None:
            info = tarfile.TarInfo(name)
            info.type, info.size, info.linkname = kind, len(data), link
            tar.addfile(info, io.BytesIO(data) if data else None)

        how = draw(st.sampled_from(["junk", "dotdot", "absolute", "symlink", "hardlink",
                                    "fifo", "device", "no model", "two models", "plain"]))
        body = draw(mutated(pnml.decode())).encode("utf-8", "replace") if how == "junk" else pnml
        name = {"dotdot": "../model.pnml", "absolute": "/tmp/M/model.pnml"}.get(
            how, "M/model.pnml")
        if how == "symlink":
            add("M/model.pnml", tarfile.SYMTYPE, link="/etc/passwd")
        elif how == "hardlink":
            add("M/model.pnml", tarfile.LNKTYPE, link="/etc/passwd")
        elif how == "fifo":
            add("M/model.pnml", tarfile.FIFOTYPE)
        elif how == "device":
            add("M/model.pnml", tarfile.CHRTYPE)
        elif how != "no model":
            add(name, data=body)
        if how == "two models":
            add("N/model.pnml", data=body)
    return path


@pytest.mark.slow
@settings(FUZZ, max_examples=100)
@given(data=st.data())
def test_fuzz_pnml_report_on_mutated_nets_and_archives(fuzz_folder: Path,  # noqa: F811
                                                       data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        pnml = (fuzz_folder / "seed.pnml").read_bytes()
        if data.draw(st.booleans()):
            model = folder / "net.pnml"
            model.write_bytes(data.draw(mutated(pnml.decode())).encode("utf-8", "replace"))
        else:
            model = data.draw(archive(folder, pnml))
        argv = [str(model), *data.draw(st.sampled_from(
            [[], ["--json"], ["--method", "symbolic"], ["--max-markings", "0"],
             ["--max-memory", "1e400"], ["--max-markings", "9" * 50]]))]
        code, _, err = call(pnml_report.main, argv)
        assert_one_line("pnml_report", argv, code, err)
        event(f"exit {code}")


# -- what the fuzz found, kept -----------------------------------------------------------------
@pytest.mark.parametrize("argv", [["fmt", "--nope", "x.mcl"], ["export", "x.jsonl"],
                                  ["view", "x.jsonl"], ["lsp", "--nope"]])
def test_an_option_mcl_fmt_export_view_or_lsp_cannot_parse_is_one_line(argv: list[str]) -> None:
    # argparse's own usage above the error made it three lines (found by the fmt fuzz)
    code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert not err.startswith("usage:"), err
    assert err.startswith(f"mcl {argv[0]}: error: "), err
    assert len([line for line in err.splitlines() if not line.startswith("  hint:")]) == 1, err


@pytest.mark.parametrize("character", ["\x85", "\x1b[2J", "\u2028", "\x0b", "\u202e"])
def test_a_mission_line_is_quoted_without_its_control_characters(tmp_path: Path,
                                                                 character: str) -> None:
    # U+0085 (NEL) in a mission was quoted as is: a terminal starts a new line at it (the
    # error was two lines), and an escape sequence would act on the terminal
    mission = tmp_path / "m.mcl"
    mission.write_text(character + SMALL, "utf-8")
    code, _, err = call(mcl.main, ["fmt", str(mission)])
    assert code == 2, err
    quoted = err.splitlines()[1]
    assert quoted.startswith("    \N{REPLACEMENT CHARACTER}"), err
    assert character[0] not in err, repr(err)
    assert err.splitlines()[2] == "    ^", err  # the caret under the character still
