"""``mcl monitor`` against secured vehicles (``mcl vehicle --users``, docs/ZENOH_SECURITY.md)
with a wrong password: one line saying the vehicle refused the observer's session, exit 2,
long before ``--timeout``, instead of "no vehicle" and exit 4. One vehicle (``--zenoh``), a
fleet (``--fleet-vehicle``), and a TLS certificate of another CA. With the right credentials
the monitor follows the mission to its end: tests/aal/test_zenoh_security.py (one vehicle)
and tests/app/test_fleet_zenoh.py (a fleet)."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.aal.test_zenoh_security import pki, tls_options, vehicle_process  # noqa: F401
from tests.app.test_fleet_zenoh import FLEET, finished, secured, vehicle
from tests.support import REPO, budget, free_endpoint, stop, subprocess_env

pytest.importorskip("zenoh")
pytestmark = pytest.mark.slow  # vehicles and the monitor in processes over Zenoh

TIMEOUT = budget(6)  # the monitor's --timeout: far longer than a refusal may take
REFUSED = (r"mcl monitor: error: the vehicle at tcp/127\.0\.0\.1:\d+ accepts connections but "
           r"refused this observer's session: check --user and --password-file \(or the TLS "
           r"certificates\) against the vehicle's --users")


def monitor(tmp_path: Path, *where: str, credentials: tuple[str, ...] = ()
            ) -> tuple[int, str, str, float]:
    """``mcl monitor --until-end`` as the operator with a wrong password (or these
    ``credentials``): its status, stdout, stderr and how long it took (wall s)."""
    (tmp_path / "wrong.pw").write_text("not-the-password\n")
    start = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-m", "app.mcl", "monitor", *where, "--until-end", "--plain",
         "--timeout", f"{TIMEOUT:g}", *(credentials or ("--user", "operator", "--password-file",
                                                       str(tmp_path / "wrong.pw")))],
        cwd=REPO, env=subprocess_env(),
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        code, out, err = finished(proc, budget(2))
    finally:
        stop(proc)
    return code, out, err, time.monotonic() - start


def assert_refused(code: int, out: str, err: str) -> None:
    assert code == 2, (code, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert re.fullmatch(REFUSED.replace("tcp", "(tcp|tls)"), lines[0]), lines[0]
    assert out == ""


def test_a_wrong_password_is_one_line_and_exit_2(tmp_path: Path) -> None:
    fleet = tmp_path / "pair.mcl"
    fleet.write_text(FLEET, encoding="utf-8")
    endpoint = free_endpoint()
    with vehicle(endpoint, "leader", *secured(fleet, "leader")[0]):
        code, out, err, took = monitor(tmp_path, "--zenoh", endpoint, "--name", "leader")
    assert_refused(code, out, err)
    assert endpoint in err
    assert took < budget(1.5) < TIMEOUT  # a refusal, not the --timeout


def test_a_fleet_with_a_wrong_password_is_one_line_and_exit_2(tmp_path: Path) -> None:
    fleet = tmp_path / "pair.mcl"
    fleet.write_text(FLEET, encoding="utf-8")
    lead, follow = free_endpoint(), free_endpoint()
    with (vehicle(lead, "leader", *secured(fleet, "leader")[0]),
          vehicle(follow, "follower", *secured(fleet, "follower")[0])):
        code, out, err, took = monitor(tmp_path, "--fleet-vehicle", f"leader={lead}",
                                       "--fleet-vehicle", f"follower={follow}")
    assert_refused(code, out, err)
    assert lead in err  # the first vehicle it tried
    assert took < budget(1.5) < TIMEOUT  # a refusal, not the --timeout


def test_a_certificate_of_another_ca_is_one_line_and_exit_2(pki: Path,  # noqa: F811
                                                            tmp_path: Path) -> None:
    endpoint = free_endpoint("tls")
    with vehicle_process(endpoint, *tls_options(pki, "vehicle")):
        code, out, err, took = monitor(tmp_path, "--zenoh", endpoint,
                                       credentials=tuple(tls_options(pki, "rogue")))
    assert_refused(code, out, err)
    assert endpoint in err
    assert took < budget(1.5) < TIMEOUT  # a refusal, not the --timeout
