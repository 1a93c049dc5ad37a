"""The behaviours that drive nothing: StartCamera, Alarms, StartLogs (paper 002 §3.1)."""

from __future__ import annotations

from behaviours.base import Behaviour, Perception, Response


class StartCamera(Behaviour):
    """While enabled, the camera takes images (the vehicle loop reads ``active``)."""

    name = "StartCamera"


class StartLogs(Behaviour):
    """While enabled, every sensor reading and estimate is logged."""

    name = "StartLogs"


class Alarms(Behaviour):
    """Watches the leak detector and the vessels' temperature and pressure."""

    name = "Alarms"
    events = ("leak", "overtemperature", "overpressure")
    parameters = ("max_temperature", "max_pressure")

    def on_update(self, p: Perception) -> Response:
        if p.leak:
            self.raise_event("leak")
        if p.temperature > self.param("max_temperature", 50.0):
            self.raise_event("overtemperature", temperature=p.temperature)
        if p.pressure > self.param("max_pressure", 1.5):
            self.raise_event("overpressure", pressure=p.pressure)
        return Response()
