"""mission/simulated.py: the simulated Ictineu built from Python, as ``mcl run --vehicle sim``
builds it: its own stack (seed, faults), the in-process adapter, the simulated declaration."""

from __future__ import annotations

import pytest

from behaviours import capabilities
from mission.capabilities import declared_behaviours
from mission.simulated import simulated_vehicle
from vehicle_adapters.inprocess import InProcess


def test_a_vehicle_of_its_own_with_its_seed_and_faults() -> None:
    one = simulated_vehicle(seed=3, faults=["leak@600", ("overtemperature", 30)])
    two = simulated_vehicle(seed=4)
    assert isinstance(one.adapter, InProcess) and one.adapter.stack is one.stack
    realtime = simulated_vehicle(realtime=True).adapter
    assert isinstance(realtime, InProcess) and realtime.speed == 1.0 and one.adapter.speed is None
    assert one.stack is not None and two.stack is not None and one.stack is not two.stack
    assert one.stack.config.seed == 3 and two.stack.config.seed == 4
    assert one.stack.config.faults == [("leak", 600.0), ("overtemperature", 30.0)]
    assert one.declares is one.adapter and one.link is None and one.status is None


def test_it_declares_what_the_simulated_stack_runs() -> None:
    vehicle = simulated_vehicle()
    assert vehicle.declares is not None
    said = vehicle.declares.declaration()
    assert said is not None and said.vehicle == "sim (the simulated Ictineu)"
    assert said.text == capabilities.simulated("sim (the simulated Ictineu)").text
    assert vehicle.stack is not None
    assert set(declared_behaviours(said).behaviours) == set(vehicle.stack.behaviours)


@pytest.mark.parametrize("fault", ["leak", "leak@", "flood@10", "leak@-1", ("leak", -1.0)])
def test_a_bad_fault_is_refused_naming_it(fault: object) -> None:
    with pytest.raises(ValueError, match="expected FAULT@SECONDS"):
        simulated_vehicle(faults=[fault])  # type: ignore[list-item]
