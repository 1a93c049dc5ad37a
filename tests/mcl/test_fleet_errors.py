"""The static errors of a fleet (docs/LANGUAGE.md, "Fleets"): each at file:line:col with its
own code, all of a file reported together."""

from __future__ import annotations

import pytest

from diagnostics import Diagnostic, MclError, Source
from mcl.api import compile_source
from mcl.fleet import compile_fleet_source

GOOD = """\
FLEET pair {
    CHANNEL orders FROM leader TO follower ACOUSTIC DELAY 1 s .. 3 s EVERY 2 s LOSSY
        MESSAGES go, abort;
    VEHICLE leader {
        MISSION lead { Wait(5 s); Send(orders, go) }
    }
    VEHICLE follower {
        MISSION follow { Receive(orders, go, timeout = 2 min) }
    }
}
"""


def _errors(text: str) -> list[Diagnostic]:
    with pytest.raises(MclError) as err:
        compile_fleet_source(Source("pair.mcl", text))
    return [d for d in err.value.diagnostics if d.severity == "error"]


def _one(text: str) -> tuple[str, str]:
    errors = _errors(text)
    assert len(errors) == 1, [e.format() for e in errors]
    return errors[0].code, str(errors[0].span)


def test_the_good_fleet_compiles() -> None:
    assert set(compile_fleet_source(Source("pair.mcl", GOOD)).vehicles) == {"leader",
                                                                            "follower"}


def test_removing_the_timeout_of_a_wait_on_a_lossy_channel_is_refused() -> None:
    text = GOOD.replace("Receive(orders, go, timeout = 2 min)", "Receive(orders, go)")
    assert _one(text) == ("fleet-wait-unbounded", "pair.mcl:8:26")


def test_a_wait_without_timeout_is_allowed_on_a_channel_that_loses_nothing() -> None:
    text = GOOD.replace(" LOSSY", "").replace("Receive(orders, go, timeout = 2 min)",
                                              "Receive(orders, go)")
    compile_fleet_source(Source("pair.mcl", text))


@pytest.mark.parametrize("race", [
    "PARALLEL { Receive(orders, go) } OR { Timeout(30 s) }",
    "PARALLEL { Receive(orders, go); Wait(1 s) } OR { Wait(1 min) }",
    "TRY { Receive(orders, go) } CATCH { Timeout(10 s) } DO { Wait(0 s) }",
])
def test_a_racing_timer_bounds_a_wait_without_timeout(race: str) -> None:
    text = GOOD.replace("Receive(orders, go, timeout = 2 min)", race)
    compile_fleet_source(Source("pair.mcl", text))


@pytest.mark.parametrize("race", [
    # a race that another unbounded wait keeps from ending
    "PARALLEL { Receive(orders, go) } OR { Receive(orders, abort) }",
    # a loop round a bounded race is bounded on each lap, but the unbounded wait is outside
    "Receive(orders, abort); PARALLEL { Wait(1 s) } OR { Timeout(2 s) }",
])
def test_a_race_that_does_not_end_by_itself_bounds_nothing(race: str) -> None:
    text = GOOD.replace("Receive(orders, go, timeout = 2 min)", race)
    assert {e.code for e in _errors(text)} == {"fleet-wait-unbounded"}


def test_an_unbounded_wait_in_on_stop_is_refused_too() -> None:
    text = GOOD.replace("timeout = 2 min) }", "timeout = 2 min) } ON STOP { "
                                              "Receive(orders, abort) }")
    assert _one(text)[0] == "fleet-wait-unbounded"


def test_waiting_on_a_channel_not_directed_to_this_vehicle_is_refused() -> None:
    text = GOOD.replace("Wait(5 s); Send", "Receive(orders, go, timeout = 1 s); Send")
    assert _one(text) == ("fleet-not-receiver", "pair.mcl:5:32")


def test_sending_on_a_channel_that_is_not_from_this_vehicle_is_refused() -> None:
    text = GOOD.replace("MISSION follow { Receive", "MISSION follow { Send(orders, go); "
                                                    "Receive")
    assert _one(text) == ("fleet-not-sender", "pair.mcl:8:31")


def test_an_unknown_channel_or_message_is_named_with_a_suggestion() -> None:
    errors = _errors(GOOD.replace("Send(orders, go)", "Send(order, go); Send(orders, abrt)"))
    assert [(e.code, str(e.span)) for e in errors] == [
        ("fleet-unknown-channel", "pair.mcl:5:40"), ("fleet-unknown-message", "pair.mcl:5:65")]
    assert "did you mean orders?" in errors[0].hint and "did you mean abort?" in errors[1].hint


def test_send_and_receive_take_a_channel_and_a_message() -> None:
    errors = _errors(GOOD.replace("Send(orders, go)", "Send(orders)").replace(
        "timeout = 2 min", "within = 2 min"))
    assert [(e.code, str(e.span)) for e in errors] == [
        ("fleet-bad-arguments", "pair.mcl:5:35"), ("fleet-bad-arguments", "pair.mcl:8:46")]


def test_a_channel_between_vehicles_that_do_not_exist_is_refused() -> None:
    errors = _errors(GOOD.replace("FROM leader TO follower", "FROM leadr TO follower, diver"))
    assert [(e.code, str(e.span)) for e in errors] == [
        ("fleet-vehicle-unknown", "pair.mcl:2:25"), ("fleet-vehicle-unknown", "pair.mcl:2:44")]
    assert "did you mean leader?" in errors[0].hint


@pytest.mark.parametrize(("change", "where"), [
    (("VEHICLE follower", "VEHICLE leader"), "pair.mcl:7:13"),
    (("MESSAGES go, abort", "MESSAGES go, go"), "pair.mcl:3:22"),
    (("TO follower", "TO follower, follower"), "pair.mcl:2:45"),
    (("    VEHICLE leader {", "    CHANNEL orders FROM leader TO follower RADIO DELAY 0 s .. 0 s "
      "MESSAGES go;\n    VEHICLE leader {"), "pair.mcl:4:13"),
])
def test_a_name_declared_twice_is_refused(change: tuple[str, str], where: str) -> None:
    codes = [(e.code, str(e.span)) for e in _errors(GOOD.replace(*change))]
    assert ("fleet-duplicate", where) in codes


@pytest.mark.parametrize(("delay", "where"), [
    ("DELAY 3 s .. 1 s", "pair.mcl:2:59"),      # from more to less
    ("DELAY 1 m .. 3 s", "pair.mcl:2:59"),      # a length
    ("DELAY 1 .. 3 s", "pair.mcl:2:59"),        # no unit
    ("DELAY -1 s .. 3 s", "pair.mcl:2:59"),     # negative
    ("DELAY 1 s .. 3 s EVERY 2 deg", "pair.mcl:2:76"),
])
def test_delays_and_intervals_are_durations_from_least_to_most(delay: str, where: str) -> None:
    assert _one(GOOD.replace("DELAY 1 s .. 3 s EVERY 2 s", delay)) == ("fleet-delay-range",
                                                                       where)


def test_a_channel_to_its_own_sender_or_named_as_the_players_events_is_refused() -> None:
    assert _one(GOOD.replace("TO follower", "TO leader"))[0] == "fleet-loopback"
    text = GOOD.replace("orders", "Link")
    assert "fleet-name-clash" in {e.code for e in _errors(text)}


def test_a_channel_named_after_a_behaviour_of_its_receiver_is_refused() -> None:
    assert _one(GOOD.replace("orders", "GoTo")) == ("fleet-name-clash", "pair.mcl:2:13")


def test_a_fleet_without_vehicles_and_headers_before_fleet_are_refused() -> None:
    assert _one("FLEET empty { }")[0] == "fleet-empty"
    assert _one('USES "ictineu";\n' + GOOD) == ("fleet-header", "pair.mcl:1:1")


def test_the_errors_of_every_vehicle_come_together() -> None:
    text = GOOD.replace("Send(orders, go)", "Send(orders, og)").replace(
        "Receive(orders, go, timeout = 2 min)", "Fly()")
    assert [(e.code, str(e.span)) for e in _errors(text)] == [
        ("fleet-unknown-message", "pair.mcl:5:48"), ("unknown-task", "pair.mcl:8:26")]


def test_send_and_receive_stay_unknown_outside_a_fleet() -> None:
    with pytest.raises(MclError) as err:
        compile_source(Source("m.mcl", "MISSION { Receive(orders, go, timeout = 1 s) }"))
    assert err.value.diagnostics[0].code == "unknown-task"
