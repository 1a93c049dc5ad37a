"""Hostile input is exit 2 and one line, never a traceback nor a hang (issue 22, deliverable
5): a scripted vehicle whose ``data`` is not a table, TOML nested 100,000 deep, behaviour
names that look like regular expressions (``"Go(To"``, ``"(x+x+)+y"``: a name is never used
as a pattern), files read without a limit (``script:/dev/zero``), ``--seed -1``, ``--speed
1e308``, ``--signing-key /dev/zero``, ``--users /dev/zero``; then a Hypothesis fuzz of ``mcl run``'s options and of ``mclc``'s files with such
values.
"""

from __future__ import annotations

import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from app import mcl, mclc
from tests.app.test_bad_input import SMALL, assert_clear, call
from tests.support import BIN, REPO, budget, subprocess_env

GOTO = '[behaviours.GoTo]\non_enable = { after = 1, event = "reached"%s }\n'
HOSTILE_TOML = {  # name: (the file, what the error line says after "FILE:L:C: error: ")
    "data a string": (GOTO % ', data = "x"', "behaviours.GoTo.on_enable.data: must be a table"),
    "data a list": ('[[at]]\ntime = 1\nevent = "Alarms.leak"\ndata = [1, 2]\n',
                    "at[0].data: must be a table"),
    "nested 100,000 deep": ("x = " + "[" * 100_000 + "]" * 100_000 + "\n",
                            "not valid TOML: nested too deeply"),
    "a name that is a broken pattern": ('[behaviours."Go(To"]\non_enable = { event = "r" }\n',
                                        "behaviour 'Go(To' is not declared"),
}


def run_script(folder: Path, text: str) -> tuple[int, str]:
    (folder / "m.mcl").write_text(SMALL, "utf-8")
    (folder / "v.toml").write_text(text, "utf-8")
    argv = ["run", str(folder / "m.mcl"), "--vehicle", f"script:{folder / 'v.toml'}",
            "--log", str(folder / "run.jsonl"), "--quiet"]
    code, _, err = call(mcl.main, argv)
    assert_clear("run", argv, code, err)
    return code, err


@pytest.mark.parametrize("case", sorted(HOSTILE_TOML))
def test_a_hostile_scripted_vehicle_is_one_clear_line(tmp_path: Path, case: str) -> None:
    text, says = HOSTILE_TOML[case]
    code, err = run_script(tmp_path, text)
    assert code == 2, err
    assert says in err.splitlines()[0], err
    assert len([x for x in err.splitlines() if "error" in x]) == 1, err


def test_a_name_that_backtracks_exponentially_is_refused_at_once(tmp_path: Path) -> None:
    # used as a pattern, "(x+x+)+y" against a line of 40 x's never ends: a subprocess, so
    # that a hang fails the test instead of hanging the suite
    (tmp_path / "m.mcl").write_text(SMALL, "utf-8")
    (tmp_path / "v.toml").write_text('[behaviours."(x+x+)+y"]\non_enable = { event = "r" }\n'
                                     "# " + "x" * 40 + "\n", "utf-8")
    proc = subprocess.run([str(BIN / "mcl"), "run", str(tmp_path / "m.mcl"), "--vehicle",
                           f"script:{tmp_path / 'v.toml'}", "--log", str(tmp_path / "r.jsonl")],
                          cwd=REPO, env=subprocess_env(), capture_output=True, text=True,
                          timeout=budget(5))
    assert proc.returncode == 2, proc.stderr
    assert "behaviour '(x+x+)+y' is not declared" in proc.stderr.splitlines()[0], proc.stderr


ONE_LINERS: dict[str, tuple[Callable[[Path], list[str]], str]] = {
    # case: (argv, what the first line starts with; {f} is the folder)
    "script:/dev/zero": (lambda f: ["run", f"{f}/m.mcl", "--vehicle", "script:/dev/zero"],
                         "/dev/zero: error: is larger than 1,048,576 bytes"),
    "--seed -1": (lambda f: ["run", f"{f}/m.mcl", "--seed", "-1"],
                  "mcl run: error: argument --seed: '-1' is not a seed"),
    "vehicle --seed -1": (lambda f: ["vehicle", "--zenoh", "tcp/127.0.0.1:7447", "--seed",
                                     "-1"], "mcl vehicle: error: argument --seed: '-1'"),
    "zenoh --speed 1e308": (lambda f: ["vehicle", "--zenoh", "tcp/127.0.0.1:7447", "--speed",
                                       "1e308"], "--speed 1e+308: error: must be at most 1000"),
    "mavlink --speed 1e308": (lambda f: ["vehicle", "--mavlink", "udpout:127.0.0.1:14550",
                                         "--speed", "1e308"],
                              "mcl vehicle: error: --speed 1e+308: must be at most 1000"),
    "--signing-key /dev/zero": (lambda f: ["vehicle", "--mavlink", "udpout:127.0.0.1:14550",
                                           "--signing-key", "/dev/zero"],
                                "mcl vehicle: error: /dev/zero: larger than 65,536 bytes"),
    "run --signing-key /dev/zero": (lambda f: ["run", f"{f}/m.mcl", "--vehicle",
                                               "mavlink:udpin:127.0.0.1:14550",
                                               "--signing-key", "/dev/zero"],
                                    "/dev/zero: error: larger than 65,536 bytes"),
    "--users /dev/zero": (lambda f: ["vehicle", "--zenoh", "tcp/127.0.0.1:7447", "--users",
                                     "/dev/zero"],
                          "mcl vehicle: error: --users /dev/zero: larger than 1,048,576"),
}


@pytest.mark.parametrize("case", sorted(ONE_LINERS))
def test_each_hostile_option_is_exit_2(tmp_path: Path, case: str) -> None:
    (tmp_path / "m.mcl").write_text(SMALL, "utf-8")
    make, start = ONE_LINERS[case]
    argv = make(tmp_path)
    code, _, err = call(mcl.main, argv)
    assert code == 2, (argv, err)
    assert "Traceback" not in err, err
    errors = [x for x in err.splitlines() if "error" in x]
    assert len(errors) == 1 and errors[0].startswith(start.format(f=tmp_path)), err


# -- the fuzz -------------------------------------------------------------------------------
FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
DEVICES = ["/dev/zero", "/dev/full", "/dev/null", "/proc/version", "/proc/self/mem"]
SEEDS = st.one_of(st.integers(-2**70, 2**70).map(str),
                  st.sampled_from(["-1", "1e3", "0x10", "", " 7", "18446744073709551616"]))
TIMES = st.sampled_from(["1e400", "1e308", "-0", "nan", "inf", "0", "1e-400", "30", "x"])


@st.composite
def run_options(draw: st.DrawFn, folder: Path) -> list[str]:
    """``mcl run`` on a small mission, a scripted vehicle, and hostile option values."""
    vehicle = draw(st.sampled_from(["script:" + str(folder / "v.toml"), *[
        "script:" + d for d in DEVICES]]))
    argv = ["run", str(folder / "m.mcl"), "--vehicle", vehicle, "--quiet", "--log",
            draw(st.sampled_from([str(folder / "run.jsonl"), *DEVICES[:4]]))]
    for option, values in (("--seed", SEEDS), ("--max-time", TIMES),
                           ("--inject", TIMES.map(lambda t: f"leak@{t}"))):
        if draw(st.booleans()):
            argv += [option, draw(values)]
    return argv


@FUZZ
@given(data=st.data())
def test_fuzz_mcl_run_hostile_options(tmp_path: Path, data: st.DataObject) -> None:
    (tmp_path / "m.mcl").write_text(SMALL, "utf-8")
    (tmp_path / "v.toml").write_text("", "utf-8")
    argv = data.draw(run_options(tmp_path))
    code, _, err = call(mcl.main, argv)
    assert_clear("run", argv, code, err)
    event(f"exit {code}")


@FUZZ
@given(path=st.sampled_from(DEVICES), output=st.sampled_from([None, *DEVICES[:4]]),
       option=st.sampled_from(["--tasks", "--params", None]))
def test_fuzz_mclc_hostile_files(tmp_path: Path, path: str, output: str | None,
                                 option: str | None) -> None:
    (tmp_path / "m.mcl").write_text(SMALL, "utf-8")
    argv = [path] if option is None else [str(tmp_path / "m.mcl"), option, path]
    if output is not None:
        argv += ["--no-verify", "--net-json", output]
    code, _, err = call(mclc.main, argv)
    assert_clear("mclc", argv, code, err)
    event(f"exit {code}")
