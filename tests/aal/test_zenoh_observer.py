"""An observer's session (aal/zenoh_observer.py): opened again while nothing is at the endpoint,
saying so once; refused, on one line, when something accepts connections there but will not
open the session. Here what accepts is a bare TCP socket (no Zenoh behind it); a real secured
vehicle refusing wrong credentials: tests/app/test_monitor_secured.py."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest

pytest.importorskip("zenoh")

from aal.zenoh_observer import (REFUSALS, SessionRefused, listens,  # noqa: E402
                                observer_session)
from diagnostics import MclError  # noqa: E402

from tests.support import budget  # noqa: E402


@pytest.fixture
def accepting() -> Iterator[str]:
    """An endpoint where the kernel accepts TCP connections that nothing ever answers."""
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        yield f"tcp/127.0.0.1:{server.getsockname()[1]}"


@pytest.fixture
def nobody() -> str:
    """An endpoint where nothing listens (a port just freed)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def test_listens_tells_an_open_port_from_a_closed_one(accepting: str, nobody: str) -> None:
    assert listens(accepting)
    assert listens(accepting.replace("tcp/", "tls/") + "?iface=lo")
    assert not listens(nobody)
    assert not listens(accepting.replace("tcp/", "udp/"))  # cannot be told: not "listens"


def test_a_stopped_observer_opens_nothing(nobody: str) -> None:
    stop = threading.Event()
    stop.set()
    said: list[str] = []
    assert observer_session(nobody, None, stop, waiting=said.append) is None
    assert said == []


@pytest.mark.slow  # one attempt: Zenoh gives up opening after 2 s
def test_nobody_there_is_waited_for_until_the_timeout_and_said_once(nobody: str) -> None:
    said: list[str] = []
    start = time.monotonic()
    session = observer_session(nobody, None, threading.Event(), timeout=0.1,
                               waiting=said.append)
    assert session is None
    assert len(said) == 1 and nobody.partition("/")[2] in said[0], said
    assert time.monotonic() - start < budget(0.5)


@pytest.mark.slow  # REFUSALS attempts of 2 s each
def test_something_there_that_refuses_is_one_error_not_a_wait(accepting: str) -> None:
    said: list[str] = []
    start = time.monotonic()
    with pytest.raises(SessionRefused) as caught:
        observer_session(accepting, None, threading.Event(), timeout=60.0,
                         waiting=said.append)
    assert time.monotonic() - start < budget(REFUSALS * 0.5)  # 2 s an attempt
    assert said == []  # never said to be waiting: something was there all along
    assert isinstance(caught.value, MclError) and caught.value.endpoint == accepting
    assert "\n" not in str(caught.value)
    assert str(caught.value).startswith(f"the vehicle at {accepting} accepts connections but "
                                        "refused this observer's session: check --user")
