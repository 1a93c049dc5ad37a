"""mission/vehicle.py: a bare adapter becomes a run's vehicle with the features it has itself
(declares, a link that can be lost, a status feed, a summary), and none it has not."""

from __future__ import annotations

from typing import Any

from aal.messages import Declaration
from mission.vehicle import Declares, Link, StatusFeed, Summary, Vehicle
from vehicle.scripted import ScriptedVehicle, parse_script
from vehicle_adapters.inprocess import InProcess


class Linked(InProcess):
    """An adapter that is also a link, a status feed and a summary (as Zenoh's is)."""

    lost_reason = ""
    run = "run-1"

    @property
    def lost(self) -> bool:
        return False

    def publish_status(self, status: dict[str, Any]) -> None:
        pass

    def summary(self) -> dict[str, Any]:
        return {}


def stack() -> ScriptedVehicle:
    return ScriptedVehicle(parse_script({}))


def test_a_bare_in_process_adapter_only_declares() -> None:
    adapter = InProcess(stack(), declaration=Declaration("v", "v", ""))
    vehicle = Vehicle.around(adapter)
    assert vehicle.adapter is adapter and vehicle.declares is adapter
    assert (vehicle.link, vehicle.status, vehicle.summary, vehicle.stack) == (
        None, None, None, None)


def test_an_adapter_with_every_feature_is_seen_to_have_them() -> None:
    adapter = Linked(stack())
    vehicle = Vehicle.around(adapter)
    features: list[object] = [vehicle.declares, vehicle.link, vehicle.status, vehicle.summary]
    assert all(f is adapter for f in features)
    assert isinstance(adapter, Declares | Link | StatusFeed | Summary)


def test_an_object_without_them_has_none() -> None:
    plain = object()
    assert not isinstance(plain, Declares | Link | StatusFeed | Summary)
    vehicle = Vehicle.around(plain)  # type: ignore[arg-type]
    assert (vehicle.declares, vehicle.link, vehicle.status, vehicle.summary) == (
        None, None, None, None)
