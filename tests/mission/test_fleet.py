"""A fleet in one process (mission/fleet.py, issue 23 deliverable 3): every vehicle's player on
one simulated clock, each on its own simulated vehicle, the channel between them; the runs of
the two-vehicle example under loss 0 to 1 never hang, never outlast the proved worst case,
end with nothing on, and at loss 1.0 the follower surfaces in every run; every exit is a safe
exit for every vehicle."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from diagnostics import MclError
from mcl.fleet import CompiledFleet, compile_fleet_file
from mission import fleet as fleet_module
from mission.fleet import run_fleet
from mission.fleet_evidence import problem, read_record
from mission.limits import mission_bound
from mission.run import NotVerified, Stop
from mission.simulated import simulated_vehicle
from mission.vehicle import Vehicle
from petri.execution.replay import check
from petri.verification.verdict import Result
from petri.execution.runlog import read_log, verify
from tests.mcl.analysis import fleet_missions
from tests.support import REPO
from vehicle.scripted import ScriptedVehicle, parse_script
from vehicle_adapters.inprocess import InProcess

PAIR = REPO / "examples" / "fleet" / "pair.mcl"


def pair() -> CompiledFleet:
    return compile_fleet_file(str(PAIR), require_values=True)


def fleet_vehicles(fleet: CompiledFleet, seed: int = 1) -> dict[str, Vehicle]:
    return {name: simulated_vehicle(seed=seed + i) for i, name in enumerate(fleet.vehicles)}


def active(vehicle: Vehicle) -> list[str]:
    """The behaviours the vehicle has on now."""
    assert isinstance(vehicle.adapter, InProcess)
    on = vehicle.adapter.active()
    assert on is not None  # the simulated vehicles can say
    return on


def lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text("ascii").splitlines()]


@pytest.mark.slow
def test_the_follower_hears_the_leader_after_the_channel_delay_and_the_logs_agree(
        tmp_path: Path) -> None:
    fleet = pair()
    result = run_fleet(fleet, fleet_vehicles(fleet), loss=0.0, seed=1, log_dir=tmp_path)
    assert {n: r.status for n, r in result.runs.items()} == {"leader": "ok", "follower": "ok"}
    assert result.exit == 0
    counts = result.channels["orders"]
    assert (counts["sent"], counts["delivered"], counts["lost"]) == (3, 3, 0)
    sends = [r for r in lines(tmp_path / "leader.jsonl") if r.get("action") == "send"]
    heard = [r for r in lines(tmp_path / "follower.jsonl") if r.get("event") == "orders.go"]
    assert [s["t"] for s in sends] == [0.0, 3.0, 6.0]
    first = heard[0]
    assert 1.0 <= first["t"] - first["data"]["sent"] <= 3.0  # the DELAY range, one clock
    assert first["data"]["sent"] == pytest.approx(sends[0]["t"])
    logs = {}
    for name, compiled in fleet.vehicles.items():  # each log replays on its own net
        records = read_log(tmp_path / f"{name}.jsonl")
        verify(records, tmp_path / f"{name}.jsonl")
        assert check(compiled.net, records, {}).ok
        logs[name] = records
    record = read_record(tmp_path / "channels.jsonl")
    assert problem(fleet, record, tmp_path / "channels.jsonl", logs) is None


@pytest.mark.slow
def test_the_same_seed_gives_the_same_run_and_another_seed_another(tmp_path: Path) -> None:
    fleet = pair()
    records = []
    for i, seed in enumerate([5, 5, 6]):
        run_fleet(fleet, fleet_vehicles(fleet), loss=0.5, seed=seed, log_dir=tmp_path / str(i))
        records.append((tmp_path / str(i) / "channels.jsonl").read_text("ascii")
                       .replace(f'"seed":{seed}', ""))
    assert records[0] == records[1]
    assert records[0] != records[2]


SCRIPT = parse_script({"behaviours": {  # a quick vehicle: every behaviour does as asked
    "GoTo": {"on_enable": {"after": 12.0, "event": "reached"}},
    "Surface": {"on_enable": {"after": 9.0, "event": "surfaced"}}}})


def scripted(fleet: CompiledFleet) -> dict[str, Vehicle]:
    return {name: Vehicle(InProcess(ScriptedVehicle(SCRIPT))) for name in fleet.vehicles}


@pytest.mark.parametrize("loss", [0.0, 0.1, 0.3, 0.5, 1.0])
def test_under_any_loss_every_run_ends_within_its_bound_with_nothing_on(loss: float) -> None:
    fleet = pair()
    bounds = {name: mission_bound(c) for name, c in fleet.vehicles.items()}
    outcomes = set()
    for seed in range(60):
        vehicles = scripted(fleet)
        result = run_fleet(fleet, vehicles, loss=loss, seed=seed, verify=seed == 0)
        for name, run in result.runs.items():
            assert run.status == "ok", (loss, seed, name, run.why)
            bound = bounds[name]
            assert bound is not None and run.time <= bound + 1e-6, (loss, seed, name)
            assert active(vehicles[name]) == [], (loss, seed, name)  # nothing on
        heard = result.channels["orders"]["delivered"]
        follower = result.runs["follower"]
        outcomes.add(heard > 0)
        if heard == 0:  # never heard: it surfaced, its safe end, 20 s + 9 s to the surface
            assert follower.time == pytest.approx(29.0), (loss, seed)
        else:  # it went as soon as it heard the first: within 1 .. 3 s of a send, + 12 s
            assert 13.0 - 1e-6 <= follower.time <= 6.0 + 3.0 + 12.0 + 1e-6, (loss, seed)
    expected = {0.0: {True}, 0.5: {True, False}, 1.0: {False}}  # heard, never heard, both
    assert outcomes == expected.get(loss, outcomes)


def test_on_the_simulated_ictineu_a_silent_link_makes_the_follower_surface() -> None:
    fleet = pair()
    vehicles = fleet_vehicles(fleet, 3)
    result = run_fleet(fleet, vehicles, loss=1.0, seed=3)
    assert result.runs["follower"].status == "ok"
    assert result.runs["follower"].time == pytest.approx(20.0, abs=0.5)
    stack = vehicles["follower"].stack
    assert stack is not None and stack.robot.state.z < 0.5  # at the surface
    assert active(vehicles["follower"]) == []


def test_a_stop_from_outside_stops_every_vehicle_through_its_abort(tmp_path: Path) -> None:
    fleet = pair()
    vehicles = fleet_vehicles(fleet)
    leader = vehicles["leader"].adapter

    def stop() -> Stop | None:
        return Stop("SIGINT received", 2) if leader.now() >= 4.0 else None

    result = run_fleet(fleet, vehicles, loss=1.0, log_dir=tmp_path, stop=stop)
    for name, run in result.runs.items():
        assert run.status == "stopped" and run.exit == 130, name
        end = lines(tmp_path / f"{name}.jsonl")[-1]
        assert end["kind"] == "end" and end["how"] == "signal" and end["exit"] == 130
        assert active(vehicles[name]) == []
    assert lines(tmp_path / "channels.jsonl")[-1]["kind"] == "end"


class Failing:
    """An adapter that raises when it is sent its first GoTo: a vehicle that breaks."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.stack = inner.stack
        self.simulated = True

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def __enter__(self) -> Failing:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def send(self, action: Any) -> None:
        if action.behaviour == "GoTo" and action.kind == "enable":
            raise OSError("the thruster driver is gone")
        self.inner.send(action)


def test_a_vehicle_that_fails_stops_the_others_and_every_log_says_why(tmp_path: Path) -> None:
    fleet = pair()
    vehicles = fleet_vehicles(fleet)
    vehicles["leader"] = Vehicle(Failing(vehicles["leader"].adapter),
                                 stack=vehicles["leader"].stack)
    result = run_fleet(fleet, vehicles, loss=1.0, log_dir=tmp_path)
    assert result.runs["leader"].status == "error"
    follower = result.runs["follower"]
    assert follower.status == "stopped" and follower.how == "fleet"
    assert "leader failed" in follower.reason and follower.time < 20.0
    end = lines(tmp_path / "follower.jsonl")[-1]
    assert end["how"] == "fleet" and end["exit"] == 4 and "leader" in end["why"]
    assert result.exit == 5  # the worst: the vehicle's error


def test_a_time_limit_aborts_each_vehicle_at_its_own_limit(tmp_path: Path) -> None:
    fleet = pair()
    result = run_fleet(fleet, fleet_vehicles(fleet), loss=1.0, max_time=8.0,
                       log_dir=tmp_path)
    follower = result.runs["follower"]
    assert follower.status == "timeout" and follower.reason.endswith("8 s reached")
    assert follower.stop_handler is not None and follower.stop_handler["start"] == 8.0
    assert lines(tmp_path / "follower.jsonl")[-1]["how"] == "time limit"
    assert result.runs["leader"].status == "timeout"  # each at the limit, each through its abort


class Hearing:
    """A vehicle's side of the channels: says where it is, hears what comes."""

    def __init__(self, at: tuple[float, float, float]) -> None:
        self.at = at
        self.got: list[tuple[str, str, dict[str, Any], float]] = []

    def payload(self, channel: str, message: str, t: float) -> dict[str, Any]:
        return {"x": self.at[0], "fix": round(t, 3)}

    def heard(self, channel: str, message: str, data: dict[str, Any], t: float) -> None:
        self.got.append((channel, message, data, t))

    def position(self) -> tuple[float, float, float]:
        return self.at


def test_the_payload_travels_the_delay_grows_with_distance_and_the_modem_hears_it(
        tmp_path: Path) -> None:
    fleet = pair()
    vehicles = fleet_vehicles(fleet)
    leader, follower = Hearing((0.0, 0.0, 0.0)), Hearing((3000.0, 0.0, 0.0))
    vehicles["leader"].modem = leader
    vehicles["follower"].modem = follower
    run_fleet(fleet, vehicles, loss=0.0, log_dir=tmp_path)
    channel, message, data, t = follower.got[0]
    assert (channel, message, data["x"], data["fix"], data["sent"]) == ("orders", "go", 0.0,
                                                                         0.0, 0.0)
    assert t == pytest.approx(0.5 + 3000.0 / 1500.0)  # latency + travel: 2.5 s, in 1 .. 3
    assert leader.got == []  # one way


def test_a_vehicle_that_is_not_simulated_is_refused_before_anything_runs(
        tmp_path: Path) -> None:
    fleet = pair()
    vehicles = fleet_vehicles(fleet)
    vehicles["follower"] = Vehicle(Failing(vehicles["follower"].adapter))
    vehicles["follower"].adapter.simulated = False  # type: ignore[attr-defined]
    with pytest.raises(MclError, match="follower of fleet pair is not simulated"):
        run_fleet(fleet, vehicles, log_dir=tmp_path)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_a_fleet_whose_proof_fails_is_refused_before_anything_runs(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each vehicle verified alone over-approximates the fleet, so a fleet whose vehicles
    pass alone rarely fails as a whole; the refusal is checked on a verdict that fails."""
    fleet = pair()
    failing = Result("fleet-no-deadlock", False, "error", "a vehicle waits for ever", "test")
    monkeypatch.setattr(fleet_module, "verify_fleet",
                        lambda f: SimpleNamespace(results=[failing]))
    with pytest.raises(NotVerified, match="fleet pair: fleet-no-deadlock"):
        run_fleet(fleet, scripted(fleet), log_dir=tmp_path)
    assert list(tmp_path.iterdir()) == []  # nothing written
    monkeypatch.undo()
    good = fleet_missions.fleet()  # paper 003's shape, proved: it runs
    result = run_fleet(good, scripted(good), loss=1.0, log_dir=tmp_path)
    assert all(r.status == "ok" for r in result.runs.values())
