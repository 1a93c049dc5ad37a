"""What a task library may not declare, refused at its file:line:col (issue 22).

A behaviour named ``Mission`` with an event ``abort`` compiled: its task waited for
``Mission.abort``, the player's own external stop, and mclc answered with a FAIL of
``terminates`` at ``{MISSION.begin}`` that says nothing of the cause. ``Link`` is the same
(``Link.lost``). The names of the sources the player raises are reserved.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from diagnostics import MclError, Source
from mcl import tasklib
from mcl.declarations import BUILTIN_SOURCES
from mcl.library_builder import RESERVED_BEHAVIOURS
from tests.support import cli, write

TEMPLATE = """// a user's library
behaviour Camera events done;
behaviour {name} events {events};
task Go() {{
    start: enable {name};
    ok:    {name}.done;
    fail:  {name}.{event};
    timeout: 1 min -> fail;
    stop:  disable {name};
}}
"""


def library(name: str, event: str) -> str:
    return TEMPLATE.format(name=name, events=f"done, {event}", event=event)


def test_every_source_the_player_raises_is_reserved() -> None:
    assert set(RESERVED_BEHAVIOURS) == set(BUILTIN_SOURCES)


@pytest.mark.parametrize("name,event", [("Mission", "abort"), ("Link", "lost")])
def test_a_behaviour_named_as_a_player_source_is_refused_at_its_name(name: str,
                                                                    event: str) -> None:
    with pytest.raises(MclError) as caught:
        tasklib.load_sources([Source("user.tasks", library(name, event))])
    [d] = caught.value.diagnostics
    assert d.span is not None
    assert (d.span.file, d.span.line, d.span.col) == ("user.tasks", 3, 11)
    assert f"behaviour {name}: the name is reserved" in d.message
    assert f"{name}.{event}" in d.message
    assert d.code == "library-reserved"


def test_other_names_like_them_stay_allowed() -> None:
    for name in ("Missions", "MissionLog", "Linker", "Uplink"):
        lib = tasklib.load_sources([Source("user.tasks", library(name, "abort"))])
        assert name in lib.behaviours


def test_mclc_says_where_and_why_not_a_fail_at_mission_begin(tmp_path: Path) -> None:
    tasks = write(tmp_path, library("Mission", "abort"), "user.tasks")
    mission = write(tmp_path, "MISSION m { Go() }\n")
    proc = cli("mclc", str(mission), "--tasks", str(tasks))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith(f"{tasks}:3:11: error: behaviour Mission: the name is "
                                  "reserved"), proc.stderr
    assert "MISSION.begin" not in proc.stdout + proc.stderr
    assert "FAIL" not in proc.stdout
