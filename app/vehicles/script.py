"""``--vehicle script:FILE.toml``: a scripted vehicle in simulated time, answering actions with
events as its file says (docs/VEHICLES.md, "Scripted vehicle")."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from diagnostics import MclError

from app.vehicles.kind import Invalid, Options, Vehicle

if TYPE_CHECKING:
    from aal.messages import Declaration
    from vehicle.scripted import Script

NAME = "script"
WHERE = "FILE.toml"
HELP = "a scripted vehicle"
TITLE = "scripted vehicle (--vehicle script:...)"
INJECT = ("--inject is for the simulated vehicle; a scripted vehicle takes [[at]] events in "
          "its file")


def add_options(options: Options) -> None:
    """None of its own: its file says everything (--realtime paces it)."""


def build(where: str, args: argparse.Namespace) -> Vehicle:
    from vehicle_adapters.inprocess import InProcess
    from vehicle.scripted import ScriptedVehicle, ScriptError, load_script

    if not where:
        raise Invalid("--vehicle script:FILE.toml needs a file")
    try:
        script = load_script(where)
        adapter = InProcess(ScriptedVehicle(script), speed=1.0 if args.realtime else None,
                            declaration=declaration(script, where))
    except ScriptError as exc:
        if exc.span is None:  # no place in the file: one line that starts with the file
            raise Invalid(str(exc)) from None
        raise  # file:line:col: error: ..., its line and a hint
    return Vehicle(adapter, declares=adapter)


def declaration(script: Script, where: str) -> Declaration:
    """A scripted vehicle's declaration: the behaviour statements of its ``tasks`` libraries;
    the script's own names are checked against them (ScriptError at their line)."""
    from aal.messages import Declaration
    from behaviours.capabilities import behaviour_statements
    from diagnostics import read_source
    from mcl import tasklib
    from vehicle.scripted import ScriptError, check_script

    from mission.capabilities import declared_behaviours

    texts = []
    for library in script.tasks:
        try:
            source = (tasklib.shipped_source(f"{library}.tasks") if tasklib.is_shipped(library)
                      else read_source(library))
        except MclError as exc:
            raise ScriptError(f"{where}: tasks: {exc.format()}") from None
        texts.append(behaviour_statements(source.text))
    said = Declaration(f"script:{where}", f"{where} (tasks = {script.tasks})", "".join(texts))
    have = declared_behaviours(said).behaviours
    check_script(script, {name: b.events for name, b in have.items()})
    return said
