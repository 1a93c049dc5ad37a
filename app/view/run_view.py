"""``mcl run MISSION.mcl --view HOST:PORT``: ``mcl view``'s page of the run, served by the
run's own process while it goes on, whatever the vehicle (sim, script, zenoh, mavlink).

The page is ``mcl view --zenoh``'s (app/view/server.py, the same page and script) and its
model is the same :class:`~app.view.live.LiveRun`, fed in process with the same status dicts
the player's status observer would publish over Zenoh (petri/execution/status.py, each
block's state in ``blocks``: mission/blocks.py): a :class:`StatusTee` takes the vehicle's
status feed's place (mission/vehicle.py's ``StatusFeed``, which makes ``run_mission`` keep
the status) and hands each status to the page, and on to the vehicle's own feed when it has
one (a Zenoh vehicle's observers, ``mcl monitor``, still get theirs). The track is the
vehicle's poses where it gives them, looked at every :data:`FOLLOW_EVERY` s: a simulated
vehicle's true track (mission/poses.py, as its run log holds it), a remote vehicle's own
position as its adapter last heard it (``pose()``: a MAVLink vehicle's LOCAL_POSITION_NED, a
Zenoh vehicle's navigator telemetry); a scripted vehicle gives none.

The server starts before the mission (a port it cannot serve on is refused then: one line,
exit 2) and stops when the run ends, however it ends; a page open then (it polls once a
second) is given up to :data:`LAST_LOOK` s to fetch the end first, so that it shows how the
run ended. The run's exit status is never changed by the view.
"""

from __future__ import annotations

import math
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from typing import Any

from diagnostics import MclError
from mcl.api import Compiled
from mission.poses import Pose, track_of
from mission.vehicle import StatusFeed, Vehicle

from app.view.data import mission_data
from app.view.live import LiveRun
from app.view.server import ViewServer

FOLLOW_EVERY = 0.2  # wall s between two looks at the vehicle's new poses
LAST_LOOK = 5.0  # wall s at most that an open page is waited for to fetch the run's end
OPEN = 10.0  # wall s: a page that fetched the data this recently is open (it polls every 1 s;
#             a loaded machine delays it)


class StatusTee:
    """The status feed the player publishes to (mission/vehicle.py's ``StatusFeed``): each
    status to the live page, then to the vehicle's own feed, if any."""

    def __init__(self, live: LiveRun, feed: StatusFeed | None):
        self.live, self.feed = live, feed
        self.own_run = uuid.uuid4().hex  # this run's id when no vehicle's feed names it

    @property
    def run(self) -> str:
        """The run's id: the vehicle's feed's (a Zenoh session's id, known once connected)."""
        return self.feed.run if self.feed is not None else self.own_run

    @run.setter
    def run(self, value: str) -> None:
        if self.feed is not None:
            self.feed.run = value
        else:
            self.own_run = value

    def publish_status(self, status: dict[str, Any]) -> None:
        if self.feed is not None:
            self.feed.publish_status(status)
        self.live.take_status(status)


def poses_of(chosen: Vehicle) -> tuple[Callable[[], Sequence[Pose]] | None, str]:
    """The vehicle's poses so far (oldest first) and what they are; (None, "") when it gives
    none."""
    track = track_of(chosen)
    if track is not None:
        return track, "the simulated vehicle's true pose"
    pose = getattr(chosen.adapter, "pose", None)
    if not callable(pose):
        return None, ""
    said: list[Pose] = []

    def sampled() -> Sequence[Pose]:  # its last position, kept when it is a new one
        now = pose()
        if now is not None and (not said or now[0] > said[-1][0]):
            said.append(now)
        return said

    return sampled, "the vehicle's own position"


class RunView:
    """``--view``: the page served at ``where`` (host, port) from before the mission until
    :meth:`close`; it takes ``chosen``'s status feed (a :class:`StatusTee`)."""

    def __init__(self, where: tuple[str, int], compiled: Compiled, chosen: Vehicle,
                 kind: str):
        self.chosen = chosen
        self.live = LiveRun(mission_data(compiled), kind, chosen.where or "mcl run's process")
        self.poses, self.live.track_from = poses_of(chosen)
        self.seen = 0  # the poses handed to the page so far
        host, port = where
        try:
            self.server = ViewServer(self.data, {}, port, host)
        except OSError as exc:  # a port taken, an address not of this machine, a bad host
            why = exc.strerror or str(exc)
            raise MclError(f"--view {host}:{port}: cannot serve there ({why}); choose "
                           "another port, or port 0 for a free one", code="view") from None
        chosen.status = StatusTee(self.live, chosen.status)
        self.stop = threading.Event()
        self.closing = threading.Event()
        self.looked = threading.Event()  # a page fetched the data once the run had ended
        self.fetched = -math.inf  # monotonic s when a page last fetched the data
        self.server.start()
        self.follower = threading.Thread(target=self.follow, name="mcl-run-view", daemon=True)
        self.follower.start()

    @property
    def url(self) -> str:
        return self.server.url

    def data(self) -> dict[str, Any]:
        """The page's data now (the server's provider)."""
        data = self.live.data()
        self.fetched = time.monotonic()
        if self.closing.is_set():
            self.looked.set()
        return data

    def follow(self) -> None:
        """Hand the page the vehicle's new poses and whether it is there, every
        :data:`FOLLOW_EVERY` s until :meth:`close`."""
        while not self.stop.wait(FOLLOW_EVERY):
            self.catch_up()

    def catch_up(self) -> None:
        """The poses since the last look, the vehicle's clock (its last pose's) and its
        presence (its link's)."""
        link = self.chosen.link
        if link is None:  # in this process: there while the run goes on
            self.live.seen_alive(True)
        elif link.lost or getattr(link, "answered", True):  # not yet answered: not seen
            self.live.seen_alive(not link.lost)
        if self.poses is None:
            return
        poses = self.poses()
        for t, x, y, z, _ in poses[self.seen:]:
            self.live.take_position([float(t), float(x), float(y), float(z)])
        self.seen = len(poses)
        if poses:  # the vehicle's clock, as its last pose gives it: the page's "now"
            self.live.take_clock(float(poses[-1][0]))

    def close(self) -> None:
        """The last poses; a page open (one that fetched the data in the last :data:`OPEN`
        s) given up to :data:`LAST_LOOK` s to fetch the end; the server stopped (even when a
        signal cuts the wait short)."""
        self.stop.set()
        self.follower.join()
        try:
            self.catch_up()
            self.closing.set()
            if time.monotonic() - self.fetched < OPEN:  # a page is open
                self.looked.wait(LAST_LOOK)
        finally:
            self.server.shutdown()
            self.server.server_close()

