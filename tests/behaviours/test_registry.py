"""The one registry of behaviours (behaviours/registry.py) against what is declared elsewhere.

- The shipped task libraries (``mcl/tasks/ictineu.tasks``, ``missions/seabed.tasks``), read by
  the task library's own parser (mcl.tasklib), agree with the registry: each behaviour
  statement's degrees of freedom and events are the registered class's, and every parameter
  an ``enable``/``configure`` action passes is one the class declares; every registered
  behaviour is declared by one of them. The check is shown to fail on a library that
  declares a registered behaviour differently.
- Every vehicle's declaration (behaviours/capabilities.py) parses with that parser and says
  what the registry says, parameters included.
- The coordinator's priorities are the classes' (no table to keep in step).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

from aal.messages import Declaration
from mission.capabilities import declared_behaviours, parameters_taken
from behaviours import ALL, Behaviour, Response, capabilities, registry
from behaviours.coordinator import PRIORITY, Coordinator
from behaviours.seabed import SEABED, statements
from diagnostics import Source
from mcl import tasklib
from tests.support import MISSIONS, REPO
from vehicle.control.stack import IctineuStack

LIBRARIES = (REPO / "mcl" / "tasks" / "ictineu.tasks", MISSIONS / "seabed.tasks")


def load(*texts: tuple[str, str]) -> tasklib.Library:
    return tasklib.load_sources([Source(name, text) for name, text in texts])


def shipped() -> tasklib.Library:
    return load(*((str(p), p.read_text("utf-8")) for p in LIBRARIES))


def disagreements(library: tasklib.Library) -> list[str]:
    """Where a task library and the registry differ (empty: they agree)."""
    out = []
    for b in library.behaviours.values():
        if b.name not in registry.REGISTRY:
            out.append(f"{b.name}: declared by {b.span.file}, not registered")
            continue
        cls = registry.behaviour(b.name)
        if b.dofs != cls.drives:
            out.append(f"{b.name} drives {b.dofs} in the library, {cls.drives} registered")
        if b.events != cls.events:
            out.append(f"{b.name} events {b.events} in the library, {cls.events} registered")
    for forms in library.tasks.values():
        for form in forms:
            for action in form.start + form.stop:
                given = registry.REGISTRY.get(action.behaviour)
                takes = given.parameters if given is not None else ()
                extra = sorted({k for k, _ in action.bindings} - set(takes))
                if given is not None and action.kind != "disable" and extra:
                    out.append(f"task {form.name} gives {action.behaviour} {extra}, which it "
                               f"does not declare (it takes {takes})")
    return out


@pytest.fixture()
def temporary() -> Iterator[list[str]]:
    """Names registered during a test, taken out after it."""
    names: list[str] = []
    yield names
    for name in names:
        registry.unregister(name)


# --- the shipped task libraries agree with the registry ------------------------------------
def test_the_shipped_task_libraries_agree_with_the_registry() -> None:
    library = shipped()
    assert disagreements(library) == []
    assert set(library.behaviours) == set(registry.REGISTRY)  # each declared, none extra
    passed = parameters_taken(library)
    assert passed["GoTo"] == set(registry.behaviour("GoTo").parameters)
    assert passed["FollowCable"] == {"speed", "length"}


@pytest.mark.parametrize("change, found", [
    (("behaviour GoTo             drives x, y, z, yaw", "behaviour GoTo drives x, y, z"),
     "GoTo drives ('x', 'y', 'z') in the library"),
    (("events achieved, lost", "events achieved, lost, drifted"),
     "AchieveHeadDist events ('achieved', 'lost', 'drifted')"),
    (("enable GoTo(x = target.x,", "enable GoTo(speed = 2, x = target.x,"),
     "task GoTo gives GoTo ['speed']"),
    (("behaviour StartLogs ", "behaviour StartLogs events full "), "StartLogs events"),
    (("behaviour StartLogs ", "behaviour Sonar; behaviour StartLogs "), "Sonar: declared"),
])
def test_a_library_that_declares_a_registered_behaviour_differently_fails(
        change: tuple[str, str], found: str) -> None:
    path = LIBRARIES[0]
    text = path.read_text("utf-8")
    assert change[0] in text
    library = load((str(path), text.replace(change[0], change[1], 1)))
    problems = disagreements(library)
    assert any(found in p for p in problems), problems


def test_a_registered_class_that_changes_disagrees_with_the_library(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(registry.behaviour("Surface"), "events", ("surfaced", "stuck"))
    assert disagreements(shipped()) == [
        "Surface events ('surfaced',) in the library, ('surfaced', 'stuck') registered"]
    monkeypatch.setattr(registry.behaviour("SearchLine"), "parameters", ())
    assert any("SearchLine ['width']" in p for p in disagreements(shipped()))


def test_seabed_statements_come_from_the_classes_like_every_declaration() -> None:
    library = load(("seabed", statements()))
    assert [b.name for b in library.behaviours.values()] == [c.name for c in SEABED]
    assert disagreements(library) == []
    assert all(registry.behaviour(c.name) is c for c in SEABED)


# --- every vehicle's declaration parses and says what the registry says ----------------------
@pytest.mark.parametrize("declaration", [
    capabilities.simulated("sim"),
    capabilities.simulated("zenoh", list(IctineuStack().behaviours)),
    capabilities.simulated("some", ["GoTo", "FollowCable", "Velocity"]),
    capabilities.ictineu("ictineu"),
    capabilities.ictineu("mavlink", ["GoTo", "Surface", "Alarms", "Arm"]),
], ids=["sim", "zenoh", "subset", "ictineu", "mavlink"])
def test_every_vehicle_declaration_parses_and_agrees_with_the_registry(
        declaration: Declaration) -> None:
    library = declared_behaviours(declaration)
    assert library.behaviours, declaration.text
    assert disagreements(library) == []
    assert library.declared_dofs == ["x", "y", "z", "yaw"]
    takes = parameters_taken(library)
    for name in library.behaviours:  # every parameter of each, no more
        assert takes[name] == set(registry.behaviour(name).parameters), name


def test_the_declarations_cover_what_each_vehicle_runs() -> None:
    assert set(declared_behaviours(capabilities.simulated("sim")).behaviours) == set(
        IctineuStack().behaviours) == set(registry.REGISTRY)
    assert list(declared_behaviours(capabilities.ictineu("i")).behaviours) == [
        c.name for c in ALL]
    some = declared_behaviours(capabilities.ictineu("m", ["Surface", "KeepAltitude", "Arm"]))
    assert list(some.behaviours) == ["Surface"]  # the Ictineu's only, of those asked for


# --- registering ------------------------------------------------------------------------------
def test_every_behaviour_is_registered_once_with_its_declaration() -> None:
    names = [c.name for c in registry.behaviours()]
    assert names == ["GoTo", "WallInspection", "AchieveHeadDist", "Surface", "StartCamera",
                     "Alarms", "StartLogs", "KeepAltitude", "FollowPipeline", "FollowCable",
                     "SearchLine"]
    goto = registry.behaviour("GoTo")
    assert (goto.drives, goto.events, goto.parameters) == (
        ("x", "y", "z", "yaw"), ("reached", "failed"), ("x", "y", "z", "yaw", "tolerance"))
    with pytest.raises(KeyError, match="no behaviour 'Hover' is registered: GoTo, "):
        registry.behaviour("Hover")


def test_a_new_behaviour_is_one_line_and_its_priority_ranks_it(temporary: list[str]) -> None:
    class Dock(Behaviour):
        name = "Dock"
        drives = ("x", "z")
        events = ("docked",)
        parameters = ("station",)
        priority = 50

        def on_update(self, p: object) -> Response:
            return Response({"x": 0.1}, {"z": 4.0})

    assert registry.register(Dock) is Dock
    temporary.append("Dock")
    assert registry.priority() == ("Dock", *PRIORITY)
    assert "behaviour Dock drives x, z events docked;" in capabilities.simulated("s").text
    assert parameters_taken(declared_behaviours(capabilities.simulated("s")))["Dock"] == {"station"}
    c = Coordinator()
    out = c.merge({"Surface": Response({"z": -0.3}), "Dock": Response({"x": 0.1}, {"z": 4.0})})
    assert out == {"x": 0.1, "y": 0.0, "z": 0.0, "yaw": 0.0}  # z held by Dock's setpoint
    assert c.last_setpoints == {"z": 4.0} and c.last_owner == {"x": "Dock", "z": "Dock"}
    assert c.overlaps == 1
    registry.unregister("Dock")
    out = c.merge({"Surface": Response({"z": -0.3}), "Dock": Response({"x": 0.1}, {"z": 4.0})})
    assert (out["z"], c.last_setpoints) == (-0.3, {})  # unregistered: ranked last


@pytest.mark.parametrize("attrs, message", [
    ({"name": ""}, "needs a name"),
    ({"name": "GoTo"}, "GoTo is registered twice"),
    ({"name": "Roll", "drives": ("roll",)}, "drives roll: the degrees of freedom are x, y"),
    ({"name": "Twice", "events": ("a", "a")}, "events names one twice"),
])
def test_a_malformed_registration_is_refused(attrs: dict[str, object], message: str) -> None:
    cls = type("Bad", (Behaviour,), attrs)
    with pytest.raises(ValueError, match=message):
        registry.register(cls)
    assert registry.REGISTRY.get(str(attrs["name"])) is not cls


def test_priority_is_derived_from_the_classes(monkeypatch: pytest.MonkeyPatch) -> None:
    assert PRIORITY == registry.priority() == ("Surface", "AchieveHeadDist", "WallInspection",
                                               "GoTo")
    monkeypatch.setattr(registry.behaviour("GoTo"), "priority", 99)
    assert registry.priority()[0] == "GoTo"
    c = Coordinator()
    c.merge({"Surface": Response({"z": -0.3}), "GoTo": Response({"z": 0.2})})
    assert c.last_owner["z"] == "GoTo"


def test_the_capabilities_read_no_task_library() -> None:
    """The declarations come from the registry, not from mcl's files (layers: behaviours/ is
    below mcl/)."""
    tree = ast.parse(Path(capabilities.__file__).read_text("utf-8"))
    imported = [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    imported += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    assert imported and not [m for m in imported if m.split(".")[0] in ("mcl", "pathlib")]
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.Constant)
                and isinstance(n.value, str) and n.value.endswith(".tasks")]
