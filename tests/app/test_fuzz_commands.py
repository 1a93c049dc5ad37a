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
  mutated (names with ``../``, links, devices, FIFOs, junk bytes) or whose own bytes are
  flipped or cut;
- the environment the commands read (``MCL_STATE_DIR``, ``MCL_CACHE_DIR``,
  ``XDG_CACHE_HOME``, ``MCL_MAVLINK_KEY``, ``MCL_ZENOH_PASSWORD``, ``MCL_DOCS_URI``): empty,
  huge, not UTF-8 (a surrogate escape, which is how Python holds such bytes);
- ``mcl vehicle`` and ``mcl monitor`` as real subprocesses on loopback, each on a port of
  its own and stopped at the end of its example, with hostile options and
  ``MCL_ZENOH_LEASE_MS`` (read once, when the module is imported: a subprocess is the only
  way to give it a value).

What the fuzz and the probing around it found is kept below it as plain tests (among them
named pipes nobody writes to or reads, given as any file a command reads or writes).

Everything but the last runs the command's ``main(argv)`` in process (tests/app/
test_bad_input.py's :func:`call`): a subprocess per example costs a second of start-up, and
the in-process fuzz runs a hundred examples in that time. The subprocesses run a few examples
each. Examples are derandomized, so CI sees the same ones.
"""

from __future__ import annotations

import io
import os
import re
import shutil
import signal
import tarfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import diagnostics
from aal.zenoh import MAX_LEASE_MS, MIN_LEASE_MS, lease_ms
from app import mcl, mclc, pnml_report
from petri.execution.runlog import GENESIS, chain
from tests.app.test_bad_input import (  # noqa: F401 - fuzz_folder is a fixture
    PARAMS, SMALL, Accepted, accepted, assert_clear, call, fuzz_folder, inside, mutated)
from tests.support import (
    BIN, REPO, budget, first_line, free_tcp_port, free_udp_port, started, subprocess_env)

FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow, HealthCheck.data_too_large])
FEW = settings(FUZZ, max_examples=6)
DOCUMENTED = {  # docs/EXIT.md, without 3 (an internal error)
    "replay": {0, 1, 2}, "mosaic": {0, 2}, "export": {0, 2}, "view": {0, 2},
    "fmt": {0, 1, 2}, "pnml_report": {0, 2, 4}, "check": {0, 1, 2, 4}, "run": {0, 1, 2, 4, 5},
    "vehicle": {0, 2}, "monitor": {0, 1, 2, 4},
}
HUGE_NUMBERS = ["9" * 5000, "1e400", "-1e400", "1" + "0" * 400, "NaN", "Infinity",
                "-0", "18446744073709551616", "1e-400", "0.1"]


def assert_one_line(command: str, argv: list[str], code: int, err: str,
                    also: tuple[str, ...] = ()) -> None:
    """The status is one ``command`` documents; on 2, one line naming the file or option
    (tests/app/test_bad_input.py's :func:`assert_clear`), or a name in ``also``, and no
    usage: the lines under it are indented (a mission's source line and its caret, a hint)."""
    assert code in DOCUMENTED[command], (argv, code, err)
    assert "Traceback" not in err and "internal error" not in err, (argv, err)
    if code != 2:
        return
    lines = [line for line in err.splitlines() if line.strip() and not line[0].isspace()]
    assert len(lines) == 1, (argv, err)
    # its line check is the same for every command, but knows mclc's and mcl's names only
    assert_clear("vehicle", [*argv, *also], code,
                 err.replace("python -m app.pnml_report:", "mclc:", 1))


def mutated_lines(draw: st.DrawFn, data: bytes) -> bytes:
    """A run log with one or two edits of its lines or bytes; half the time its digest chain
    recomputed afterwards, as a forger would."""
    lines = data.splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 2))):
        how = draw(st.sampled_from(["flip", "drop", "duplicate", "swap", "key", "repeat",
                                    "number", "cut"]))
        i = draw(st.integers(0, len(lines) - 1))
        line = lines[i]
        if how == "flip" and line:
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
    if draw(st.integers(0, 3)) == 0:  # the archive's own bytes: flipped, or cut
        data = bytearray(path.read_bytes())
        at = draw(st.integers(0, len(data) - 1))
        data[at] ^= 1 << draw(st.integers(0, 7))
        cut = draw(st.sampled_from([len(data), len(data) // 2, 10]))
        path.write_bytes(bytes(data[:cut]))
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


# -- mcl mosaic: a mutated images folder -------------------------------------------------------
@pytest.fixture(scope="module")
def images(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run's images folder: two images of the wall, exact navigation data."""
    pytest.importorskip("cv2")  # the mosaic's image library; its test module needs it too
    from tests.mosaic.test_mosaic_input import survey  # after the skip: it imports cv2

    return survey(tmp_path_factory.mktemp("survey") / "run.images", images=2)


@st.composite
def mosaic_argv(draw: st.DrawFn, seed: Path, folder: Path) -> list[str]:
    """The images folder copied to ``folder/run.images``, one of its files or an option
    mutated (or none)."""
    target = folder / "run.images"
    shutil.copytree(seed, target)
    broken = draw(st.sampled_from([None, "index.csv", "camera.json", "00001.png", "option"]))
    if broken in ("index.csv", "camera.json"):
        path = target / broken
        path.write_bytes(draw(mutated(path.read_text("utf-8"))).encode("utf-8", "replace"))
    elif broken == "00001.png":
        data = bytearray((target / broken).read_bytes())
        for _ in range(draw(st.integers(1, 4))):
            at = draw(st.integers(0, len(data) - 1))
            data[at] = draw(st.integers(0, 255))
        cut = draw(st.sampled_from([len(data), len(data) // 2, 33, 8, 0]))
        (target / broken).write_bytes(bytes(data[:cut]))
    argv = ["mosaic", str(draw(st.sampled_from([target, folder / "run.jsonl"]))),
            "--no-truth", "--out", str(folder / "out")]
    if broken == "option":
        argv += draw(st.sampled_from([["--scale", "0"], ["--scale", "nan"], ["--scale", "1e400"],
                                      ["--max-memory", "1KiB"], ["--max-memory", "9" * 400],
                                      ["--max-memory", "1.5MiB"], ["--out", "/dev/null/x"],
                                      ["--out", "/proc/version"], ["--out", ""]]))
    return argv


@pytest.mark.slow
@settings(FUZZ, max_examples=30)
@given(data=st.data())
def test_fuzz_mcl_mosaic_on_a_mutated_images_folder(images: Path, data: st.DataObject) -> None:
    with inside(images.parent) as folder:
        argv = data.draw(mosaic_argv(images, folder))
        code, _, err = call(mcl.main, argv)
        # a file of the images folder is named as such, the run log given or not
        assert_one_line("mosaic", argv, code, err, (str(folder / "run.images"),))
        event(f"exit {code}")


# -- the environment the commands read --------------------------------------------------------
ENV_VALUES = st.sampled_from([
    "", " ", "x" * 100_000, "\udcff\udcfe", "caf\udce9", "/dev/null", "/dev/full",
    "/proc/version", "/etc/passwd/x", "a\nb", "9" * 5000, "-1", "FOLDER/m.mcl", "FOLDER/none",
    "0" * 64, "ff" * 32])
ENV_COMMANDS = {  # the variable: the command lines that read it ({f}: the folder)
    "MCL_CACHE_DIR": [["check", "{f}/m.mcl"]],
    "XDG_CACHE_HOME": [["check", "{f}/m.mcl"]],
    "MCL_DOCS_URI": [["check", "{f}/m.mcl", "--format", "sarif"]],
    "MCL_MAVLINK_KEY": [["run", "{f}/m.mcl", "--vehicle", "mavlink:udpin:127.0.0.1:14550",
                         "--log", "{f}/run.jsonl"],
                        ["vehicle", "--mavlink", "udpout:127.0.0.1:14550"]],
    "MCL_ZENOH_PASSWORD": [["monitor", "--zenoh", "tcp/127.0.0.1:7447", "--user", "x"],
                           ["run", "{f}/m.mcl", "--vehicle", "zenoh:tcp/127.0.0.1:7447",
                            "--user", "x", "--log", "{f}/run.jsonl"]],
}


def assert_env_clear(command: str, argv: list[str], variable: str, code: int,
                     err: str) -> None:
    """As :func:`assert_one_line`, the line may also start with the variable's name."""
    assert_one_line(command, argv, code, err, (f"${variable}", variable))


@pytest.mark.slow
@settings(FUZZ, max_examples=60)
@given(variable=st.sampled_from(sorted(ENV_COMMANDS)), value=ENV_VALUES, data=st.data())
def test_fuzz_the_environment_the_commands_read(fuzz_folder: Path,  # noqa: F811
                                               variable: str, value: str,
                                               data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        (folder / "m.mcl").write_text(SMALL, "utf-8")
        argv = [a.format(f=folder) for a in data.draw(st.sampled_from(ENV_COMMANDS[variable]))]
        with mock.patch.dict(os.environ, {variable: value.replace("FOLDER", str(folder))}):
            code, _, err = call(mcl.main, argv)
        assert_env_clear(argv[0], argv, variable, code, err)
        event(f"{variable} exit {code}")


@pytest.mark.parametrize("value", ["\udcff\udcfe", "a\nb", " ", "x" * (2 << 20)])
def test_a_zenoh_password_in_the_environment_is_checked_as_a_file_s_is(value: str) -> None:
    # found by the fuzz: a password that is not UTF-8 reached Zenoh, whose refusal was a
    # traceback (exit 1); a two-line one was taken whole
    argv = ["monitor", "--zenoh", "tcp/127.0.0.1:7447", "--user", "x"]
    with mock.patch.dict(os.environ, {"MCL_ZENOH_PASSWORD": value}):
        code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert err.startswith("mcl monitor: error: $MCL_ZENOH_PASSWORD: "), err
    with mock.patch.dict(os.environ, {"MCL_ZENOH_PASSWORD": " secret "}):
        assert call(mcl.main, argv)[0] == 0  # the session would open: Accepted


def test_the_zenoh_lease_from_the_environment_stays_within_an_hour() -> None:
    # found by the fuzz: 4,000 digits reached Zenoh, which refused them as "--zenoh ...:
    # error: error parsing number: too large"; 10**20 ms was taken (no peer ever lost)
    assert lease_ms("9" * 4000) == MAX_LEASE_MS == lease_ms(str(10**20))
    assert lease_ms("5000") == 5000
    assert lease_ms("-5") == lease_ms("") == lease_ms(None) == lease_ms("x") == MIN_LEASE_MS
    assert lease_ms("9" * 5000) == lease_ms("\udcff") == MIN_LEASE_MS


# -- mcl vehicle and mcl monitor as real processes ---------------------------------------------
SPEEDS = st.sampled_from(["10", "1000", "0.001", "1e308", "nan", "-1", "x"])
PROCESS_ENV = {  # what the processes read when they start, and a hostile value of each
    "MCL_ZENOH_LEASE_MS": st.sampled_from(["", "-5", "9" * 4000, str(10**20), "\udcff",
                                           "5000"]),
    "MCL_STATE_DIR": st.sampled_from(["", "/proc/version", "/dev/full/x", "\udcff",
                                      "x" * 5000, "state"]),
    "MCL_MAVLINK_KEY": st.sampled_from(["", " ", "\udcff", "ab" * 32, "x" * 70_000]),
}


@st.composite
def process_argv(draw: st.DrawFn) -> tuple[list[str], dict[str, str]]:
    """``mcl vehicle`` (Zenoh or MAVLink, on a port of its own on loopback) or ``mcl
    monitor``, with a hostile option value or environment."""
    command = draw(st.sampled_from(["zenoh", "mavlink", "monitor"]))
    if command == "zenoh":
        argv = ["vehicle", "--zenoh", f"tcp/127.0.0.1:{free_tcp_port()}", "--speed",
                draw(SPEEDS), "--name", draw(st.sampled_from(["auv", "a/b", "", "x" * 70]))]
        names = ["MCL_ZENOH_LEASE_MS"]
    elif command == "mavlink":
        argv = ["vehicle", "--mavlink", f"udpout:127.0.0.1:{free_udp_port()}", "--speed",
                draw(SPEEDS), *draw(st.sampled_from([[], ["--signing-key", "key"],
                                                     ["--signing-key", "/dev/zero"],
                                                     ["--require-signing"]]))]
        names = ["MCL_STATE_DIR", "MCL_MAVLINK_KEY"]
    else:
        argv = ["monitor", "--zenoh", f"tcp/127.0.0.1:{free_tcp_port()}", "--timeout",
                draw(st.sampled_from(["0.5", "nan", "-1", "1e400"]))]
        names = ["MCL_ZENOH_LEASE_MS"]
    env = {name: draw(PROCESS_ENV[name]) for name in names if draw(st.booleans())}
    return argv, env


@pytest.mark.slow
@settings(FUZZ, max_examples=10)
@given(case=process_argv())
def test_fuzz_mcl_vehicle_and_monitor_as_processes(tmp_path: Path,
                                                   case: tuple[list[str], dict[str, str]]
                                                   ) -> None:
    # a real process, because the Zenoh lease is read once, when aal.zenoh is imported, and
    # the signing state is kept by the vehicle server the in-process fuzz replaces
    argv, env = case
    (tmp_path / "key").write_text("a passphrase\n", "utf-8")
    with started([str(BIN / "mcl"), *argv], ready=None, env={**subprocess_env(), **env},
                 cwd=tmp_path) as proc:
        line = first_line(proc, budget(3))  # "vehicle auv ready on ...", or nothing: refused
        if line and "ready" in line:  # accepted: it stops on Ctrl-C, with status 0
            proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=budget(3))
        err = proc.stderr.read() if proc.stderr else ""
    names = tuple(f"${name}" for name in env)
    if argv[0] == "monitor" and code == 4:  # no vehicle on that port: said in two lines
        assert "no vehicle" in err and "Traceback" not in err, err
    else:
        assert_one_line(argv[0], argv, code, err, names)
    event(f"{argv[0]} {argv[1]} exit {code}")


@pytest.mark.parametrize("value", ["\udcff\udcfe", "x" * 70_000])
def test_a_signing_key_in_the_environment_is_named_when_refused(value: str) -> None:
    # found by the fuzz: a key that is not UTF-8 was refused as "mcl vehicle: error: 'utf-8'
    # codec can't encode characters ...", naming nothing; 70,000 bytes were taken as a key
    argv = ["vehicle", "--mavlink", "udpout:127.0.0.1:14550"]
    with mock.patch.dict(os.environ, {"MCL_MAVLINK_KEY": value}):
        code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert err.startswith("mcl vehicle: error: $MCL_MAVLINK_KEY: "), err
    with mock.patch.dict(os.environ, {"MCL_MAVLINK_KEY": "a passphrase"}):
        assert call(mcl.main, argv)[0] == 0  # the vehicle would start: Accepted


def test_an_empty_mcap_path_is_named_as_given(fuzz_folder: Path) -> None:  # noqa: F811
    # found by the fuzz: Path("") is ".", so "--mcap ''" was refused as ".: error: ... is a
    # directory", naming a folder the user never gave
    argv = ["export", str(fuzz_folder / "seed.jsonl"), "--mcap", ""]
    code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert err.startswith("--mcap '': error: "), err


@pytest.mark.parametrize("main", [pnml_report.main, mclc.main])
def test_a_pnml_in_an_unknown_encoding_is_invalid_input(fuzz_folder: Path,  # noqa: F811
                                                        main: Callable[[list[str]], int]
                                                        ) -> None:
    # found by the fuzz: expat raised LookupError for encoding='tf-8': exit 3
    with inside(fuzz_folder) as folder:
        net = folder / "net.pnml"
        net.write_bytes((fuzz_folder / "seed.pnml").read_bytes().replace(
            b"encoding='utf-8'", b"encoding='tf-8'", 1))
        assert b"encoding='tf-8'" in net.read_bytes()
        code, _, err = call(main, [str(net)])
        assert code == 2, err
        assert err.startswith(f"{net}:1:1: error: invalid XML: unknown encoding: tf-8"), err


def test_a_rechained_log_without_a_field_its_kind_needs_is_not_exported(
        fuzz_folder: Path) -> None:  # noqa: F811
    # found by the fuzz: a 'fire' record without 'transition', the chain recomputed, passed
    # the verification and ended mcl export in a KeyError (exit 3); replay said not conformant
    with inside(fuzz_folder) as folder:
        log = folder / "edited.jsonl"
        log.write_bytes(rechained((fuzz_folder / "seed.jsonl").read_bytes().replace(
            b'"transition":', b'"x":', 1)))
        argv = ["export", str(log), "--mcap", str(folder / "out.mcap")]
        code, _, err = call(mcl.main, argv)
        assert code == 2, err
        assert re.match(rf"{re.escape(str(log))}:\d+:1: error: a 'fire' record needs "
                        r"'transition' \(str\), not None$", err.splitlines()[0]), err
        assert not (folder / "out.mcap").exists()


@pytest.fixture()
def fifo(tmp_path: Path) -> Iterator[Path]:
    """A named pipe nobody opens, the wait for a named pipe's first bytes cut to 0.2 s."""
    path = tmp_path / "fifo"
    os.mkfifo(path)
    (tmp_path / "m.mcl").write_text(SMALL, "utf-8")
    with mock.patch.object(diagnostics, "FIFO_WAIT", 0.2):
        yield path


@pytest.mark.parametrize("make", [
    lambda f: ["fmt", str(f)], lambda f: ["check", str(f)],
    lambda f: ["check", str(f.parent / "m.mcl"), "--params", str(f)],
    lambda f: ["replay", str(f.parent / "run.jsonl"), str(f)],
])
def test_a_named_pipe_nobody_writes_to_is_refused_not_waited_on(
        fifo: Path, make: Callable[[Path], list[str]]) -> None:
    # found by probing the commands' files: reading a FIFO without a writer hung for ever
    if make(fifo)[0] == "replay":
        code, _, err = call(mcl.main, ["run", str(fifo.parent / "m.mcl"), "--vehicle",
                                       "script:/dev/null", "--log",
                                       str(fifo.parent / "run.jsonl"), "--quiet"])
        assert code == 0, err
    argv = make(fifo)
    code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert err.startswith(f"{fifo}:1:1: error: cannot be read: a named pipe nobody wrote to "
                          "within 0.2 s"), err


@pytest.mark.parametrize("make", [
    lambda f: ["run", str(f.parent / "m.mcl"), "--vehicle", "script:/dev/null", "--log",
               str(f)],
    lambda f: ["check", str(f.parent / "m.mcl"), "--no-verify", "--net-json", str(f)],
])
def test_a_named_pipe_nobody_reads_is_refused_as_an_output(
        fifo: Path, make: Callable[[Path], list[str]]) -> None:
    # found by probing: opening a FIFO without a reader to write waited for ever, and a
    # SIGTERM then found the run log's writer waiting again
    argv = make(fifo)
    code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert err.startswith(f"{fifo}: error: cannot write it ("), err
    assert "a named pipe nobody reads" in err.splitlines()[0], err


@pytest.mark.parametrize("make", [
    lambda f: ["run", str(f.parent / "m.mcl"), "--vehicle", f"script:{f}", "--log",
               str(f.parent / "r.jsonl")],
    lambda f: ["vehicle", "--mavlink", "udpout:127.0.0.1:14550", "--signing-key", str(f)],
    lambda f: ["vehicle", "--zenoh", "tcp/127.0.0.1:7447", "--users", str(f)],
    lambda f: ["monitor", "--zenoh", "tcp/127.0.0.1:7447", "--user", "x", "--password-file",
               str(f)],
])
def test_a_named_pipe_nobody_writes_to_is_refused_as_any_file_a_command_reads(
        fifo: Path, make: Callable[[Path], list[str]]) -> None:
    # the scripted vehicle, a signing key, a user list, a password file hung the same way
    argv = make(fifo)
    code, _, err = call(mcl.main, argv)
    assert code == 2, err
    assert_one_line(argv[0], argv, code, err)
    assert "a named pipe nobody wrote to within 0.2 s" in err.splitlines()[0], err
