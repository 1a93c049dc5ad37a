"""The clock every remote adapter follows (vehicle_adapters/link.py): the events an adapter
makes itself are stamped on the clock the player reads, which never goes back."""

from __future__ import annotations

import pytest

from vehicle_adapters import link
from vehicle_adapters.link import RemoteVehicle


class Wall:
    """A monotonic clock the test moves by hand."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def wall(monkeypatch: pytest.MonkeyPatch) -> Wall:
    clock = Wall()
    monkeypatch.setattr(link.time, "monotonic", clock)
    return clock


def test_an_event_stamped_on_an_extrapolated_clock_is_not_delivered_before_it(wall: Wall) -> None:
    # The vehicle said 10 s at 20 x wall time; 0.2 wall s later the followed clock reads 14 s.
    # An event the adapter makes then is stamped 14 s. The vehicle's next reading says 12 s
    # (it ran slower than the estimate): the player must not read the clock below 14 s when it
    # is delivered, or the log says it was delivered before it was raised (mcl replay refuses).
    vehicle = RemoteVehicle(max_extrapolation=0.25)
    with vehicle.lock:
        vehicle.set_clock_locked(10.0, speed=20.0)
    wall.t += 0.2
    with vehicle.lock:
        stamped = vehicle.now_locked()
        vehicle.set_clock_locked(12.0)
    assert stamped == pytest.approx(14.0)
    assert vehicle.vehicle_time_locked() < stamped  # the followed clock itself went back
    assert vehicle.now() >= stamped
    wall.t += 0.05  # and it goes on from there, never back
    later = vehicle.now()
    assert later >= stamped


def test_link_lost_is_stamped_no_earlier_than_the_clock_read_before(wall: Wall) -> None:
    vehicle = RemoteVehicle(max_extrapolation=0.25)
    with vehicle.lock:
        vehicle.set_clock_locked(10.0, speed=20.0)
    wall.t += 0.2
    read = vehicle.now()  # 14 s, extrapolated
    with vehicle.lock:
        vehicle.set_clock_locked(12.0)
    vehicle.link_lost("test: no heartbeat")
    (lost,) = vehicle.receive(until=read)
    assert (lost.source, lost.name) == ("Link", "lost")
    assert lost.t >= read
    assert vehicle.now() >= lost.t
