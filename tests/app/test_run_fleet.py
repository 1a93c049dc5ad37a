"""``mcl run FLEET.mcl`` and ``mcl replay DIR FLEET.mcl`` (app/fleet_run.py,
app/fleet_replay.py): the fleet's timeline with each vehicle's name, each vehicle's end and
log, each channel's figures; the logs replay together; bad options are one line, exit 2."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from app import replay, run
from tests.support import MISSIONS, REPO, cli

PAIR = REPO / "examples" / "fleet" / "pair.mcl"


@pytest.mark.slow
def test_the_fleet_runs_from_the_command_line_and_its_logs_replay(tmp_path: Path) -> None:
    done = cli("mcl", "run", str(PAIR), "--log-dir", str(tmp_path), "--loss", "0.3",
               "--seed", "7")
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert re.search(r"^leader +0\.0 s  Send@\d+:\d+ +→ send orders\(message=go\)$", out, re.M)
    assert re.search(r"^follower +\d+\.\d s +← orders\.go$", out, re.M)
    assert "leader: mission lead ended OK" in out and "follower: mission follow ended OK" in out
    figures = re.search(r"channel orders \(leader -> follower\): sent (\d+), delivered (\d+), "
                        r"lost (\d+), dropped (\d+), undelivered (\d+); median delay", out)
    assert figures is not None
    sent, delivered, lost, dropped, undelivered = map(int, figures.groups())
    assert sent == 3 and delivered + lost + dropped + undelivered == 3
    assert {p.name for p in tmp_path.iterdir()} == {"leader.jsonl", "follower.jsonl",
                                                    "channels.jsonl"}
    checked = cli("mcl", "replay", str(tmp_path), str(PAIR))
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "fleet pair conforms" in checked.stdout


@pytest.mark.slow
def test_a_tampered_fleet_log_is_not_conformant(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    assert run.main([str(PAIR), "--log-dir", str(tmp_path), "--quiet", "--seed", "2"]) == 0
    log = tmp_path / "follower.jsonl"
    (tmp_path / "copy").mkdir()
    for name in ("leader.jsonl", "channels.jsonl"):
        (tmp_path / "copy" / name).write_bytes((tmp_path / name).read_bytes())
    (tmp_path / "copy" / "follower.jsonl").write_text(
        log.read_text("ascii").replace('"event":"orders.go"', '"event":"orders.no"', 1), "ascii")
    capsys.readouterr()
    assert replay.main([str(tmp_path), str(PAIR)]) == 0
    assert replay.main([str(tmp_path / "copy"), str(PAIR)]) == 1
    assert "follower.jsonl:" in capsys.readouterr().out


@pytest.mark.parametrize("args, says", [
    (["--loss", "1.5"], "the loss is a probability from 0 to 1"),
    (["--loss", "radio=0.3"], "fleet pair has no channel 'radio'"),
    (["--loss", "0.2", "--loss", "orders=0.3"], "give one or the other"),
    (["--log", "x.jsonl"], "a fleet writes one run log per vehicle"),
    (["--vehicle", "mavlink:udpin:127.0.0.1:14550"], "a fleet runs in one process"),
    (["--param", "x=1"], "not for a fleet"),
    (["--foxglove", "127.0.0.1:8765"], "not for a fleet yet"),
])
def test_a_bad_fleet_option_is_one_line_and_exit_2(
        args: list[str], says: str, capsys: pytest.CaptureFixture[str]) -> None:
    try:
        code = run.main([str(PAIR), *args])
    except SystemExit as exc:  # argparse's own refusal of an option's value
        code = int(str(exc.code))
    assert code == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err and len(err.strip().splitlines()) <= 3


def test_loss_on_a_single_mission_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert run.main([str(MISSIONS / "every_construct.mcl"), "--loss", "0.3"]) == 2
    assert "--loss: only for a fleet" in capsys.readouterr().err


def test_replay_of_a_fleet_needs_its_folder(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "leader.jsonl").write_text(json.dumps({"kind": "header"}) + "\n", "ascii")
    assert replay.main([str(tmp_path / "leader.jsonl"), str(PAIR)]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_a_log_dir_that_cannot_be_made_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("", "ascii")
    assert run.main([str(PAIR), "--log-dir", str(blocker / "logs")]) == 2
    err = capsys.readouterr().err
    assert "(--log-dir): cannot make its folder" in err and "Traceback" not in err
