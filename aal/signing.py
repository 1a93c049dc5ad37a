"""MAVLink 2 message signing for both ends of a MAVLink link (the player and the vehicle).

The key is 32 bytes shared by both ends. :func:`load_key` reads it from a file given on the
command line (``--signing-key FILE``) or else from the environment variable ``MCL_MAVLINK_KEY``.
Either holds 64 hexadecimal digits (the key itself) or any other text, a passphrase, which is
hashed with SHA-256 as MAVProxy's ``signing setup PASSPHRASE`` does (so that MAVProxy and mcl
share a key from one passphrase).

:func:`enable` sets up pymavlink's signing on a ``mavutil`` connection: every message sent is
signed; a message received with a wrong signature (wrong key, or a replayed timestamp) is
always rejected; an unsigned one is accepted unless ``require`` is set, in which case only
RADIO_STATUS may come unsigned (as ArduPilot allows, for radios that cannot sign). Rejected
messages never reach the application (pymavlink turns them into BAD_DATA); they are counted in
the returned :class:`SigningState`.

The signing timestamp (10 µs units since 2015-01-01) must never go back for one key, or the
other end would reject our messages as replays. The state persists it in a small file (by
default ``$MCL_STATE_DIR`` or ``~/.local/state/mcl``, one file per key hash and side); a new
run starts after the timestamp saved by the last one plus a margin covering messages signed
after that save (:data:`SAVE_MARGIN`, one second: a run never signs ahead of the wall clock by
more). Call :meth:`SigningState.save` now and then (every few seconds) and at exit: it also
moves the timestamp up to the wall clock, as MAVProxy and ArduPilot do, because pymavlink only
adds one per message and a peer rejects a new stream more than a minute behind its own
timestamp.

Replay across a restart. pymavlink accepts a stream it has not seen (every stream, after a
restart) when its timestamp is at most a minute behind its own: an end that lost its state (a
fresh ``$MCL_STATE_DIR``: a reboot on tmpfs, a new container) would obey a capture of the last
minute. So each end refuses, before pymavlink's checks, every timestamp below a floor: its own
clock when it started minus a skew, or just above the timestamp its last run saved when that
is higher. A timestamp floor, not a handshake: MAVLink 2 signing has no challenge to answer,
and a handshake would be a protocol ArduSub, MAVProxy and QGroundControl do not speak; the
floor needs only the clock the signing timestamps already come from.

The vehicle's skew is :data:`CLOCK_SKEW`, two seconds: a capture signed more than two seconds
before the vehicle started is refused. Its ground station does not lag behind it: pymavlink
moves an end's timestamp up to every signed timestamp it accepts, and the player sends nothing
before it has heard the vehicle, so it signs on the vehicle's clock (or later, if its own is
ahead). The player's skew is :data:`PLAYER_CLOCK_SKEW`, pymavlink's minute: it must hear a
vehicle whose clock is behind its own before the vehicle has heard anything from it (on
``udpin`` it does not even know where the vehicle is until then). The floor trusts the
vehicle's real-time clock: a vehicle without one must set it (NTP, GPS) before it starts, or
keep its state.

A message with a wrong signature leaves its stream's timestamp as it was (pymavlink records it
before checking the signature, so one forged datagram could block a stream for good).
"""

from __future__ import annotations

import hashlib
import os
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from diagnostics import MclError, Span, open_input

ENV_KEY = "MCL_MAVLINK_KEY"
ENV_STATE_DIR = "MCL_STATE_DIR"
EPOCH_2015 = 1420070400  # s: MAVLink signing timestamps count from 2015-01-01 UTC
TICKS_PER_SECOND = 100_000  # a signing timestamp tick is 10 µs
SAVE_MARGIN = TICKS_PER_SECOND  # covers what is signed after a save: 100,000 messages (1 tick each)
CLOCK_SKEW = 2 * TICKS_PER_SECOND  # the vehicle: how far below its clock at start it still accepts
PLAYER_CLOCK_SKEW = 60 * TICKS_PER_SECOND  # the player: pymavlink's window for a new stream
MSG_ID_RADIO_STATUS = 109  # may come unsigned even when signing is required (as ArduPilot)
_HEX_KEY = re.compile(r"[0-9a-fA-F]{64}")
_KEY_HINT = ("a signing key file holds 64 hexadecimal digits or a passphrase "
             f"(or set ${ENV_KEY})")


class SigningError(MclError, ValueError):
    """A key that cannot be used: says which file or variable and why. ``str()`` is
    ``WHERE: reason``; :meth:`format` gives ``WHERE: error: reason`` and a hint."""

    def __init__(self, message: str, where: str | None = None, reason: str = "",
                 hint: str = "") -> None:
        span = Span.of_file(where) if where is not None else None
        super().__init__(reason or message, span=span, hint=hint, code="signing-key",
                         text=message)


def _refuse(where: str, reason: str) -> SigningError:
    return SigningError(f"{where}: {reason}", where, reason, _KEY_HINT)


def key_from_text(text: str, where: str) -> bytes:
    """64 hex digits -> those 32 bytes; any other non-empty text -> SHA-256 of the passphrase."""
    text = text.strip()
    if not text:
        raise _refuse(where, "the signing key is empty")
    if _HEX_KEY.fullmatch(text):
        return bytes.fromhex(text)
    try:  # from the environment, bytes that are not UTF-8 come as surrogates
        data = text.encode("utf-8")
    except UnicodeEncodeError:
        raise _refuse(where, "the signing key is not UTF-8 text") from None
    if len(data) > MAX_KEY_BYTES:
        raise _refuse(where, f"larger than {MAX_KEY_BYTES:,} bytes: not a signing key")
    return hashlib.sha256(data).digest()


MAX_KEY_BYTES = 64 * 1024  # a signing key file: 64 hex digits, or a passphrase


def load_key(path: str | None) -> bytes | None:
    """The signing key from the file ``path``, else from ``$MCL_MAVLINK_KEY``, else None."""
    if path is not None:
        try:
            with open_input(path) as f:  # with a limit: --signing-key /dev/zero
                raw = f.read(MAX_KEY_BYTES + 1)
            if len(raw) > MAX_KEY_BYTES:
                raise _refuse(path, f"larger than {MAX_KEY_BYTES:,} bytes: not a signing key")
            text = raw.decode("utf-8")
        except FileNotFoundError:
            raise _refuse(path, "no such signing key file") from None
        except IsADirectoryError:
            raise _refuse(path, "is a directory, not a signing key file") from None
        except (OSError, UnicodeDecodeError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            raise _refuse(path, f"cannot read the signing key: {reason}") from None
        return key_from_text(text, path)
    env = os.environ.get(ENV_KEY)
    if env is None:
        return None
    return key_from_text(env, f"${ENV_KEY}")


def key_id(key: bytes) -> str:
    """A short public name for a key (a hash of its hash): names its timestamp file."""
    return hashlib.sha256(hashlib.sha256(key).digest()).hexdigest()[:16]


def default_timestamp_file(key: bytes, side: str) -> Path:
    """Where one side (``vehicle`` or ``player``) keeps the last timestamp used with a key."""
    base = os.environ.get(ENV_STATE_DIR)
    root = Path(base) if base else Path.home() / ".local" / "state" / "mcl"
    return root / f"mavlink-signing-{side}-{key_id(key)}.timestamp"


def wall_timestamp() -> int:
    """The signing timestamp of the wall clock now."""
    return int((max(time.time(), EPOCH_2015) - EPOCH_2015) * TICKS_PER_SECOND)


@dataclass
class SigningState:
    """Signing on one connection: counts of what was rejected and the timestamp's file."""

    mav: Any  # the connection's pymavlink MAVLink object (conn.mav)
    require: bool
    timestamp_file: Path | None
    start_timestamp: int = 0  # the first timestamp this run signs with
    floor: int = 0  # the lowest timestamp this run accepts (replays from before it refused)
    rejected_old: int = 0  # of rejected_bad: signed below the floor
    accepted_unsigned: int = 0
    rejected_unsigned: int = 0
    rejected_bad: int = 0
    _seen_bad: int = field(default=0, repr=False)

    @property
    def timestamp(self) -> int:
        """The next timestamp this end signs with."""
        return int(self.mav.signing.timestamp)

    @property
    def accepted_signed(self) -> int:
        return int(self.mav.signing.goodsig_count)

    def allow_unsigned(self, mav: Any, msg_id: int) -> bool:
        """pymavlink's callback for a message without a good signature: accept it or not.

        pymavlink calls it right after counting a bad signature (``badsig_count``), or for a
        message that has no signature at all; the count tells the two apart."""
        bad = mav.signing.badsig_count != self._seen_bad
        self._seen_bad = mav.signing.badsig_count
        if bad:
            self.rejected_bad += 1
            return False
        if self.require and msg_id != MSG_ID_RADIO_STATUS:
            self.rejected_unsigned += 1
            return False
        self.accepted_unsigned += 1
        return True

    def check_signature(self, msgbuf: bytearray, src_system: int, src_component: int) -> bool:
        """pymavlink's check of a signed message (installed in its place by :func:`enable`),
        with two rules first and last: a timestamp below :attr:`floor` is refused, and a
        message whose signature is wrong leaves its stream's timestamp as it was."""
        if signature_timestamp(msgbuf) < self.floor:
            self.rejected_old += 1
            return False
        streams = self.mav.signing.stream_timestamps
        stream = (msgbuf[-13], src_system, src_component)  # (link id, system, component)
        before = streams.get(stream)
        if type(self.mav).check_signature(self.mav, msgbuf, src_system, src_component):
            return True
        if before is None:
            streams.pop(stream, None)
        else:
            streams[stream] = before
        return False

    def advance(self) -> None:
        """Move the timestamp up to the wall clock (never back).

        pymavlink adds one per message signed; without this a long run falls behind the wall
        clock, and a peer that starts later rejects its stream as more than a minute old."""
        self.mav.signing.timestamp = max(self.timestamp, wall_timestamp())

    def save(self) -> None:
        """Advance the timestamp to the wall clock and write it (atomically), so that a
        restart goes on after it. Call it from the thread that sends (it changes the
        timestamp the next message is signed with)."""
        self.advance()
        if self.timestamp_file is None:
            return
        self.timestamp_file.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.timestamp_file.with_suffix(".tmp")
        tmp.write_text(f"{self.timestamp}\n", encoding="ascii")
        os.replace(tmp, self.timestamp_file)

    def counts(self) -> dict[str, int]:
        return {"signed": self.accepted_signed, "unsigned": self.accepted_unsigned,
                "rejected_unsigned": self.rejected_unsigned, "rejected_bad": self.rejected_bad}


def signature_timestamp(msgbuf: bytes | bytearray) -> int:
    """The timestamp in a signed message's signature block (its last 13 bytes: link id,
    timestamp in 6 bytes little-endian, signature in 6)."""
    return int.from_bytes(bytes(msgbuf[-12:-6]), "little")


def saved_timestamp(path: Path | None) -> int:
    """The timestamp a previous run saved in ``path`` (0 when there is none or it is junk)."""
    if path is None:
        return 0
    try:
        return max(0, int(path.read_text(encoding="ascii").strip()))
    except (OSError, ValueError, UnicodeDecodeError):
        return 0


def enable(conn: Any, key: bytes, *, require: bool, link_id: int,
           timestamp_file: Path | None, skew: int = CLOCK_SKEW) -> SigningState:
    """Sign everything ``conn`` (a mavutil connection) sends and check what it receives,
    refusing timestamps ``skew`` ticks or more below this end's clock now."""
    if len(key) != 32:
        raise SigningError(f"a MAVLink signing key has 32 bytes, not {len(key)}")
    if not 0 <= link_id <= 255:
        raise SigningError(f"link id {link_id} is not in 0..255")
    state = SigningState(conn.mav, require, timestamp_file)
    previous, wall = saved_timestamp(timestamp_file), wall_timestamp()
    start = max(wall, previous + SAVE_MARGIN if previous else 0)
    state.start_timestamp = start
    state.floor = max(wall - skew, previous + 1 if previous else 0)
    callback: Callable[[Any, int], bool] = state.allow_unsigned
    conn.setup_signing(key, sign_outgoing=True, allow_unsigned_callback=callback,
                       initial_timestamp=start, link_id=link_id)
    conn.mav.check_signature = state.check_signature  # the floor first, then pymavlink's
    state._seen_bad = int(conn.mav.signing.badsig_count)
    try:
        state.save()
    except OSError as exc:  # without its state, a restarted end would take a replay
        raise state_error(timestamp_file, exc) from None
    return state


def state_error(timestamp_file: Path | None, exc: OSError) -> SigningError:
    """The refusal of a signing state that cannot be written (``$MCL_STATE_DIR`` read-only,
    not a directory, on a full disk): one line naming the directory and why."""
    folder = str(timestamp_file.parent) if timestamp_file is not None else "?"
    given = os.environ.get(ENV_STATE_DIR)
    where = f"${ENV_STATE_DIR} {given}" if given else folder
    reason = (f"cannot keep the MAVLink signing timestamp in {folder} "
              f"({exc.strerror or exc})")
    return SigningError(f"{where}: {reason}", where, reason,
                        f"set ${ENV_STATE_DIR} to a directory this user can write: the "
                        "timestamp kept there refuses a replayed capture after a restart")
