"""The vehicle's behaviours (paper 002 §3.1), one lifecycle, each raising the events of AAL.md."""

from behaviours.base import DOFS, Behaviour, Perception, Response
from behaviours.motion import AchieveHeadDist, GoTo, Surface, WallInspection
from behaviours.sensing import Alarms, StartCamera, StartLogs

ALL: tuple[type[Behaviour], ...] = (GoTo, WallInspection, AchieveHeadDist, Surface,
                                    StartCamera, Alarms, StartLogs)

__all__ = ["ALL", "DOFS", "AchieveHeadDist", "Alarms", "Behaviour", "GoTo", "Perception",
           "Response", "StartCamera", "StartLogs", "Surface", "WallInspection"]
