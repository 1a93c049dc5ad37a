"""Bad input everywhere gets one clear line and exit 2 (issue 12, point 4).

Two parts:

- the table: every case a new user met (output paths that are directories or in no folder,
  a PNML with a huge count, Zenoh endpoints that are not, ``--speed 0``, ``--max-time -5`` and
  ``nan``, a port 0, a log that is a directory, a closed standard output), each through the
  command's ``main(argv)`` in process, then a closed pipe through real subprocesses;
- the fuzz: Hypothesis drives every command (``mclc``, ``mcl run``, ``mcl replay``,
  ``mcl vehicle`` over Zenoh and MAVLink, ``mcl monitor``) in process with generated junk in
  every option and input file (MCL, task libraries, parameter files, TOML scripted vehicles,
  PNML, run logs, endpoints, URLs), mostly mutations of real files. The exit status is one the
  command documents and never 3 (internal error) nor an uncaught exception; for 2, stderr has
  no traceback and its error line starts with the file or the option it is about (after the
  command's name where a command says ``mcl vehicle: error: --mavlink ...``), or is argparse's
  own ``PROG: error: ...`` line for an option it cannot parse.

Nothing is really opened: a Zenoh or MAVLink link, a vehicle server or a monitor session that
the options would start raises :class:`Accepted` instead (the input was accepted), and signal
handlers are not installed in the test process.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any
from unittest import mock

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from app import mclc
from app import mcl
from tests.support import BIN, MISSIONS, REPO

SMALL = "MISSION {\n    StartLogs(enable);\n    Wait(2 s);\n    StartLogs(disable)\n}\n"
# the parameter file's names are the PARAMs of every mission below but SMALL (an error there)
PARAMS = "PARAM d = 1.5 m;\nPARAM h = 90 deg;\nMISSION {\n    AchieveHeadDist(h, d)\n}\n"
TOML = ('[behaviours.AchieveHeadDist]\non_enable = { after = 5.0, event = "achieved" }\n\n'
        '[[at]]\ntime = 1.0\nevent = "Alarms.leak"\n')
PARAM_FILE = "d = 2 m\nh = 45 deg\n"
TASKS = (REPO / "mcl" / "tasks" / "ictineu.tasks").read_text("utf-8")
DAM = (MISSIONS / "dam_inspection.mcl").read_text("utf-8")
SCALE = float(os.environ.get("MCL_PROPERTY_SCALE", "1"))
FUZZ = settings(max_examples=max(1, round(40 * SCALE)), deadline=None, derandomize=SCALE == 1,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
ALLOWED = {  # the exit statuses each command documents, but 3 (an internal error)
    "mclc": {0, 1, 2, 4}, "run": {0, 1, 2, 4, 5}, "replay": {0, 1, 2}, "vehicle": {0, 2},
    "monitor": {0, 2},
}


class Accepted(BaseException):  # noqa: N818 - not an error: the input was accepted
    """Raised where the command would open a link or start serving: the input was accepted.
    A BaseException, so that no ``except Exception`` of the command can swallow it."""


def accepted(*_: Any, **__: Any) -> Any:
    raise Accepted


@contextlib.contextmanager
def no_links() -> Iterator[None]:
    """Every place a command would open a link, serve or install signal handlers."""
    from vehicle.servers import ardusub
    from vehicle.servers import zenoh_server as serve
    from vehicle_adapters import zenoh_link
    from vehicle_adapters.mavlink import link as mavlink_link

    from app import monitor, monitor_fleet

    with mock.patch.object(zenoh_link.ZenohVehicle, "__enter__", accepted), \
            mock.patch.object(mavlink_link.MavlinkVehicle, "__enter__", accepted), \
            mock.patch.object(serve, "VehicleServer", accepted), \
            mock.patch.object(ardusub, "ArduSubVehicle", accepted), \
            mock.patch.object(monitor, "open_session", accepted), \
            mock.patch.object(monitor_fleet, "open_session", accepted), \
            mock.patch.object(signal, "signal", lambda *_: None):
        yield


def call(main: Callable[[list[str]], int], argv: list[str]) -> tuple[int, str, str]:
    """Run a command's main in process: (status, stdout, stderr); Accepted counts as 0."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), no_links():
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: --help, or an option it cannot parse
            code = exc.code if isinstance(exc.code, int) else 2
        except Accepted:
            code = 0
    return code, out.getvalue(), err.getvalue()


def named(argv: list[str]) -> list[str]:
    """What an error line may start with: a file or an option of the command line."""
    names = [a for a in argv if a.startswith("--")]
    for a in argv:
        if not a.startswith("--") and a:
            names.append(a)
            names.append(a.partition(":")[2])  # script:FILE, zenoh:ENDPOINT
    return [n for n in names if n]


def assert_clear(command: str, argv: list[str], code: int, err: str) -> None:
    assert code in ALLOWED[command], (argv, code, err)
    assert "Traceback" not in err and "internal error" not in err, (argv, err)
    if code != 2:
        return
    lines = [line for line in err.split("\n") if line.strip()]
    assert lines, (argv, "exit 2 without a word")
    if lines[0].startswith("usage:"):  # argparse's own refusal: its last line says why
        assert ": error: " in lines[-1], (argv, err)
        return
    parsed = re.match(r"^(mclc|mcl( \w+)?): error: (argument (\S+):|unrecognized arguments: "
                      r"(\S+)|the following arguments are required: )", lines[0])
    if parsed:  # argparse's own refusal in one line (app.arguments.Parser): names the option
        options = (parsed[4] or parsed[5] or "").split("/")  # as given, or abbreviated
        assert any(o.startswith(a) for o in options for a in argv if a.startswith("-")) or \
            parsed[3].startswith("the following"), (argv, err)
        assert len([line for line in lines if not line.startswith("  hint:")]) == 1, err
        return
    first = next((line for line in lines if "error" in line), lines[0])
    # "NAME: error: ...", or with the command first ("mcl vehicle: error: NAME ...")
    text = re.sub(r"^(mclc|mcl( \w+)?)?:? ?error: ", "", first)
    assert any(text.startswith(n) for n in named(argv)), (argv, first)


# -- the table: what a new user met -------------------------------------------------------------
@pytest.fixture()
def folder(tmp_path: Path) -> Path:
    (tmp_path / "x.mcl").write_text(SMALL, "utf-8")
    (tmp_path / "out").mkdir()
    (tmp_path / "empty.toml").write_text("", "utf-8")
    return tmp_path


def big_pnml(folder: Path) -> Path:
    net = folder / "x.pnml"
    code, _, err = call(mclc.main, [str(folder / "x.mcl"), "--no-verify", "--pnml", str(net)])
    assert code == 0, err
    text = net.read_text("utf-8")
    assert "<text>1</text>" in text
    net.write_text(text.replace("<text>1</text>", "<text>99999999999999999999999</text>", 1))
    return net


TABLE: dict[str, tuple[str, Callable[[Path], list[str]], str]] = {
    # case: (command, argv, what the line must start with: {f} is the folder)
    "mclc --dot DIR": ("mclc", lambda f: [f"{f}/x.mcl", "--dot", f"{f}/out"], "{f}/out: error"),
    "mclc --pnml no/such/dir": ("mclc", lambda f: [f"{f}/x.mcl", "--pnml",
                                                   f"{f}/no/such/dir/x.pnml"],
                                "{f}/no/such/dir/x.pnml: error"),
    "mclc --net-json ''": ("mclc", lambda f: [f"{f}/x.mcl", "--net-json", ""],
                            "--net-json '': error"),
    "mclc huge initialMarking": ("mclc", lambda f: [str(big_pnml(f))], "{f}/x.pnml:"),
    "mcl run --log DIR": ("run", lambda f: ["run", f"{f}/x.mcl", "--vehicle",
                                            f"script:{f}/empty.toml", "--log", f"{f}/out"],
                          "{f}/out: error"),
    "mcl replay DIR": ("replay", lambda f: ["replay", f"{f}/out", f"{f}/x.mcl"],
                       "{f}/out: error"),
    "mcl replay missing": ("replay", lambda f: ["replay", f"{f}/no.jsonl", f"{f}/x.mcl"],
                           "{f}/no.jsonl: error"),
    "zenoh:garbage": ("run", lambda f: ["run", f"{f}/x.mcl", "--vehicle", "zenoh:garbage",
                                        "--log", f"{f}/x.jsonl"], "--vehicle zenoh:garbage"),
    "zenoh:foo/127.0.0.1:1": ("run", lambda f: ["run", f"{f}/x.mcl", "--vehicle",
                                                "zenoh:foo/127.0.0.1:1", "--log",
                                                f"{f}/x.jsonl"], "--vehicle zenoh:foo"),
    "zenoh port 0 (run)": ("run", lambda f: ["run", f"{f}/x.mcl", "--vehicle",
                                             "zenoh:tcp/127.0.0.1:0", "--log", f"{f}/x.jsonl"],
                           "--vehicle zenoh:tcp/127.0.0.1:0"),
    "mcl vehicle --speed 0": ("vehicle", lambda f: ["vehicle", "--zenoh", "tcp/127.0.0.1:7447",
                                                    "--speed", "0"], "--speed 0: error"),
    "mcl vehicle --speed nan": ("vehicle", lambda f: ["vehicle", "--speed", "nan"],
                                "--speed nan: error"),
    "mcl vehicle --zenoh port 0": ("vehicle", lambda f: ["vehicle", "--zenoh",
                                                         "tcp/127.0.0.1:0"],
                                   "--zenoh tcp/127.0.0.1:0: error"),
    "mcl vehicle --name a/b": ("vehicle", lambda f: ["vehicle", "--name", "a/b"],
                               "--name a/b: error"),
    "mcl monitor --zenoh garbage": ("monitor", lambda f: ["monitor", "--zenoh", "garbage"],
                                    "--zenoh garbage: error"),
    "mcl monitor --timeout nan": ("monitor", lambda f: ["monitor", "--timeout", "nan"],
                                  "--timeout nan: error"),
    "--max-time -5": ("run", lambda f: ["run", f"{f}/x.mcl", "--max-time", "-5"],
                      "argparse"),
    "--max-time nan": ("run", lambda f: ["run", f"{f}/x.mcl", "--max-time", "nan"],
                       "argparse"),
}


@pytest.mark.parametrize("case", sorted(TABLE))
def test_each_case_a_new_user_met_is_one_clear_line_and_exit_2(case: str,
                                                                folder: Path) -> None:
    command, make, start = TABLE[case]
    argv = make(folder)
    code, _, err = call(mclc.main if command == "mclc" else mcl.main, argv)
    assert code == 2, (argv, code, err)
    assert_clear(command, argv, code, err)
    lines = [line for line in err.split("\n") if line.strip()]
    if start == "argparse":
        assert lines[-1].startswith("mcl run: error: argument --max-time:"), err
    else:
        assert lines[0].startswith(start.format(f=folder)), (lines[0], start)
        assert len([line for line in lines if not line.startswith("  hint:")]) == 1, err
    assert not any("/root/.cargo" in line or ".rs:" in line for line in lines), err


def test_zenoh_messages_lose_the_paths_of_the_machine_that_built_zenoh() -> None:
    import json

    import zenoh

    from aal.zenoh import zenoh_error

    config = zenoh.Config()
    with pytest.raises(zenoh.ZError) as caught:  # Zenoh's message names its source files
        config.insert_json5("connect/endpoints", json.dumps(["garbage"]))
    assert ".rs:" in str(caught.value), str(caught.value)
    text = zenoh_error(caught.value)
    assert "garbage" in text, text
    assert ".rs:" not in text and "/root/" not in text, text
    assert zenoh_error(RuntimeError("bad thing at /root/.cargo/x/y.rs:86.")) == "bad thing"


def test_a_closed_standard_output_ends_quietly_in_process(folder: Path) -> None:
    class Closed(io.StringIO):
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

    err = io.StringIO()
    with contextlib.redirect_stdout(Closed()), contextlib.redirect_stderr(err):
        code = mclc.main([f"{folder}/x.mcl", "--no-verify"])
    assert code == 0, err.getvalue()
    assert "Traceback" not in err.getvalue() and "internal error" not in err.getvalue()


@pytest.mark.parametrize("command", [
    ["mclc", "missions/dam_inspection.mcl"],
    ["mclc", "missions/dam_inspection.mcl", "--no-verify", "--format", "json"],
    ["mcl", "check", "missions/dam_inspection.mcl", "--format", "sarif"],
])
def test_a_writer_to_a_closed_pipe_exits_quietly(command: list[str]) -> None:
    # a real pipe whose reader has gone: `mclc ... | head -0`
    read, write = os.pipe()
    os.close(read)
    try:
        result = subprocess.run([str(BIN / command[0]), *command[1:]], stdout=write,
                                stderr=subprocess.PIPE, text=True, cwd=REPO, timeout=300)
    finally:
        os.close(write)
    assert result.returncode in (0, 1, 4), result.stderr
    assert "Traceback" not in result.stderr and "BrokenPipe" not in result.stderr, \
        result.stderr
    assert "internal error" not in result.stderr, result.stderr


# -- the fuzz: junk in every option and input file ----------------------------------------------
@st.composite
def mutated(draw: st.DrawFn, seed: str) -> str:
    """A real file's text with a few random edits (or, sometimes, random text)."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.text(max_size=200))
    text = seed
    for _ in range(draw(st.integers(1, 2))):
        at = draw(st.integers(0, len(text)))
        how = draw(st.sampled_from(["cut", "insert", "delete", "duplicate", "replace"]))
        if how == "cut":
            text = text[:at]
        elif how == "insert":
            text = text[:at] + draw(st.text(min_size=1, max_size=8)) + text[at:]
        elif how == "delete":
            text = text[:at] + text[at + draw(st.integers(1, 20)):]
        elif how == "duplicate":
            text = text[:at] + text[at:at + draw(st.integers(1, 40))] + text[at:]
        else:
            text = text[:at] + draw(st.sampled_from(
                list("{}();,=\"'[]#/\\\n\t 0-9.e") + ["nan", "1e999", "-", "99999999999999999999",
                                                    "\x00", "é", "MISSION", "TRY"])) + \
                text[at + 1:]
    return text


NUMBER_TEXT = st.one_of(st.sampled_from(["0", "-5", "nan", "inf", "-inf", "1e999", "1e-999",
                                         "", "x", "3", "0.5", "99999999999999999999"]),
                        st.text(max_size=6))
ENDPOINTS = st.one_of(
    st.text(max_size=30),
    st.builds(lambda proto, host, port: f"{proto}/{host}:{port}",
              st.sampled_from(["tcp", "tcp", "udp", "foo", "", "tls", "unixsock-stream", "TCP"]),
              st.sampled_from(["127.0.0.1", "127.0.0.1", "localhost", "", "[::1]", "::1", "a b",
                               "999.1.1.1", "x" * 300]),
              st.sampled_from(["7447", "7447", "1", "0", "65536", "-1", "", "x",
                               "99999999999"])))
URLS = st.one_of(
    st.text(max_size=30),
    st.builds(lambda scheme, host, port: f"{scheme}:{host}:{port}",
              st.sampled_from(["udpin", "udpout", "udp", "tcp", "tcpin", "serial", "file", "",
                               "udpbcast"]),
              st.sampled_from(["127.0.0.1", "localhost", "", "0.0.0.0", "a b", "/dev/null"]),
              st.sampled_from(["0", "1", "14550", "65536", "-1", "", "x"])))
PATHS = st.sampled_from(["FOLDER", "FOLDER/no/such/dir/x", "", "FOLDER/mission.mcl/x",
                         "FOLDER/new.out", "/proc/x/y"])


FILES = ("mission.mcl", "lib.tasks", "p.params", "v.toml")


def files(folder: Path, draw: st.DrawFn, broken: str | None) -> dict[str, str]:
    """Writes the input files, ``broken`` (or none) a mutation of the real one, so that each
    example reaches past the files it does not break; returns their paths."""
    out = {}
    for name, seed in (("mission.mcl", draw(st.sampled_from([SMALL, PARAMS, DAM]))),
                       ("lib.tasks", TASKS), ("p.params", PARAM_FILE), ("v.toml", TOML)):
        path = folder / name
        if name != broken:
            path.write_text(seed, "utf-8")
        elif draw(st.integers(0, 9)) == 0:
            path.write_bytes(draw(st.binary(max_size=64)))
        else:
            path.write_bytes(draw(mutated(seed)).encode("utf-8", errors="replace"))
        out[name] = str(path)
    return out


def path_option(folder: Path, draw: st.DrawFn) -> str:
    return draw(PATHS).replace("FOLDER", str(folder))


PARAM_TEXT = st.one_of(
    st.text(max_size=10),
    st.builds(lambda name, value: f"{name}={value}", st.sampled_from(["d", "h", "x", ""]),
              st.sampled_from(["2 m", "90 deg", "enable", "nan m", "1e999 m", "", "(1, 2)"])))


@st.composite
def mclc_argv(draw: st.DrawFn, folder: Path) -> list[str]:
    """One thing broken (a file, an option) or nothing, the rest valid."""
    broken = draw(st.sampled_from([None, *FILES[:3], "mission.mcl", "param", "output",
                                   "option"]))
    f = files(folder, draw, broken)
    argv = [f["mission.mcl"]]
    if draw(st.booleans()) or broken == "lib.tasks":
        argv += ["--tasks", f["lib.tasks"]]
    if draw(st.booleans()) or broken == "p.params":
        argv += ["--params", f["p.params"]]
    if broken == "param":
        argv += ["--param", draw(PARAM_TEXT)]
    for option in ("--dot", "--dot-tasks", "--pnml", "--net-json"):
        if draw(st.integers(0, 5)) == 0:
            argv += [option, path_option(folder, draw) if broken == "output" else
                     str(folder / f"out{option}")]
    argv += draw(st.sampled_from([[], ["--no-verify"], ["--method", "structural"],
                                  ["--format", "sarif"], ["--format", "junit"], ["--json"]]))
    if broken == "option":
        argv += draw(st.sampled_from([["--method", "nope"], ["--format"], ["--nope"], ["-"]]))
    return argv


@st.composite
def pnml_argv(draw: st.DrawFn, folder: Path) -> list[str]:
    seed = (folder / "seed.pnml").read_text("utf-8")
    path = folder / "net.pnml"
    path.write_bytes(draw(mutated(seed)).encode("utf-8", errors="replace"))
    return [str(path)] + draw(st.sampled_from([[], ["--format", "json"], ["--no-verify"]]))


@st.composite
def run_argv(draw: st.DrawFn, folder: Path) -> list[str]:
    """One thing broken (a file, the vehicle, an option) or nothing, the rest valid."""
    broken = draw(st.sampled_from([None, None, *FILES, "vehicle", "zenoh", "mavlink",
                                   "max-time", "seed", "param", "inject", "log", "option"]))
    f = files(folder, draw, broken)
    argv = ["run", f["mission.mcl"], "--log", str(folder / "run.jsonl"), "--quiet"]
    if broken == "zenoh":
        argv += ["--vehicle", f"zenoh:{draw(ENDPOINTS)}"]
    elif broken == "mavlink":
        argv += ["--vehicle", f"mavlink:{draw(URLS)}"]
    elif broken == "vehicle":
        argv += ["--vehicle", draw(st.one_of(st.text(max_size=12), st.sampled_from(
            ["script:", "sim:x", "script:" + str(folder), "zenoh", "mavlink:"])))]
    elif draw(st.integers(0, 4)) == 0:  # the simulated vehicle steps its physics: short
        argv += ["--vehicle", "sim", "--max-time", "30"]
    else:
        argv += ["--vehicle", f"script:{f['v.toml']}"]
    if broken == "max-time":
        argv += ["--max-time", draw(NUMBER_TEXT)]
    if draw(st.booleans()) or broken == "lib.tasks":
        argv += ["--tasks", f["lib.tasks"]]
    if draw(st.booleans()) or broken == "p.params":
        argv += ["--params", f["p.params"]]
    if broken == "param":
        argv += ["--param", draw(PARAM_TEXT)]
    if broken == "inject":
        argv += ["--inject", draw(st.sampled_from(["leak@600", "leak@", "x@1", "@", "leak@nan",
                                                   "leak@-1", ""]))]
    if broken == "seed":
        argv += ["--seed", draw(NUMBER_TEXT)]
    if broken == "log":
        i = argv.index("--log")
        argv[i + 1] = path_option(folder, draw)
    if broken == "option":
        argv += draw(st.sampled_from([["--user", "x"], ["--require-signing"], ["--scouting"],
                                      ["--signing-key", str(folder / "nokey")], ["--nope"],
                                      ["--tls-ca", str(folder)], ["--password-file", "x"]]))
    if draw(st.booleans()):
        argv += ["--no-verify"]
    return argv


@st.composite
def replay_argv(draw: st.DrawFn, folder: Path) -> list[str]:
    seed = (folder / "seed.jsonl").read_text("utf-8")
    path = folder / "edited.jsonl"
    path.write_bytes(draw(mutated(seed)).encode("utf-8", errors="replace"))
    mission = draw(st.sampled_from([str(folder / "seed.mcl"), str(folder / "missing.mcl"),
                                    str(folder)]))
    return ["replay", str(path), mission]


@st.composite
def vehicle_argv(draw: st.DrawFn) -> list[str]:
    """mcl vehicle over Zenoh or MAVLink: one option junk (or none), the rest valid."""
    zenoh = draw(st.booleans())
    broken = draw(st.sampled_from([None, "where", "name", "timeout", "speed", "inject",
                                   "log-level", "option"]))
    if zenoh:
        argv = ["vehicle", "--zenoh", draw(ENDPOINTS) if broken == "where" else
                "tcp/127.0.0.1:7447"]
        if broken == "name":
            argv += ["--name", draw(st.sampled_from(["", "a/b", "*", "x" * 70, "a b"]))]
    else:
        argv = ["vehicle", "--mavlink", draw(URLS) if broken == "where" else
                "udpout:127.0.0.1:14550"]
    if broken == "timeout":
        argv += ["--player-timeout" if zenoh else "--gcs-timeout", draw(NUMBER_TEXT)]
    argv += ["--speed", draw(NUMBER_TEXT) if broken == "speed" else "10"]
    if broken == "inject":
        argv += ["--inject", draw(st.sampled_from(["leak@", "x@1", "leak@nan", "@", "leak"]))]
    if broken == "log-level":
        argv += ["--log-level", draw(st.sampled_from(["nope", "", "debug", "5"]))]
    if broken == "option":
        argv += draw(st.sampled_from([["--nope"], ["--user"], ["--tls-ca", "/nonexistent"],
                                      ["--require-signing"], ["--seed", "x"]]))
    return argv


@st.composite
def monitor_argv(draw: st.DrawFn) -> list[str]:
    broken = draw(st.sampled_from([None, "where", "timeout", "name"]))
    argv = ["monitor", "--zenoh", draw(ENDPOINTS) if broken == "where" else
            "tcp/127.0.0.1:7447"]
    if broken == "timeout":
        argv += ["--timeout", draw(NUMBER_TEXT)]
    if broken == "name":
        argv += ["--name", draw(st.sampled_from(["", "a/b", "*", "x" * 70]))]
    return argv


@pytest.fixture(scope="module")
def fuzz_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A genuine PNML and a genuine run log, the seeds of their mutations."""
    from mcl.api import compile_file
    from petri.execution.player import Player
    from petri.formats.pnml import write_pnml
    from petri.execution.runlog import RunLog, net_digest
    from petri.execution.runner import run
    from vehicle_adapters.inprocess import InProcess
    from vehicle.scripted import ScriptedVehicle, load_script

    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "seed.mcl").write_text(PARAMS, "utf-8")
    (folder / "v.toml").write_text(TOML, "utf-8")
    compiled = compile_file(str(folder / "seed.mcl"))
    write_pnml(compiled.net, str(folder / "seed.pnml"))
    player = Player(compiled.net)
    with RunLog(folder / "seed.jsonl", {"mission": "m", "net": net_digest(compiled.net),
                                        "params": {}, "tasks": []}) as log:
        player.observers.append(log)
        outcome = run(player, InProcess(ScriptedVehicle(load_script(str(folder / "v.toml")))),
                      "m")
        log.end(outcome.time, outcome.status, outcome.reason)
    return folder


@contextlib.contextmanager
def inside(folder: Path) -> Iterator[Path]:
    """A fresh folder per example, made the current one (default outputs land there)."""
    before = os.getcwd()
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        os.chdir(tmp)
        try:
            yield Path(tmp)
        finally:
            os.chdir(before)


@FUZZ
@given(data=st.data())
def test_fuzz_mclc_on_missions_libraries_and_parameter_files(fuzz_folder: Path,
                                                             data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        argv = data.draw(mclc_argv(folder))
        code, _, err = call(mclc.main, argv)
        assert_clear("mclc", argv, code, err)
        event(f"exit {code}")


@FUZZ
@given(data=st.data())
def test_fuzz_mclc_on_pnml(fuzz_folder: Path, data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        (folder / "seed.pnml").write_bytes((fuzz_folder / "seed.pnml").read_bytes())
        argv = data.draw(pnml_argv(folder))
        code, _, err = call(mclc.main, argv)
        assert_clear("mclc", argv, code, err)
        event(f"exit {code}")


@pytest.mark.slow
@FUZZ
@given(data=st.data())
def test_fuzz_mcl_run(fuzz_folder: Path, data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        argv = data.draw(run_argv(folder))
        code, _, err = call(mcl.main, argv)
        assert_clear("run", argv, code, err)
        event(f"exit {code}")


@FUZZ
@given(data=st.data())
def test_fuzz_mcl_replay(fuzz_folder: Path, data: st.DataObject) -> None:
    with inside(fuzz_folder) as folder:
        for name in ("seed.jsonl", "seed.mcl"):
            (folder / name).write_bytes((fuzz_folder / name).read_bytes())
        argv = data.draw(replay_argv(folder))
        code, _, err = call(mcl.main, argv)
        assert_clear("replay", argv, code, err)
        event(f"exit {code}")


@FUZZ
@given(argv=st.one_of(vehicle_argv(), monitor_argv()))
def test_fuzz_mcl_vehicle_and_monitor(argv: list[str]) -> None:
    code, _, err = call(mcl.main, argv)
    assert_clear(argv[0], argv, code, err)
    event(f"{argv[0]} exit {code}")


def test_the_fuzz_reaches_every_outcome(fuzz_folder: Path) -> None:
    """The harness can tell accepted input from refused input (the fuzz is not vacuous)."""
    with inside(fuzz_folder) as folder:
        (folder / "m.mcl").write_text(SMALL, "utf-8")
        (folder / "v.toml").write_text("", "utf-8")
        ok = call(mcl.main, ["run", "m.mcl", "--vehicle", "script:v.toml", "--quiet"])
        assert ok[0] == 0, ok
        assert call(mcl.main, ["run", "m.mcl", "--vehicle", "zenoh:tcp/127.0.0.1:9"])[0] == 0
        assert call(mcl.main, ["vehicle", "--zenoh", "tcp/127.0.0.1:9"])[0] == 0
        bad = call(mcl.main, ["run", "m.mcl", "--vehicle", "zenoh:x"])
        assert bad[0] == 2 and bad[2].startswith("--vehicle zenoh:x: error"), bad
        with pytest.raises(AssertionError):  # a line that names nothing is caught
            assert_clear("run", ["run", "m.mcl"], 2, "something went wrong\n")
        with pytest.raises(AssertionError):
            assert_clear("run", ["run", "m.mcl"], 3, "m.mcl: internal error\n")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
