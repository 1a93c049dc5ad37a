"""The vehicle's behaviours (paper 002 §3.1), one lifecycle, each raising the events of
docs/AAL.md."""

from behaviours import motion, registry, sensing
from behaviours.base import DOFS, Behaviour, Perception, Response
from behaviours.motion import AchieveHeadDist, GoTo, Surface, WallInspection
from behaviours.sensing import Alarms, StartCamera, StartLogs

# The paper's stack (what mcl/tasks/ictineu.tasks declares): the behaviours of motion.py and
# sensing.py, in the order the registry has them (the seabed's are behaviours.seabed.SEABED)
ALL: tuple[type[Behaviour], ...] = tuple(
    cls for cls in registry.behaviours() if cls.__module__ in (motion.__name__, sensing.__name__))

__all__ = ["ALL", "DOFS", "AchieveHeadDist", "Alarms", "Behaviour", "GoTo", "Perception",
           "Response", "StartCamera", "StartLogs", "Surface", "WallInspection"]
