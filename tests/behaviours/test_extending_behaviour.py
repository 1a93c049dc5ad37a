"""docs/EXTENDING.md's "Add a task" and "Add a behaviour", built and run from the doc itself.

The fenced blocks of those two sections (```LANG PATH) are extracted, so the doc cannot drift
from what works: the task example's library and mission are written to a temporary folder,
checked and verified by the real ``mclc`` and run in process on the simulated vehicle; the
behaviour example's class is written into a temporary package, its registry line executed
there, its statement appended to a copy of the shipped Ictineu library, and its mission
compiled with the API and run in process on the simulated stack to its end, the new
behaviour's event arriving; and the same mission over MAVLink (UDP loopback) on the ArduSub-like
vehicle, the adapter running the class's position law with no file of vehicle_adapters/ edited.
"""

from __future__ import annotations

import re
import shlex
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from mission.capabilities import check_capabilities, declared_behaviours, parameters_taken
from behaviours import capabilities, registry
from mcl import tasklib
from mcl.api import compile_file
from petri.execution.player import Player, Record
from petri.execution.runner import Outcome, run
from tests.support import REPO, budget, cli, free_udp_port
from tests.behaviours.test_registry import disagreements
from vehicle.control.stack import IctineuStack, StackConfig
from vehicle.servers.ardusub import ArduSubVehicle
from vehicle.servers.ardusub_autopilot import ACCEPTED
from vehicle_adapters.inprocess import InProcess
from vehicle_adapters.mavlink.link import MavlinkVehicle

DOC = REPO / "docs" / "EXTENDING.md"
BLOCK = re.compile(r"^```(\w+)[ \t]*(\S*)[ \t]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def section(title: str) -> list[tuple[str, str, str]]:
    """The fenced blocks (language, path, text) of the doc's section that starts so."""
    text = DOC.read_text("utf-8")
    start = text.index(f"\n## {title}")
    end = text.find("\n## ", start + 1)
    return [(m[1], m[2], m[3]) for m in BLOCK.finditer(text[start:end if end > 0 else len(text)])]


def block(blocks: list[tuple[str, str, str]], path: str) -> str:
    found = [text for _, where, text in blocks if where == path]
    assert len(found) == 1, f"EXTENDING.md: expected one block for {path}, found {len(found)}"
    return found[0]


def run_in_process(mission: Path, tasks: list[str] | None = None
                   ) -> tuple[Outcome, list[Record], IctineuStack]:
    """Compile (the API) and run on the simulated stack in process, as ``mcl run`` does:
    refused first if the vehicle's declaration lacks what the mission needs."""
    compiled = compile_file(str(mission), tasks, require_values=True)
    stack = IctineuStack(StackConfig(seed=1))
    declaration = capabilities.simulated("sim (the simulated Ictineu)")
    check_capabilities(compiled, declaration)
    player = Player(compiled.net)
    records: list[Record] = []
    player.observers.append(records.append)
    with InProcess(stack, declaration=declaration) as vehicle:
        outcome = run(player, vehicle, compiled.mission.name or mission.stem,
                      max_time=1800.0)
    return outcome, records, stack


def events(records: list[Record]) -> list[tuple[float, str]]:
    return [(r.t, str(r.data["event"])) for r in records if r.kind == "event"]


# --- Add a task (text only) --------------------------------------------------------------------
def test_the_doc_s_new_task_checks_verifies_and_runs(tmp_path: Path) -> None:
    blocks = section("Add a task")
    for name in ("dive.tasks", "dive.mcl"):
        (tmp_path / name).write_text(block(blocks, name), "utf-8")
    commands = [shlex.split(line) for line in block(blocks, "").splitlines() if line.strip()]
    assert [c[0] for c in commands] == ["mclc", "mcl"]
    mclc = cli(*commands[0], cwd=tmp_path)  # the real command, as the doc says
    assert mclc.returncode == 0, mclc.stdout + mclc.stderr
    library = tasklib.load(["ictineu", str(tmp_path / "dive.tasks")])
    assert [f.signature for f in library.tasks["Dive"]] == [
        "Dive(depth: length in [0 m, 100 m], tolerance: length >= 0 m = …)"]

    outcome, records, stack = run_in_process(tmp_path / "dive.mcl")
    assert outcome.status == "ok", outcome
    seen = [e for _, e in events(records)]
    assert seen[:2] == ["GoTo.reached", "Surface.surfaced"], seen
    assert not any(b.active for b in stack.behaviours.values())  # nothing left enabled
    assert stack.coordinator.overlaps == 0 and stack.unknown_actions == []


def test_the_doc_s_run_command_is_the_real_one(tmp_path: Path) -> None:
    blocks = section("Add a task")
    for name in ("dive.tasks", "dive.mcl"):
        (tmp_path / name).write_text(block(blocks, name), "utf-8")
    command = shlex.split(block(blocks, "").splitlines()[1])
    done = cli(*command, "--max-time", "600", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "GoTo.reached" in done.stdout and "Surface.surfaced" in done.stdout, done.stdout


# --- Add a behaviour (at most three files) -------------------------------------------------
@pytest.fixture()
def extension(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A package of its own for the doc's class file; the registry restored afterwards."""
    before = dict(registry.REGISTRY)
    package = tmp_path / "extension"
    package.mkdir()
    (package / "__init__.py").write_text("", "utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    registry.REGISTRY.clear()
    registry.REGISTRY.update(before)
    for name in [m for m in sys.modules if m == "extension" or m.startswith("extension.")]:
        del sys.modules[name]


@pytest.mark.slow
def test_the_doc_s_new_behaviour_is_three_files_and_runs(extension: Path) -> None:
    blocks = section("Add a behaviour")
    assert sorted({where for _, where, _ in blocks} - {"hold.mcl"}) == [
        "behaviours/depth.py", "behaviours/registry.py", "mcl/tasks/ictineu.tasks"]
    # 1. the class file, in a package of its own
    (extension / "extension" / "depth.py").write_text(block(blocks, "behaviours/depth.py"),
                                                      "utf-8")
    # 2. its registry line, run as if written in behaviours/registry.py (the import relative)
    line = block(blocks, "behaviours/registry.py")
    assert "HoldDepth" not in registry.REGISTRY
    exec(compile(line, "EXTENDING.md: behaviours/registry.py", "exec"),  # noqa: S102
         {"__name__": "extension.registry", "__package__": "extension",
          "register": registry.register})
    cls = registry.behaviour("HoldDepth")
    assert (cls.drives, cls.events, cls.parameters, cls.priority) == (
        ("z",), ("held",), ("depth",), 0)
    # 3. its statement and task, appended to (a copy of) the Ictineu library
    library = extension / "ictineu.tasks"
    library.write_text((REPO / "mcl" / "tasks" / "ictineu.tasks").read_text("utf-8") + "\n"
                       + block(blocks, "mcl/tasks/ictineu.tasks"), "utf-8")
    assert disagreements(tasklib.load([str(library)])) == []  # the registry agrees
    declared = declared_behaviours(capabilities.simulated("sim"))
    assert declared.behaviours["HoldDepth"].events == ("held",)
    assert parameters_taken(declared)["HoldDepth"] == {"depth"}

    mission = extension / "hold.mcl"
    mission.write_text(block(blocks, "hold.mcl"), "utf-8")
    verified = cli("mclc", "--tasks", str(library), str(mission))
    assert verified.returncode == 0, verified.stdout + verified.stderr
    fight = extension / "fight.mcl"  # the doc: HoldDepth and GoTo in parallel are refused
    fight.write_text("MISSION { PARALLEL { HoldDepth(3 m) } AND { GoTo((0, 0, 2, 0 deg)) } }\n",
                     "utf-8")
    refused = cli("mclc", "--tasks", str(library), str(fight))
    assert refused.returncode == 1, refused.stdout + refused.stderr
    assert "[FAIL] dof-exclusive: two behaviours can drive z (GoTo and HoldDepth)" in \
        refused.stdout, refused.stdout
    outcome, records, stack = run_in_process(mission, [str(library)])
    assert outcome.status == "ok", outcome
    assert "HoldDepth" in stack.behaviours and not stack.behaviours["HoldDepth"].active
    seen = events(records)
    assert [e for _, e in seen][:2] == ["HoldDepth.held", "Surface.surfaced"], seen
    held = next(r for r in records if r.kind == "event" and r.data["event"] == "HoldDepth.held")
    assert abs(float(held.data["data"]["depth"]) - 3.0) <= 0.2, held.data
    assert stack.coordinator.overlaps == 0 and stack.unknown_actions == []


def install(extension: Path) -> tuple[Path, Path]:
    """The doc's three files in place (the class, its registry line, the library with its
    statement appended) and its mission: (the library, the mission)."""
    blocks = section("Add a behaviour")
    (extension / "extension" / "depth.py").write_text(block(blocks, "behaviours/depth.py"),
                                                      "utf-8")
    exec(compile(block(blocks, "behaviours/registry.py"),  # noqa: S102
                 "EXTENDING.md: behaviours/registry.py", "exec"),
         {"__name__": "extension.registry", "__package__": "extension",
          "register": registry.register})
    library = extension / "ictineu.tasks"
    library.write_text((REPO / "mcl" / "tasks" / "ictineu.tasks").read_text("utf-8") + "\n"
                       + block(blocks, "mcl/tasks/ictineu.tasks"), "utf-8")
    mission = extension / "hold.mcl"
    mission.write_text(block(blocks, "hold.mcl"), "utf-8")
    return library, mission


def test_the_doc_s_new_behaviour_runs_over_mavlink(extension: Path) -> None:
    library, mission = install(extension)
    compiled = compile_file(str(mission), [str(library)], require_values=True)
    port = free_udp_port()
    stop, ready = threading.Event(), threading.Event()
    ardusub = ArduSubVehicle(f"udpout:127.0.0.1:{port}", speed=20.0, stop=stop, ready=ready)
    served = threading.Thread(target=ardusub.run, name="ardusub", daemon=True)
    served.start()
    try:
        assert ready.wait(budget(3)), "the ArduSub-like vehicle never got ready"
        with MavlinkVehicle(f"udpin:127.0.0.1:{port}", connect_timeout=budget(3)) as vehicle:
            said = vehicle.declaration()
            assert "behaviour HoldDepth drives z events held;" in said.text  # no 4th file
            check_capabilities(compiled, said)
            player = Player(compiled.net)
            records: list[Record] = []
            player.observers.append(records.append)
            outcome = run(player, vehicle, "hold", max_time=600.0)
    finally:
        stop.set()
        served.join(budget(2))
    assert outcome.status == "ok", outcome
    seen = events(records)
    assert [e for _, e in seen][:2] == ["HoldDepth.held", "Surface.surfaced"], seen
    held = next(r for r in records if r.kind == "event" and r.data["event"] == "HoldDepth.held")
    assert abs(float(held.data["data"]["depth"]) - 3.0) <= 0.2, held.data
    # the vehicle's side: HoldDepth drives z, so a disarm switches it off (no list names it)
    stack = ardusub.stack
    assert ardusub.arm(True) == ACCEPTED and stack.behaviours["HoldDepth"].drives == ("z",)
    ardusub.act("enable", "HoldDepth", {"depth": 3.0})
    assert stack.behaviours["HoldDepth"].active
    ardusub.arm(False)
    assert not stack.behaviours["HoldDepth"].active
