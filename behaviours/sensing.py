"""The behaviours that drive nothing: StartCamera, Alarms, StartLogs (paper 002 §3.1)."""

from __future__ import annotations

from behaviours.base import Behaviour, Perception, Response


class StartCamera(Behaviour):
    """While enabled, the camera takes images (the vehicle switches its ``camera`` with it)."""

    name = "StartCamera"
    switches = "camera"


class StartLogs(Behaviour):
    """While enabled, every sensor reading and estimate is logged (the vehicle's ``logs``)."""

    name = "StartLogs"
    switches = "logs"


class Alarms(Behaviour):
    """Watches the leak detector and the vessels' temperature and pressure: the alarms the
    vehicle's own autopilot reported first (``Perception.alarms``: ArduSub's STATUSTEXTs), then
    the thresholds on the readings (a reading not sent is NaN: no alarm)."""

    name = "Alarms"
    events = ("leak", "overtemperature", "overpressure")
    parameters = ("max_temperature", "max_pressure")

    def on_update(self, p: Perception) -> Response:
        for alarm in sorted(p.alarms):
            self.raise_event(alarm)
        if p.leak:
            self.raise_event("leak")
        if p.temperature > self.param("max_temperature", 50.0):
            self.raise_event("overtemperature", temperature=p.temperature)
        if p.pressure > self.param("max_pressure", 1.5):
            self.raise_event("overpressure", pressure=p.pressure)
        return Response()

    def on_setpoints(self, p: Perception) -> Response:
        """The same watch on a vehicle whose autopilot holds positions (it drives nothing)."""
        return self.on_update(p)
