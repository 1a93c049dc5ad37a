"""docs/EXTENDING.md, "Add a kind of vehicle": the page's one file and one registry line,
installed in a copy of ``app/``, make a kind ``mcl run`` runs a mission on to its end (a real
subprocess), with the refusals every kind gets from the registry."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from petri.execution.runlog import read_log
from tests.support import REPO, budget, subprocess_env

DOC = REPO / "docs" / "EXTENDING.md"
DAM = str(REPO / "missions" / "dam_inspection.mcl")
FENCE = re.compile(r"^```(\w+) ([^\n]+)\n(.*?)^```$", re.MULTILINE | re.DOTALL)


def section() -> str:
    text = DOC.read_text("utf-8")
    start = text.index("## Add a kind of vehicle")
    end = text.find("\n## ", start + 1)
    return text[start:] if end < 0 else text[start:end]


def blocks() -> dict[str, str]:
    """The section's code blocks by the path their fence names."""
    found: dict[str, str] = {}
    for _, path, body in FENCE.findall(section()):
        assert path not in found, f"two blocks for {path}"
        found[path] = body
    return found


def the_file_and_the_line() -> tuple[str, str, str]:
    """(the new module's name, its text, the registry line), as the page gives them."""
    code = blocks()
    new = [p for p in code if p.startswith("app/vehicles/") and p != "app/vehicles/__init__.py"]
    assert len(new) == 1, f"one new file, not {new}"
    lines = [line for line in code["app/vehicles/__init__.py"].splitlines() if line.strip()]
    assert len(lines) == 1, f"one registry line, not {lines}"
    return Path(new[0]).stem, code[new[0]], lines[0]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding a copy of app/ with the page's file and line: a process started there
    imports that app/ (the rest of the tree as installed)."""
    name, text, line = the_file_and_the_line()
    root = tmp_path_factory.mktemp("extended")
    shutil.copytree(REPO / "app", root / "app", ignore=shutil.ignore_patterns("__pycache__"))
    (root / "app" / "vehicles" / f"{name}.py").write_text(text, "utf-8")
    registry = root / "app" / "vehicles" / "__init__.py"
    source = registry.read_text("utf-8")
    start = source.index("KINDS: list[str] = [")
    close = source.index("\n]", start)  # the list's end: the line goes last
    registry.write_text(source[:close] + "\n" + line + source[close:], "utf-8")
    return root


def mcl(root: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "app.mcl", *args], cwd=root,
                          capture_output=True, text=True, timeout=budget(30),
                          env=subprocess_env(), stdin=subprocess.DEVNULL)


def test_the_page_gives_one_file_and_one_line() -> None:
    name, text, line = the_file_and_the_line()
    assert name == "loopback" and f'"{name}"' in line
    assert not (REPO / "app" / "vehicles" / f"{name}.py").exists()  # not shipped: built here
    assert f'"{name}"' not in (REPO / "app" / "vehicles" / "__init__.py").read_text("utf-8")
    for needed in ("NAME =", "WHERE =", "HELP =", "TITLE =", "INJECT =", "def add_options(",
                   "def build("):
        assert needed in text, needed


@pytest.mark.slow
def test_the_command_on_the_page_runs_the_mission_to_its_end(installed: Path) -> None:
    command = next(line for line in section().splitlines() if line.startswith("mcl run "))
    args = command.split()[2:]
    assert args[0] == "missions/dam_inspection.mcl"
    log = installed / "loopback.jsonl"
    done = mcl(installed, "run", DAM, *args[1:], "--log", str(log))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "mission dam_inspection ended OK after 8.0 s" in done.stdout, done.stdout
    records = read_log(str(log))
    assert records[0]["vehicle"] == "loopback:2"
    actions = {r["behaviour"]: r["t"] for r in records
               if r.get("kind") == "action" and r.get("action") == "enable"}
    events = [(r["event"], r["t"]) for r in records if r.get("kind") == "event"]
    assert [e for e, _ in events] == ["GoTo.reached", "AchieveHeadDist.achieved",
                                      "WallInspection.done", "GoTo.reached"], events
    assert "Alarms" in actions and not any(e.startswith("Alarms.") for e, _ in events)
    for event, t in events:  # each 2 s after an enable of its behaviour
        enables = [r["t"] for r in records if r.get("kind") == "action"
                   and r.get("action") == "enable" and r["behaviour"] == event.split(".")[0]]
        assert any(abs(t - (e + 2.0)) < 1e-9 for e in enables), (event, t, enables)
    ignored = [r["event"] for r in records if r.get("kind") == "ignored"]
    assert ignored == ["AchieveHeadDist.achieved"]  # KeepHeadDist's own enable, answered
    end = records[-1]
    assert end["kind"] == "end" and end["exit"] == 0 and end["how"] == "ok", end
    replay = mcl(installed, "replay", str(log), DAM)
    assert replay.returncode == 0 and "conforms" in replay.stdout, replay.stdout + replay.stderr


@pytest.mark.slow
def test_the_registry_refuses_for_the_new_kind(installed: Path) -> None:
    log = str(installed / "refused.jsonl")
    helped = mcl(installed, "run", "--help")
    assert helped.returncode == 0
    assert "loopback:SECONDS" in " ".join(helped.stdout.split()), helped.stdout
    other = mcl(installed, "run", DAM, "--silent", "Alarms", "--log", log)
    assert other.returncode == 2
    assert other.stderr.strip() == ("--silent: error: is for --vehicle loopback:...; "
                                    "this run's vehicle is 'sim'"), other.stderr
    inject = mcl(installed, "run", DAM, "--vehicle", "loopback:2", "--inject", "leak@3",
                 "--log", log)
    assert inject.returncode == 2
    assert inject.stderr.startswith("--inject: error: is for the simulated vehicle"), \
        inject.stderr
    bad = mcl(installed, "run", DAM, "--vehicle", "loopback:soon", "--log", log)
    assert bad.returncode == 2 and bad.stderr.startswith("--vehicle loopback:soon: error: ")
    unknown = mcl(installed, "run", DAM, "--vehicle", "warp", "--log", log)
    assert unknown.returncode == 2
    assert "mavlink:URL or loopback:SECONDS" in unknown.stderr, unknown.stderr
    endless = mcl(installed, "run", DAM, "--vehicle", "loopback:inf", "--log", log)
    assert endless.returncode == 2 and endless.stderr.startswith("--vehicle loopback:inf: error: ")
    typo = mcl(installed, "run", DAM, "--vehicle", "loopback:2", "--silent", "Alarm", "--log", log)
    assert typo.returncode == 2
    assert typo.stderr.startswith("--silent Alarm: error: the vehicle has no such behaviour"), \
        typo.stderr
    for output in (other, inject, bad, unknown, endless, typo):
        assert "Traceback" not in output.stderr


def test_every_registered_kind_supplies_what_a_kind_must() -> None:
    from app import vehicles

    kinds = vehicles.kinds()
    assert [k.NAME for k in kinds] == vehicles.KINDS
    assert all(isinstance(k, vehicles.Kind) for k in kinds)
    broken = type(sys)("broken")  # a module without build(): refused by name
    sys.modules["app.vehicles.broken"] = broken
    try:
        vehicles.KINDS.append("broken")
        with pytest.raises(TypeError, match="broken.py is not a kind of vehicle"):
            vehicles.kinds()
    finally:
        vehicles.KINDS.remove("broken")
        del sys.modules["app.vehicles.broken"]
