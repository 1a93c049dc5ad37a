"""Where the fleet was explored explicitly, every joint state the players visit is in the
verified graph (issue 23, deliverable 6): runs of the two-vehicle example in one process
(mission/fleet.py), at every loss and many seeds, each firing of each player followed on a
shadow of its marking; every joint marking of the players (each vehicle's places; the
channels' places may be anything) is one the explicit product (mcl/analysis/fleet.py) holds.
The runtime's channels are timed and queue messages, the product's are untimed and keep one
per link: the vehicles' parts must still all be there, since the product over-approximates.
"""

from __future__ import annotations

from typing import Any

from mcl.analysis.fleet_replay import visited
from mcl.analysis.fleet_verification import verify_fleet
from mcl.fleet import compile_fleet_file
from mission.fleet import run_fleet
from mission.vehicle import Vehicle
from petri.net import Net
from petri.semantics import Semantics
from tests.support import REPO
from vehicle.scripted import ScriptedVehicle, parse_script
from vehicle_adapters.inprocess import InProcess

PAIR = REPO / "examples" / "fleet" / "pair.mcl"
SCRIPTS = [  # quick vehicles that reach their goal, and one whose GoTo times out
    parse_script({"behaviours": {"GoTo": {"on_enable": {"after": 12.0, "event": "reached"}},
                                 "Surface": {"on_enable": {"after": 9.0,
                                                           "event": "surfaced"}}}}),
    parse_script({"behaviours": {"Surface": {"on_enable": {"after": 9.0,
                                                           "event": "surfaced"}}}}),
]


class Joint:
    """The players' joint markings, as their firings come: one shadow marking per vehicle."""

    def __init__(self, nets: dict[str, Net]) -> None:
        self.rules = {name: Semantics(net) for name, net in nets.items()}
        self.marking = {name: r.initial() for name, r in self.rules.items()}
        self.seen = {self.now()}

    def now(self) -> tuple[tuple[int, ...], ...]:
        return tuple(tuple(m) for m in self.marking.values())

    def observer(self, name: str) -> Any:
        def follow(record: Any) -> None:
            if record.kind == "fire":  # one thread at a time: the others are between steps
                self.rules[name].fire(self.marking[name], record.data["index"])
                self.seen.add(self.now())
        return follow


def test_every_joint_state_the_players_visit_is_in_the_verified_graph() -> None:
    fleet = compile_fleet_file(str(PAIR), require_values=True)
    verdict = verify_fleet(fleet, "explicit", keep_graph=True)
    assert verdict.ok and verdict.space is not None and verdict.space.complete
    names = list(fleet.vehicles)
    joint = Joint({n: c.net for n, c in fleet.vehicles.items()})
    runs = 0
    for script in SCRIPTS:
        for loss in (0.0, 0.3, 0.5, 1.0):
            for seed in range(8):
                run_fleet(fleet, {n: Vehicle(InProcess(ScriptedVehicle(script))) for n in names},
                          loss=loss, seed=seed, verify=False,
                          observers={n: [joint.observer(n)] for n in names})
                joint.marking = {n: r.initial() for n, r in joint.rules.items()}
                runs += 1
    assert runs == 64 and len(joint.seen) > 20  # many joint states, not a handful
    missing = [m for m in joint.seen
               if not visited(verdict.space, verdict.fleet, dict(zip(names, m, strict=True)))]
    assert missing == []


def test_a_joint_state_the_product_cannot_reach_is_not_found() -> None:
    """The check can fail: the follower that has heard ``go`` beside a leader that has sent
    nothing yet is no state of the fleet, and the lookup says so (beside the leader as it
    was, it is one)."""
    fleet = compile_fleet_file(str(PAIR), require_values=True)
    verdict = verify_fleet(fleet, "explicit", keep_graph=True)
    assert verdict.space is not None
    names = list(fleet.vehicles)
    joint = Joint({n: c.net for n, c in fleet.vehicles.items()})
    heard: list[dict[str, list[int]]] = []

    def on_hearing(record: Any) -> None:
        if record.kind == "fire" and record.data["cause"] == "orders.go" and not heard:
            heard.append({n: list(m) for n, m in joint.marking.items()})

    run_fleet(fleet, {n: Vehicle(InProcess(ScriptedVehicle(SCRIPTS[0]))) for n in names},
              loss=0.0, seed=1, verify=False,
              observers={"leader": [joint.observer("leader")],
                         "follower": [joint.observer("follower"), on_hearing]})
    assert heard, "the follower heard go"
    assert visited(verdict.space, verdict.fleet, heard[0])
    before = {"leader": Semantics(fleet.vehicles["leader"].net).initial(),
              "follower": heard[0]["follower"]}
    assert not visited(verdict.space, verdict.fleet, before)
