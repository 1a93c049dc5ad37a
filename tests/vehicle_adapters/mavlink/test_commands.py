"""vehicle_adapters/mavlink/commands.py on its own: COMMAND_LONGs, their answers and retries.

No link: ``send`` appends to a list, and the tests answer with COMMAND_ACK messages by hand (or
from a thread, for the calls that wait). Times passed to ``retry`` are the monotonic clock
plus an offset, so nothing sleeps for a retry.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aal.mavlink import MODES
from vehicle_adapters.mavlink.commands import (
    ACK_TIMEOUT,
    ACK_TRIES,
    COMMANDS,
    Commands,
    result_name,
)

ACCEPTED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED


def ack(command: int, result: int = ACCEPTED) -> Any:
    return mavlink.MAVLink_command_ack_message(command, result)


def _commands() -> tuple[Commands, list[Any]]:
    sent: list[Any] = []
    return Commands(sent.append), sent


def test_a_command_is_sent_with_seven_parameters_and_confirmation_zero() -> None:
    commands, sent = _commands()
    assert commands.command(mavlink.MAV_CMD_LOGGING_START, 1, 2) is None  # no wait
    (msg,) = sent
    assert msg.get_type() == "COMMAND_LONG" and msg.command == mavlink.MAV_CMD_LOGGING_START
    assert (msg.confirmation, msg.param1, msg.param2, msg.param7) == (0, 1.0, 2.0, 0.0)
    assert commands.sent == 1 and commands.unanswered() == [mavlink.MAV_CMD_LOGGING_START]


def test_an_ack_answers_the_command_and_in_progress_keeps_it_waiting() -> None:
    commands, _ = _commands()
    cmd = mavlink.MAV_CMD_IMAGE_START_CAPTURE
    commands.command(cmd)
    commands.on_ack(ack(cmd, mavlink.MAV_RESULT_IN_PROGRESS))
    assert commands.unanswered() == [cmd] and commands.acks == 0
    commands.on_ack(ack(mavlink.MAV_CMD_LOGGING_STOP))  # not asked: ignored
    assert commands.unanswered() == [cmd]
    commands.on_ack(ack(cmd))
    assert commands.unanswered() == [] and commands.acks == 1
    assert commands.accepted(cmd) and len(commands.latencies) == 1
    commands.command(cmd)
    commands.on_ack(ack(cmd, DENIED))
    assert not commands.accepted(cmd) and commands.results[cmd] == DENIED


def test_an_unanswered_command_is_sent_again_then_given_up() -> None:
    commands, sent = _commands()
    cmd = mavlink.MAV_CMD_LOGGING_STOP
    commands.command(cmd)
    start = time.monotonic()
    commands.retry(start)  # too early
    assert len(sent) == 1
    for k in range(1, ACK_TRIES):
        commands.retry(start + k * (ACK_TIMEOUT + 0.1))
        assert [m.confirmation for m in sent] == list(range(k + 1))
    commands.retry(start + ACK_TRIES * (ACK_TIMEOUT + 0.1))
    assert len(sent) == ACK_TRIES and commands.unanswered() == []  # dropped


def test_a_lost_link_gives_up_every_command_that_waited() -> None:
    commands, sent = _commands()
    commands.command(mavlink.MAV_CMD_LOGGING_STOP)
    commands.retry(time.monotonic() + ACK_TIMEOUT + 0.1, give_up=True)
    assert commands.unanswered() == [] and len(sent) == 1


def _answering(commands: Commands, sent: list[Any], results: dict[int, int]) -> threading.Thread:
    """A thread that answers each command sent (by ``results``, default accepted)."""
    def run() -> None:
        answered = 0
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and answered < 2:
            if len(sent) > answered:
                cmd = sent[answered].command
                commands.on_ack(ack(cmd, results.get(cmd, ACCEPTED)))
                answered += 1
            time.sleep(0.001)
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_take_control_asks_for_guided_then_arms() -> None:
    commands, sent = _commands()
    _answering(commands, sent, {})
    assert commands.take_control(lambda: 2.0) is None
    assert [m.command for m in sent] == [mavlink.MAV_CMD_DO_SET_MODE,
                                         mavlink.MAV_CMD_COMPONENT_ARM_DISARM]
    assert sent[0].param2 == MODES["GUIDED"] and sent[1].param1 == 1.0


@pytest.mark.parametrize("refused,what", [
    (mavlink.MAV_CMD_DO_SET_MODE, "GUIDED mode"),
    (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, "arming"),
])
def test_take_control_says_what_was_refused(refused: int, what: str) -> None:
    commands, sent = _commands()
    _answering(commands, sent, {refused: DENIED})
    assert commands.take_control(lambda: 2.0) == (what, DENIED)


def test_take_control_without_an_answer() -> None:
    commands, _ = _commands()
    assert commands.take_control(lambda: 0.0) == ("GUIDED mode", None)  # waits 0.1 s at least


def test_confirm_off_says_what_holds() -> None:
    commands, _ = _commands()
    stop = COMMANDS["StartCamera", "disable"]
    commands.command(stop)
    assert commands.confirm_off(["StartCamera"], lambda: [], 0.05) == (
        "NOT confirmed within 0.05 s: 1 command(s) unacknowledged")
    commands.on_ack(ack(stop, DENIED))
    assert commands.confirm_off(["StartCamera"], lambda: [], 0.05) == (
        "NOT confirmed: the vehicle did not accept stopping StartCamera")
    commands.command(stop)
    commands.on_ack(ack(stop))
    assert commands.confirm_off(["StartCamera", "GoTo"], lambda: ["GoTo"], 0.05) == (
        "NOT confirmed within 0.05 s: GoTo still on")
    assert commands.confirm_off(["StartCamera"], lambda: [], 0.05) == (
        "confirmed: every command acknowledged (2 COMMAND_ACKs), no behaviour on")


def test_result_names() -> None:
    assert result_name(None) == "no answer"
    assert result_name(ACCEPTED) == "MAV_RESULT_ACCEPTED"
    assert result_name(9999) == "9999"
