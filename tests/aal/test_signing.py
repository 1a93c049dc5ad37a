"""aal/signing.py on its own: keys, timestamps and what a signed end accepts, in memory.

Two ends of a link are pymavlink ``MAVLink`` objects joined by bytes (no socket, no process):
one signs what it packs, the other parses it with the checks :func:`aal.signing.enable` sets
up. A message signed with the key is accepted; one signed with another key, or replayed, is
rejected and counted; an unsigned one is accepted unless signing is required (RADIO_STATUS
always passes). Keys come from a file or the environment, as hex digits or a passphrase; the
timestamp never goes back across runs.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega

from aal import signing
from diagnostics import MclError
from tests.support import REPO, budget, free_udp_port, subprocess_env

KEY = bytes(range(32))


class End:
    """One end of a link in memory: what ``enable`` needs of a mavutil connection."""

    setup_signing = mavutil.mavfile.setup_signing

    def __init__(self, system: int) -> None:
        self.mav = ardupilotmega.MAVLink(None, system, 1)
        self.mav.robust_parsing = True  # as mavutil: a rejected message comes as BAD_DATA

    def heartbeat(self) -> bytes:
        return bytes(self.mav.heartbeat_encode(6, 8, 0, 0, 0).pack(self.mav))

    def radio_status(self) -> bytes:
        return bytes(self.mav.radio_status_encode(1, 2, 3, 4, 5, 6, 7).pack(self.mav))

    def receive(self, data: bytes) -> list[str]:
        return [m.get_type() for m in self.mav.parse_buffer(data) or []]


def _enable(end: End, key: bytes = KEY, require: bool = True, **kw: Any) -> signing.SigningState:
    kw.setdefault("timestamp_file", None)
    return signing.enable(end, key, require=require, link_id=kw.pop("link_id", 1), **kw)


# -- what a signed end accepts --------------------------------------------------------------
def test_a_message_signed_with_the_key_is_accepted() -> None:
    sender, receiver = End(1), End(2)
    _enable(sender)
    state = _enable(receiver)
    assert receiver.receive(sender.heartbeat()) == ["HEARTBEAT"]
    assert state.counts() == {"signed": 1, "unsigned": 0, "rejected_unsigned": 0,
                              "rejected_bad": 0}


def test_a_message_signed_with_another_key_or_replayed_is_rejected() -> None:
    sender, stranger, receiver = End(1), End(3), End(2)
    _enable(sender)
    _enable(stranger, hashlib.sha256(b"another key").digest())
    state = _enable(receiver)
    assert receiver.receive(stranger.heartbeat()) == ["BAD_DATA"]
    first, second = sender.heartbeat(), sender.heartbeat()
    assert receiver.receive(second) == ["HEARTBEAT"]
    assert receiver.receive(first) == ["BAD_DATA"]  # an older timestamp: a replay
    assert (state.rejected_bad, state.accepted_signed) == (2, 1)


@pytest.mark.parametrize("require,heartbeat,counts", [
    (True, ["BAD_DATA"], {"unsigned": 1, "rejected_unsigned": 1}),
    (False, ["HEARTBEAT"], {"unsigned": 2, "rejected_unsigned": 0}),
])
def test_unsigned_messages_pass_unless_signing_is_required_but_radio_status_always(
        require: bool, heartbeat: list[str], counts: dict[str, int]) -> None:
    plain, receiver = End(3), End(2)
    state = _enable(receiver, require=require)
    assert receiver.receive(plain.heartbeat()) == heartbeat
    assert receiver.receive(plain.radio_status()) == ["RADIO_STATUS"]
    got = state.counts()
    assert {k: got[k] for k in counts} == counts and got["rejected_bad"] == 0


def test_enable_refuses_a_key_of_the_wrong_size_and_a_bad_link_id() -> None:
    with pytest.raises(signing.SigningError, match="32 bytes, not 31"):
        _enable(End(1), bytes(31))
    with pytest.raises(signing.SigningError, match="link id 256 is not in 0..255"):
        _enable(End(1), link_id=256)


# -- timestamps ------------------------------------------------------------------------------
def test_a_new_run_starts_after_the_timestamp_the_last_one_saved(tmp_path: Path) -> None:
    stamp = tmp_path / "state" / "player.timestamp"
    first = _enable(End(1), timestamp_file=stamp)
    saved = int(stamp.read_text("ascii"))
    assert saved >= first.start_timestamp >= signing.wall_timestamp() - signing.TICKS_PER_SECOND
    ahead = signing.wall_timestamp() + 10**9  # a clock that went back: the saved one is ahead
    stamp.write_text(f"{ahead}\n", "ascii")
    second = _enable(End(1), timestamp_file=stamp)
    assert second.start_timestamp == ahead + signing.SAVE_MARGIN
    assert int(stamp.read_text("ascii")) >= ahead + signing.SAVE_MARGIN


def test_save_moves_the_timestamp_up_to_the_wall_clock_never_back(tmp_path: Path) -> None:
    end = End(1)
    state = _enable(end, timestamp_file=tmp_path / "t")
    end.mav.signing.timestamp = 5  # far behind the wall clock
    state.save()
    assert state.timestamp >= signing.wall_timestamp() - signing.TICKS_PER_SECOND
    ahead = signing.wall_timestamp() + 10**9
    end.mav.signing.timestamp = ahead
    state.advance()
    assert state.timestamp == ahead
    assert not (tmp_path / "t.tmp").exists()  # written atomically


@pytest.mark.parametrize("content,expected", [
    (None, 0), ("", 0), ("junk", 0), ("-5", 0), ("12345\n", 12345),
])
def test_saved_timestamp_is_zero_unless_a_number_was_saved(tmp_path: Path, content: str | None,
                                                           expected: int) -> None:
    path = tmp_path / "t"
    if content is not None:
        path.write_text(content, "ascii")
    assert signing.saved_timestamp(path) == expected
    assert signing.saved_timestamp(None) == 0


def test_the_timestamp_file_is_per_side_and_key_under_the_state_directory(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(signing.ENV_STATE_DIR, str(tmp_path))
    player = signing.default_timestamp_file(KEY, "player")
    assert player == tmp_path / f"mavlink-signing-player-{signing.key_id(KEY)}.timestamp"
    assert signing.default_timestamp_file(KEY, "vehicle") != player
    assert signing.default_timestamp_file(bytes(32), "player") != player
    monkeypatch.delenv(signing.ENV_STATE_DIR)
    assert signing.default_timestamp_file(KEY, "player").parent == (
        Path.home() / ".local" / "state" / "mcl")


def test_key_id_is_short_stable_and_does_not_show_the_key() -> None:
    assert signing.key_id(KEY) == signing.key_id(bytes(KEY))
    assert len(signing.key_id(KEY)) == 16 and signing.key_id(KEY) != signing.key_id(bytes(32))
    assert KEY.hex()[:16] != signing.key_id(KEY)
    assert signing.key_id(KEY) != hashlib.sha256(KEY).hexdigest()[:16]


# -- keys -------------------------------------------------------------------------------------
@pytest.mark.parametrize("text,key", [
    ("ab" * 32, bytes([0xAB]) * 32),
    ("  " + "0F" * 32 + "\n", bytes([0x0F]) * 32),
    ("my passphrase\n", hashlib.sha256(b"my passphrase").digest()),
    ("ab" * 31, hashlib.sha256(("ab" * 31).encode()).digest()),  # not 64 digits: a passphrase
])
def test_a_key_is_64_hex_digits_or_a_passphrase(text: str, key: bytes) -> None:
    assert signing.key_from_text(text, "k") == key


def test_load_key_from_a_file_then_the_environment(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(signing.ENV_KEY, raising=False)
    assert signing.load_key(None) is None
    monkeypatch.setenv(signing.ENV_KEY, "cd" * 32)
    assert signing.load_key(None) == bytes([0xCD]) * 32
    path = tmp_path / "key"
    path.write_text("file phrase", "utf-8")
    assert signing.load_key(str(path)) == hashlib.sha256(b"file phrase").digest()  # file first


@pytest.mark.parametrize("setup,reason", [
    ("missing", "no such signing key file"),
    ("directory", "is a directory, not a signing key file"),
    ("empty", "the signing key is empty"),
    ("binary", "cannot read the signing key"),
])
def test_a_key_that_cannot_be_used_names_its_file(tmp_path: Path, setup: str,
                                                  reason: str) -> None:
    path = tmp_path / "key"
    if setup == "directory":
        path.mkdir()
    elif setup == "empty":
        path.write_text("  \n", "utf-8")
    elif setup == "binary":
        path.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(signing.SigningError) as info:
        signing.load_key(str(path))
    exc = info.value
    assert isinstance(exc, MclError) and isinstance(exc, ValueError)
    assert str(exc).startswith(f"{path}: {reason}")
    assert exc.format().startswith(f"{path}: error: {reason}")
    assert "64 hexadecimal digits" in exc.diagnostics[0].hint


def test_an_empty_key_in_the_environment_names_the_variable(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(signing.ENV_KEY, "")
    with pytest.raises(signing.SigningError, match=r"^\$MCL_MAVLINK_KEY: the signing key is empty"):
        signing.load_key(None)


# -- a restart that lost its state (issue 22) -------------------------------------------------
def test_a_restarted_end_with_no_saved_state_refuses_a_capture_older_than_its_start() -> None:
    """A capture made 30 s before the receiver started (its state lost: no timestamp file) was
    accepted by pymavlink's rule for a new stream (at most a minute behind); the floor, the
    receiver's clock at start minus CLOCK_SKEW, refuses it. A message signed now passes."""
    old, now, receiver = End(1), End(3), End(2)
    _enable(old)
    old.mav.signing.timestamp = signing.wall_timestamp() - 30 * signing.TICKS_PER_SECOND
    capture = [old.heartbeat() for _ in range(3)]
    _enable(now)
    state = _enable(receiver)
    assert state.floor == state.start_timestamp - signing.CLOCK_SKEW
    assert [receiver.receive(c) for c in capture] == [["BAD_DATA"]] * 3
    assert (state.rejected_old, state.rejected_bad, state.accepted_signed) == (3, 3, 0)
    assert receiver.receive(now.heartbeat()) == ["HEARTBEAT"]
    assert state.accepted_signed == 1


def test_a_capture_just_inside_the_skew_passes_and_just_below_the_floor_does_not() -> None:
    receiver = End(2)
    state = _enable(receiver)
    for offset, expected in ((0, ["HEARTBEAT"]), (-1, ["BAD_DATA"])):
        sender = End(1 + (offset < 0) * 2)  # two streams: each is new to the receiver
        _enable(sender)
        sender.mav.signing.timestamp = state.floor + offset
        assert receiver.receive(sender.heartbeat()) == expected, offset
    assert state.rejected_old == 1


def test_with_its_state_kept_the_floor_is_above_the_last_timestamp_saved(tmp_path: Path) -> None:
    stamp = tmp_path / "vehicle.timestamp"
    ahead = signing.wall_timestamp() + 600 * signing.TICKS_PER_SECOND
    stamp.write_text(f"{ahead}\n", "ascii")
    state = _enable(End(2), timestamp_file=stamp)
    assert state.floor == ahead + 1


def test_a_forged_signature_does_not_move_its_stream_timestamp() -> None:
    """pymavlink records a stream's timestamp before it checks the signature: one datagram with
    a wrong signature and the largest timestamp blocked the real sender's stream for good."""
    sender, forger, receiver = End(1), End(1), End(2)
    _enable(sender)
    _enable(forger, hashlib.sha256(b"not the key").digest())
    forger.mav.signing.timestamp = 2**48 - 2  # the largest a signature block holds
    state = _enable(receiver)
    assert receiver.receive(forger.heartbeat()) == ["BAD_DATA"]
    assert receiver.receive(sender.heartbeat()) == ["HEARTBEAT"]
    assert (state.rejected_bad, state.accepted_signed) == (1, 1)


# -- a signing state that cannot be kept is refused at the start (issue 22) ---------------------
def unwritable_state(tmp_path: Path, how: str) -> Path:
    """A state directory enable() cannot write: a file where the directory should be, or a
    read-only directory (only for a user whom permissions bind: not root)."""
    if how == "not a directory":
        (tmp_path / "file").write_text("x", "ascii")
        return tmp_path / "file" / "state"
    if os.geteuid() == 0:
        pytest.skip("root writes into a read-only directory: permissions cannot be tested")
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    return folder


@pytest.mark.parametrize("how", ["not a directory", "read-only"])
def test_a_state_directory_that_cannot_be_written_is_refused_naming_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, how: str) -> None:
    state = unwritable_state(tmp_path, how)
    monkeypatch.setenv(signing.ENV_STATE_DIR, str(state))
    with pytest.raises(signing.SigningError) as caught:
        _enable(End(1), timestamp_file=signing.default_timestamp_file(KEY, "vehicle"))
    text = str(caught.value)
    assert text.startswith(f"${signing.ENV_STATE_DIR} {state}: cannot keep the MAVLink "
                           "signing timestamp"), text
    assert "\n" not in text and "this user can write" in caught.value.format()


def test_without_the_variable_the_refusal_names_the_folder(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    monkeypatch.delenv(signing.ENV_STATE_DIR, raising=False)
    state = unwritable_state(tmp_path, "not a directory")
    with pytest.raises(signing.SigningError) as caught:
        _enable(End(1), timestamp_file=state / "player.timestamp")
    assert str(caught.value).startswith(f"{state}: cannot keep"), str(caught.value)


@pytest.mark.parametrize("command", ["vehicle", "run"])
def test_mcl_refuses_an_unwritable_state_in_one_line_exit_2(tmp_path: Path,
                                                            command: str) -> None:
    state = unwritable_state(tmp_path, "not a directory")
    key = tmp_path / "key"
    key.write_text("a passphrase\n", "ascii")
    port = free_udp_port()
    if command == "vehicle":
        argv = ["vehicle", "--mavlink", f"udpin:127.0.0.1:{port}"]
    else:
        argv = ["run", str(REPO / "missions" / "dam_inspection.mcl"), "--log",
                str(tmp_path / "run.jsonl"), "--vehicle", f"mavlink:udpout:127.0.0.1:{port}"]
    proc = subprocess.run([sys.executable, "-m", "app.mcl", *argv, "--signing-key", str(key)],
                          capture_output=True, text=True, timeout=budget(30),
                          env=subprocess_env(**{signing.ENV_STATE_DIR: str(state)}))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = [line for line in proc.stderr.splitlines() if not line.startswith("  hint:")]
    assert len(lines) == 1, proc.stderr
    assert f"${signing.ENV_STATE_DIR} {state}" in lines[0] and "Not a directory" in lines[0]
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr
