"""What ``mcl vehicle`` (Zenoh) says when it stops (issue 22, smaller items): the actions it
dropped as invalid, such as those that name no run, were counted but never said ("0 actions,
0 stale" after two such actions)."""

from __future__ import annotations

from types import SimpleNamespace

from app.vehicle import stopped


def server(actions: int, stale: int, dropped: int, on: tuple[str, ...]) -> SimpleNamespace:
    behaviours = {n: SimpleNamespace(name=n, active=n in on) for n in ("GoTo", "Surface")}
    return SimpleNamespace(actions=actions, stale=stale, dropped=dropped,
                           stack=SimpleNamespace(t=66.94, behaviours=behaviours))


def test_the_stop_line_counts_the_invalid_actions_dropped() -> None:
    text = stopped("auv", server(0, 0, 2, ()))
    assert text.splitlines() == [
        "vehicle auv stopped after 66.9 s of simulated time (0 actions, 0 stale, 2 invalid "
        "dropped)", "  behaviours on at exit: none"]


def test_the_stop_line_names_the_behaviours_still_on() -> None:
    text = stopped("auv2", server(16, 1, 0, ("Surface", "GoTo")))
    assert "(16 actions, 1 stale, 0 invalid dropped)" in text
    assert text.endswith("behaviours on at exit: GoTo, Surface")
