"""Paper 003's pair as simulated vehicles for a fleet: the ASV and the UUV in one world.

``mcm_vehicles(seed=1)`` is what ``mcl run missions/mcm.mcl`` runs on: both stacks
(vehicle/control/asv_stack.py, uuv_stack.py) share one simulated world (the ASV's sonar sees
the UUV, the UUV's camera the mine), each behind its own in-process adapter, declaring the
behaviours of its task library (missions/asv.tasks, missions/uuv.tasks), and each with its
side of the modem (:class:`mission.vehicle.Modem`): the ASV answers ``payload("guide", "fix",
t)`` with its last sonar fix (R, epsilon, its heading and position in {T}, the ping time) and
``payload("guide", "release", t)`` with the mine's depth; the UUV's ``heard`` lets it go on
``release`` and hands every ``fix`` to its navigator. docs/MCM.md.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from mission.vehicle import Vehicle

NAMES = ("asv", "uuv")  # the task libraries' stems, and the vehicles' names in missions/mcm.mcl


def mcm_vehicles(seed: int = 1, faults: Sequence[str | tuple[str, Any]] = (),
                 method: str = "repropagate", realtime: bool = False) -> dict[str, Vehicle]:
    """The ASV and the UUV of one world, by name. ``faults``: ``"clutter@60"``,
    ``"falsetarget@60"``, ``"current=0.2,0"`` (or parsed, ``("clutter", 60.0)``; ValueError
    naming a bad one); ``method``: the UUV navigator's delayed fusion ("naive",
    "repropagate", "larsen"); ``realtime``: the clocks run at wall-clock speed."""
    # imported here for start-up speed: the simulated world (numpy, the EKF) is loaded only
    # by a program that builds one, not by every user of mission/
    from aal.messages import Declaration
    from behaviours.capabilities import declaration_text
    from vehicle.control.asv_stack import AsvStack
    from vehicle.control.mcm_stack import McmStack, mcm_world, parse_mcm_fault
    from vehicle.control.uuv_stack import UuvStack, navigator
    from vehicle_adapters.inprocess import InProcess

    parsed = [parse_mcm_fault(f) if isinstance(f, str) else f for f in faults]
    world = mcm_world(seed, parsed)
    stacks: dict[str, McmStack] = {"asv": AsvStack(world, seed),
                                   "uuv": UuvStack(world, seed, navigator(method))}
    chosen: dict[str, Vehicle] = {}
    for name, stack in stacks.items():
        said = Declaration(f"sim {name} (paper 003)", "behaviours/mcm.py",
                           declaration_text(stack.classes))
        adapter = InProcess(stack, speed=1.0 if realtime else None, declaration=said)
        chosen[name] = Vehicle(adapter, declares=adapter, modem=stack,
                               summary=Figures(stack.figures))
    return chosen


class Figures:
    """A vehicle's figures against the simulated ground truth, as its run's summary
    (:class:`mission.vehicle.Summary`): what ``mcl run`` prints under the vehicle."""

    def __init__(self, figures: Callable[[], dict[str, Any]]) -> None:
        self.figures = figures

    def summary(self) -> dict[str, Any]:
        return self.figures()
