"""Running a compiled mission: the layer between the commands (``app/``) and the language
(``mcl/``).

- :func:`run_mission` (``mission/run.py``): one call runs a compiled mission on a vehicle with
  its time bound, capability check, verification, run log and safe exit, and returns a
  :class:`RunResult`. Several run side by side in one process, one thread each.
- :func:`run_fleet` (``mission/fleet.py``): a fleet's vehicles on one simulated clock, with
  their channels between them (``mission/channels.py``), returning a :class:`FleetResult`.
- :func:`simulated_vehicle` (``mission/simulated.py``): the simulated Ictineu, built from
  Python; :class:`Vehicle` (``mission/vehicle.py``): what a run runs on.
- :func:`check_capabilities` (``mission/capabilities.py``): is the mission within what the
  vehicle declares? :func:`max_time` and :func:`mission_bound` (``mission/limits.py``): how long
  it may run.
- :class:`Exit` (``mission/exits.py``): the exit statuses of every command (docs/EXIT.md).
- :class:`Handled` (``mission/handled.py``): an event a CATCH handled, as a run tells it;
  :class:`NoVehicle`: no vehicle answered, so the mission never started.

The names are loaded when first used, for start-up speed: ``mclc`` imports
:mod:`mission.exits` alone, not the player and the verifier.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mission.capabilities import check_capabilities, declared_behaviours
    from mission.exits import Exit
    from mission.fleet import FleetResult, run_fleet
    from mission.limits import max_time, mission_bound
    from mission.handled import Handled
    from mission.run import NotVerified, NoVehicle, RunResult, Stop, run_mission
    from mission.simulated import simulated_vehicle
    from mission.vehicle import Vehicle

HOMES = {  # each public name -> the module that defines it
    "run_mission": "mission.run", "RunResult": "mission.run", "Stop": "mission.run",
    "NotVerified": "mission.run", "simulated_vehicle": "mission.simulated",
    "Vehicle": "mission.vehicle", "check_capabilities": "mission.capabilities",
    "declared_behaviours": "mission.capabilities", "max_time": "mission.limits",
    "mission_bound": "mission.limits", "Exit": "mission.exits", "NoVehicle": "mission.run",
    "Handled": "mission.handled", "run_fleet": "mission.fleet", "FleetResult": "mission.fleet",
}
__all__ = ["Exit", "FleetResult", "Handled", "NoVehicle", "NotVerified", "RunResult", "Stop", "Vehicle", "check_capabilities",
           "declared_behaviours", "max_time", "mission_bound", "run_fleet", "run_mission",
           "simulated_vehicle"]


def __getattr__(name: str) -> Any:
    """``mission.NAME``: the name from its module, imported now (for start-up speed)."""
    if name not in HOMES:
        raise AttributeError(f"module 'mission' has no attribute {name!r}")
    return getattr(importlib.import_module(HOMES[name]), name)
