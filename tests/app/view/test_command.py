"""``mcl view`` as a user runs it: the address on its first line, the page served, Ctrl-C
ends it with 0; bad input is one line and exit 2, never a traceback."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import urllib.request
from pathlib import Path

import pytest

from app import mcl
from tests.app.view.runs import DAM, dam_log
from tests.support import BIN, MISSIONS, REPO, budget, first_line, stop, subprocess_env


@pytest.fixture(scope="module")
def leak(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return dam_log(tmp_path_factory.mktemp("leak"))


def test_serves_until_interrupted(leak: Path) -> None:
    proc = subprocess.Popen([str(BIN / "mcl"), "view", str(leak), str(DAM)], cwd=REPO,
                            env=subprocess_env(), stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = first_line(proc, budget(10))
        assert line and line.startswith("mcl view: http://127.0.0.1:"), line
        url = re.search(r"http://\S+/", line).group(0)  # type: ignore[union-attr]
        with urllib.request.urlopen(url + "data.json", timeout=budget(2)) as reply:
            data = json.load(reply)
        assert data["mission"] == "dam_inspection" and data["end"]["status"] == "ok"
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=budget(2)) == 0
    finally:
        stop(proc)


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    code = mcl.main(["view", *args])
    captured = capsys.readouterr()
    return code, captured.out + captured.err


def test_bad_input_is_one_line(leak: Path, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    other = MISSIONS / "pipeline_inspection.mcl"
    code, said = run(capsys, str(leak), str(other))
    assert code == 2 and said.count("\n") == 1, said
    assert said.startswith(f"{leak}:1: error: not a run of {other}: ")
    code, said = run(capsys, str(tmp_path / "none.jsonl"), str(DAM))
    assert code == 2 and said.startswith(f"{tmp_path / 'none.jsonl'}:") and "Traceback" \
        not in said, said
    cut = tmp_path / "cut.jsonl"
    cut.write_text("".join(leak.read_text().splitlines(keepends=True)[:5]).replace(
        '"t":0.0', '"t":1.0', 1))
    code, said = run(capsys, str(cut), str(DAM))
    assert code == 2 and said.count("\n") == 1 and "error" in said, said
    code, said = run(capsys, str(leak), str(DAM), "--port", "70000")
    assert (code, said) == (2, "--port 70000: error: not a port (0 to 65535)\n")


def test_a_log_and_its_mission_or_a_vehicle_and_its_mission(
        leak: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for args in ([str(leak)], ["--zenoh", "tcp/127.0.0.1:7447", str(leak), str(DAM)]):
        with pytest.raises(SystemExit) as exited:
            mcl.main(["view", *args])
        assert exited.value.code == 2
        assert "error: give RUN.jsonl MISSION.mcl, or --zenoh ENDPOINT MISSION.mcl" in \
            capsys.readouterr().err
    code, said = run(capsys, "--zenoh", "nope", str(DAM))
    assert code == 2 and said.startswith("--zenoh nope: error: ") and said.count("\n") == 1
