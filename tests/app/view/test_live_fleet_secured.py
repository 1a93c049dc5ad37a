"""``mcl view FLEET.mcl --fleet-vehicle NAME=ENDPOINT ...`` against secured vehicles (``mcl
vehicle --users``, docs/ZENOH_SECURITY.md): with an observer's credentials the page follows
the fleet to its end, every vehicle's tree, the channel's messages and every vehicle's track
(its navigator's estimate); with a wrong password the view says so on one line and exits 2,
instead of waiting for a vehicle that is there."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.app.test_fleet_zenoh import (FLEET, finished, listening, player, players, secured,
                                        vehicle)
from tests.app.view.test_fleet import states_at
from tests.app.view.test_live_fleet import until_ended
from tests.support import REPO, budget, first_line, free_endpoint, stop, subprocess_env

pytest.importorskip("zenoh")
pytestmark = pytest.mark.slow  # vehicles, players and the view in processes over Zenoh


def view(fleet: Path, lead: str, follow: str, password: Path) -> subprocess.Popen[str]:
    """``mcl view`` following the fleet as the operator, with the password in ``password``."""
    return subprocess.Popen(
        [sys.executable, "-m", "app.mcl", "view", str(fleet), "--fleet-vehicle",
         f"leader={lead}", "--fleet-vehicle", f"follower={follow}", "--user", "operator",
         "--password-file", str(password)], cwd=REPO, env=subprocess_env(),
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_the_view_follows_a_secured_fleet_as_its_operator(tmp_path: Path) -> None:
    fleet = tmp_path / "pair.mcl"
    fleet.write_text(FLEET, encoding="utf-8")
    logs, lead, follow = tmp_path / "zenoh", free_endpoint(), free_endpoint()
    (lead_vehicle, lead_player), (follow_vehicle, follow_player) = (
        secured(fleet, "leader"), secured(fleet, "follower"))
    (tmp_path / "operator.pw").write_text("watch\n")
    with (vehicle(lead, "leader", *lead_vehicle),
          vehicle(follow, "follower", *follow_vehicle)):
        watching = view(fleet, lead, follow, tmp_path / "operator.pw")
        try:
            line = first_line(watching, budget(10))
            assert line and "fleet pair, live from 2 vehicles" in line, line
            url = re.search(r"http://\S+/", line).group(0)  # type: ignore[union-attr]
            follower = player(fleet, "follower", follow, logs, "--fleet-vehicle",
                              f"leader={lead}", *follow_player)
            listening(follower, logs / "follower.jsonl")
            leader = player(fleet, "leader", lead, logs, *lead_player)
            with players(follower, leader):
                code_f, _, err_f = finished(follower, budget(10))
                code_l, _, err_l = finished(leader, budget(5))
            assert (code_l, code_f) == (0, 0), err_l + err_f
            data = until_ended(url)
        finally:
            stop(watching)
    assert data["end"]["status"] == "ok", data["link"]
    assert "LOST" not in data["link"] and data["link"].count(": alive") == 2, data["link"]
    assert states_at(data, 1e9)["follower/task@17:21"] == "ok"
    assert [e["text"] for e in data["timeline"] if e["kind"] == "channel"] == [
        "channel orders: go sent by leader", "channel orders: done sent by leader"]
    for name in ("leader", "follower"):  # each vehicle's track, on mission time
        track = data["tracks"][name]
        assert len(track) > 5 and track[0][0] >= 0.0, name
        assert data["tracks_from"][name] == "the navigator's estimate"
    assert data["tracks"]["follower"][-1][1:3] == pytest.approx([-3.0, 2.0], abs=0.6)


def test_wrong_credentials_are_one_line_and_exit_2(tmp_path: Path) -> None:
    fleet = tmp_path / "pair.mcl"
    fleet.write_text(FLEET, encoding="utf-8")
    lead, follow = free_endpoint(), free_endpoint()
    (tmp_path / "wrong.pw").write_text("not-the-password\n")
    with (vehicle(lead, "leader", *secured(fleet, "leader")[0]),
          vehicle(follow, "follower", *secured(fleet, "follower")[0])):
        watching = view(fleet, lead, follow, tmp_path / "wrong.pw")
        try:
            code, out, err = finished(watching, budget(20))
        finally:
            stop(watching)
    assert code == 2, err
    assert "live from 2 vehicles" in out  # it served the page, then gave up
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert re.fullmatch(r"mcl view: error: the vehicle at tcp/127\.0\.0\.1:\d+ accepts "
                        r"connections but refused this observer's session: check --user "
                        r"and --password-file .*", lines[0]), lines[0]
