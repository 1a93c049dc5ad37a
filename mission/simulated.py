"""The simulated Ictineu as a vehicle to run a mission on, built from Python.

``simulated_vehicle(seed=2)`` is what ``mcl run --vehicle sim --seed 2`` runs on: the whole
simulated stack (:class:`vehicle.control.stack.IctineuStack`) in this process, in simulated
time, behind the in-process adapter, declaring every registered behaviour. Each call builds a
vehicle of its own (its own random streams, its own clock), so that several run side by side
in one process, one thread each. The camera's images are kept only when asked:
``mosaic.hook.attach(vehicle.stack, LOG_PATH)`` before the run (``mcl run`` does).
"""

from __future__ import annotations

from collections.abc import Sequence

from mission.vehicle import Vehicle

NAME = "sim (the simulated Ictineu)"  # the vehicle its declaration names


def simulated_vehicle(seed: int = 1, faults: Sequence[str | tuple[str, float]] = (),
                      realtime: bool = False, name: str = NAME) -> Vehicle:
    """A simulated Ictineu in front of a dam wall. ``faults``: sensor faults at mission
    times, as ``"leak@600"`` or ``("leak", 600.0)`` (ValueError naming a bad one);
    ``realtime``: its clock runs at wall-clock speed (else as fast as it can)."""
    # imported here for start-up speed: the simulated stack (numpy, the seabed, the camera)
    # is loaded only by a program that builds one, not by every user of mission/
    from behaviours import capabilities
    from vehicle.control.stack import IctineuStack, StackConfig, parse_fault
    from vehicle_adapters.inprocess import InProcess

    parsed = [parse_fault(f if isinstance(f, str) else f"{f[0]}@{f[1]}") for f in faults]
    stack = IctineuStack(StackConfig(seed=seed, faults=parsed))
    adapter = InProcess(stack, speed=1.0 if realtime else None,
                        declaration=capabilities.simulated(name))
    return Vehicle(adapter, stack=stack, declares=adapter)
