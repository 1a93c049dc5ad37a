"""A run as a library call: :func:`run_mission` runs a compiled mission on a vehicle, with its
time bound, its capability check, its verification, its run log and its safe exit, and returns
what happened as a :class:`RunResult`.

    from mcl.api import compile_file
    from mission import run_mission, simulated_vehicle

    result = run_mission(compile_file("missions/dam_inspection.mcl", require_values=True),
                         simulated_vehicle(seed=2), log="out/runs/dam.jsonl")
    print(result.status, result.time, result.firings, result.exit)

The steps, in order:

1. the time bound (:func:`mission.limits.max_time`);
2. the capability check with the vehicle's declaration, if known before connecting
   (:func:`mission.capabilities.check_capabilities`: an :class:`~diagnostics.MclError`, and
   nothing is written or sent);
3. verification (:func:`mcl.analysis.verification.verify_mission`): an unverified mission is
   refused (:class:`NotVerified`) unless ``verify=False``;
4. the run log opens (its header); the vehicle is connected (``waiting`` hears, every second,
   how long it has been waiting); a link lost while connecting with no vehicle that ever
   answered (no HEARTBEAT, no liveliness token) is :class:`NoVehicle`: the mission never
   started, nothing was sent, and the end record says so (``how: "no vehicle"``, exit 6); a
   vehicle that answered but refused the run (GUIDED, arming, access control) is
   ``Link.lost`` for the mission, as a loss later is; a remote vehicle's own declaration
   is checked again (a refusal now is logged: the end record says ``refused``, exit 2);
5. the player and the runner (:func:`petri.execution.runner.run`), which end every run that
   does not end by itself through the mission's abort; a run log that cannot be written (a
   full disk, its folder removed) is one reason (:mod:`mission.logwriter`: ``how: "log
   failed"``, exit 4, the end record handed back as ``RunResult.unwritten``);
6. the end record: how and why the run ended, its exit status (:mod:`mission.exits`), what was
   switched off and what the vehicle confirmed of it, and every event a CATCH handled
   (``handled``: :mod:`mission.handled`). A handled alarm does not change the exit status: a
   mission that caught a leak and surfaced as written ends OK (exit 0), and says so; a handler
   that ends with the core library's ``Fail()`` ends the mission FAIL (exit 1). A bug of ours still writes it (``error``,
   exit 3) before the exception goes on.

The run log also takes, once a minute of mission time, how far along each long task is when
its vehicle says (``progress`` records: :mod:`mission.progress`), and, when ``track`` is
given, the vehicle's pose once a second (``pose`` records: :mod:`mission.poses`).

Nothing here is process-wide: no signal handler (``stop`` asks for a stop; ``mcl run`` turns
signals into it), no printing (``observers`` see every record; the caller prints), no global
state. Several runs go side by side in one process, one thread each (examples/two_vehicles.py).
"""

from __future__ import annotations

import contextlib
import dataclasses
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from diagnostics import MclError
from mcl.analysis.verification import verify_mission
from mcl.api import Compiled
from petri.execution.player import MAX_FIRINGS_PER_INSTANT, Order, Player, Record
from petri.execution.runlog import RunLog, net_digest
from petri.execution.runner import MissionClock, Outcome, run
from petri.execution.signing import Signer
from petri.execution.status import MissionStatus

from mission.blocks import BlockStates
from mission.capabilities import check_capabilities
from mission.exits import Exit, run_exit
from mission.stop_handler import StopWatch, as_record, bound
from mission.handled import CatchWatch, Handled
from mission.limits import max_time as time_bound
from mission.logwriter import LogUnwritable, LogWriter
from mission.poses import PoseLog, Track
from mission.progress import ProgressLog
from mission.vehicle import Answers, Vehicle

if TYPE_CHECKING:
    from aal.messages import Vehicle as Adapter

HOW = {"ok": "ok", "fail": "fail", "timeout": "time limit", "stuck": "stuck",
       "stopped": "signal", "error": "error", "zeno": "zeno"}  # the runner's status -> the end record's how
TIME_NOTE = "mission time: 0 at the mission's start"
PROGRESS_EVERY = 1.0  # wall s between two words of progress while connecting


@dataclass(frozen=True)
class Stop:
    """A request to stop a run now: why, and the signal that asked (None: not a signal; the
    run's exit status is then 128 + N)."""

    reason: str
    signal: int | None = None
    count: int = 1  # the how-many-th request this is: a new one halts the stop handler
    how: str = "signal"  # the end record's how for a run this stopped


class NotVerified(MclError):
    """The mission is not verified, so it is not run (nothing was written or sent)."""

    def __init__(self, failed: list[str]):
        self.failed = failed  # the error-level properties not established
        message = f"not verified ({', '.join(failed)}): refusing to run it"
        super().__init__(message, hint="mclc shows why; verify=False runs it anyway",
                         code="not-verified", text=message)


class NoVehicle(MclError):
    """No vehicle answered while connecting: the mission never started and nothing was
    sent. ``reason``: what the link says, e.g. "no vehicle answered
    at udpin:127.0.0.1:14550 within 10 s (no HEARTBEAT)"."""

    def __init__(self, reason: str):
        self.reason = reason
        message = f"{reason}: the mission never started"
        super().__init__(message, hint="start the vehicle first (mcl vehicle), or check "
                         "--vehicle", code="no-vehicle", text=message)


@dataclass(frozen=True)
class RunResult:
    """What a run did: how it ended, when, and what its end record says."""

    mission: str  # the mission's name
    status: str  # how the runner ended it: ok, fail, timeout, stuck, stopped, error, zeno
    how: str  # the end record's how: ok, fail, time limit, stuck, signal, error, zeno
    time: float  # mission time at the end, s
    reason: str  # why the runner stopped it ("" when the mission ended by itself)
    why: str  # the end record's why
    exit: int  # the exit status of the run (mission.exits; docs/EXIT.md)
    firings: int  # transitions fired
    switched_off: tuple[str, ...]  # the behaviours the abort switched off
    confirmed: str  # what the vehicle confirmed of the switch-off
    limit: float  # the mission time limit, s
    limit_from: str  # where the limit comes from
    log: Path | None  # the run log (None: none was written)
    vehicle_clock: tuple[float, float] | None  # the vehicle's clock at start and end, when it
    #                                            differs from mission time
    handled: tuple[Handled, ...] = ()  # every event a CATCH handled, in order
    stop_handler: dict[str, Any] | None = None  # how the ON STOP handler went, if it ran
    unwritten: Mapping[str, Any] | None = None  # the end record the run log could not take
    #   (a full disk, its folder removed): the caller puts it where it still can
    log_failure: str = ""  # why the run log is incomplete ("": it is whole)

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def run_mission(compiled: Compiled, vehicle: Vehicle | Adapter, *,
                log: str | Path | None = None, header: Mapping[str, Any] | None = None,
                max_time: float | None = None,
                stop: Callable[[], Stop | str | None] | None = None,
                observers: Iterable[Callable[[Record], None]] = (), verify: bool = True,
                clock: MissionClock | None = None,
                end_note: Callable[[], str | None] | None = None,
                during: contextlib.AbstractContextManager[Any] | None = None,
                waiting: Callable[[str, float], None] | None = None,
                max_firings_per_instant: int = MAX_FIRINGS_PER_INSTANT,
                signer: Signer | None = None,
                sender: Callable[[Order], None] | None = None,
                track: Track | None = None) -> RunResult:
    """Run ``compiled`` on ``vehicle`` to its end (the steps: this module's docstring).

    ``log``: the run log's path (None: no log); ``header``: what its header says of the run
    besides the mission, its file and its net (parameters, tasks, vehicle...); ``max_time``:
    the mission time limit, s (None: from the mission's timeouts); ``stop``: called every
    round, returns why to stop now (a :class:`Stop` or a reason) or None; ``observers``: see
    every record of the player, after the log (one with a ``tick(t)`` method is also told
    the mission time at every round of the runner: progress reports); ``verify``: refuse an unverified mission
    (:class:`NotVerified`); ``clock``: the mission clock, for an observer that shows the
    vehicle's clock beside mission time; ``end_note``: what the end record's why adds, asked
    once the run has ended; ``during``: entered once the mission is checked and verified,
    before its log opens, and left after its end record (``mcl run``'s signal handlers);
    ``waiting``: told ``(where, seconds)`` every second while a vehicle with a link is being
    connected (``mcl run``'s progress); ``max_firings_per_instant``: past this many firings at one mission instant the player
    stops the mission through its abort (a loop that goes round without time passing: the
    end record's how is ``zeno``, exit 4); ``signer``: the key that signs every line of the
    log (:mod:`petri.execution.signing`; None: the log is chained, not signed); ``sender``:
    where the mission's ``Send`` actions go (a fleet's channel: :mod:`mission.fleet`);
    ``track``: the vehicle's poses so far, of which the run log takes one a second
    (:mod:`mission.poses`; None: the log holds no poses).
    Raises :class:`~diagnostics.MclError` when the vehicle cannot run the mission (before
    the first action), :class:`NoVehicle` when no vehicle answered while connecting."""
    limit = time_bound(compiled, max_time)
    chosen = vehicle if isinstance(vehicle, Vehicle) else Vehicle.around(vehicle)
    said = chosen.declares.declaration() if chosen.declares is not None else None
    if said is not None:  # known before connecting: refuse now
        check_capabilities(compiled, said)
    if verify:
        verdict = verify_mission(compiled, "auto")
        if not verdict.ok:
            raise NotVerified([r.name for r in verdict.results
                               if not r.holds and r.severity == "error"])
    name = compiled.name
    about = {"mission": name, "file": compiled.source.name, "net": net_digest(compiled.net),
             **(header or {}), "max_time": limit[0], "time": TIME_NOTE}
    play = _Play(compiled, chosen, name, Player(compiled.net,
                        max_firings_per_instant=max_firings_per_instant, sender=sender),
                 clock if clock is not None else MissionClock())
    with contextlib.ExitStack() as held:
        if during is not None:
            held.enter_context(during)
        poses = (PoseLog(track, lambda: play.clock.origin) if track is not None
                 else None)
        opened = (held.enter_context(_open_log(log, about, signer, poses))
                  if log is not None else None)
        outcome = play.run(opened, observers, limit[0], stop, waiting)
        result = play.result(outcome, end_note, limit, opened)
        if opened is not None:
            opened.end(max(outcome.time, play.last_t), result.how, result.why,
                       exit=result.exit, status=play.player.status,
                       vehicle_t=round(play.clock.vehicle(outcome.time), 6),
                       vehicle_t0=round(play.clock.origin or 0.0, 6),
                       switched_off=outcome.switched_off, confirmed=outcome.confirmed,
                       limit=limit[0], limit_from=limit[1],
                       handled=[h.as_record() for h in result.handled],
                       **({"stop_handler": result.stop_handler} if result.stop_handler
                          else {}))
            if opened.unwritten is not None:
                result = dataclasses.replace(result, unwritten=opened.unwritten,
                                             log_failure=opened.failure)
    return result


@contextlib.contextmanager
def _open_log(path: str | Path, about: dict[str, Any], signer: Signer | None = None,
              poses: PoseLog | None = None) -> Iterator[LogWriter]:
    """The run log, open (signed by ``signer``, if given), behind its :class:`LogWriter`
    (which logs ``poses``, if given); one whose header cannot be written is
    :class:`LogUnwritable`."""
    try:
        log = RunLog(path, about, signer)
    except OSError as exc:
        raise LogUnwritable(path, exc) from None
    try:
        yield LogWriter(log, poses)
    finally:
        with contextlib.suppress(OSError):  # what a full disk did not take: said already
            log.close()


@contextlib.contextmanager
def connecting(chosen: Vehicle, waiting: Callable[[str, float], None] | None
               ) -> Iterator[None]:
    """While the vehicle is being connected: ``waiting(where, seconds)`` every second, from a
    thread of its own (the connection blocks this one), for a vehicle with a link."""
    if waiting is None or chosen.link is None:
        yield
        return
    done = threading.Event()
    started = time.monotonic()

    def tick() -> None:
        while not done.wait(PROGRESS_EVERY):
            waiting(chosen.where or "the vehicle", time.monotonic() - started)

    ticker = threading.Thread(target=tick, name="connecting", daemon=True)
    ticker.start()
    try:
        yield
    finally:
        done.set()
        ticker.join()


class _Play:
    """One run's player on its vehicle, from connecting to the outcome."""

    def __init__(self, compiled: Compiled, chosen: Vehicle, name: str, player: Player,
                 clock: MissionClock):
        self.compiled, self.chosen, self.name = compiled, chosen, name
        self.player, self.clock = player, clock
        self.last_t = 0.0  # the mission time of the last record (the end never goes back)
        self.stopped: list[Stop] = []  # the stops asked for, first first
        self.catches = CatchWatch(compiled)  # what the CATCH blocks handled
        self.stop_watch = StopWatch()  # how the ON STOP handler ended

    def seen(self, record: Record) -> None:
        self.last_t = record.t

    def run(self, opened: LogWriter | None, observers: Iterable[Callable[[Record], None]],
            limit: float, stop: Callable[[], Stop | str | None] | None,
            waiting: Callable[[str, float], None] | None = None) -> Outcome:
        """Connect, check the vehicle's own word, and run; no vehicle, a refusal or a bug of
        ours is logged (the end record) before it goes on."""
        chosen, player = self.chosen, self.player
        try:
            with contextlib.ExitStack() as held:
                with connecting(chosen, waiting):
                    held.enter_context(chosen.adapter)
                link = chosen.link
                if (link is not None and link.lost and isinstance(link, Answers)
                        and not link.answered):  # nobody there: the mission never starts
                    raise NoVehicle(link.lost_reason or "no vehicle answered")
                if chosen.declares is not None:
                    said = chosen.declares.declaration()  # a remote vehicle's own word
                    if said is not None:
                        check_capabilities(self.compiled, said)
                if opened is not None:
                    player.observers.append(opened)
                player.observers.extend((self.seen, self.catches, self.stop_watch))
                if chosen.status is not None:  # observers of the mission: mcl monitor, view
                    blocks = BlockStates(player.net)  # the status carries each block's state
                    publish = chosen.status.publish_status
                    player.observers.extend((blocks, MissionStatus(
                        player, self.name, chosen.status.run,
                        lambda view: publish({**view, "blocks": blocks.now()}),
                        vehicle_time=self.clock.vehicle,
                        progress=getattr(chosen.adapter, "progress", None))))
                player.observers.extend(observers)
                told = getattr(chosen.adapter, "progress", None)
                if opened is not None and callable(told):  # long tasks' progress, logged
                    player.observers.append(ProgressLog(player.net, told, opened.progress))
                # an observer with a tick(t) is told the mission time at every round
                rounds = [tick for o in player.observers
                          if callable(tick := getattr(o, "tick", None))]
                return run(player, chosen.adapter, self.name, max_time=limit,
                           stop=self.asking(stop, opened), clock=self.clock,
                           stop_bound=bound(self.compiled.checked), rounds=rounds)
        except NoVehicle as exc:  # the mission never started: nothing was sent
            if opened is not None:
                opened.end(0.0, "no vehicle", str(exc), exit=Exit.NO_VEHICLE,
                           status=player.status)
            raise
        except MclError as exc:  # refused, or a vehicle that cannot be reached: nothing sent
            first = exc.diagnostics[0].message if exc.diagnostics else str(exc)
            if opened is not None:
                opened.end(self.last_t, "refused", first, exit=Exit.INVALID,
                           status=player.status)
            raise
        except Exception as exc:  # a bug of ours: the log still says how the run ended
            if opened is not None:
                opened.end(self.last_t, "error", f"internal error: {type(exc).__name__}: "
                           f"{exc}", exit=Exit.INTERNAL, status=player.status)
            raise

    def asking(self, stop: Callable[[], Stop | str | None] | None,
               opened: LogWriter | None = None) -> Callable[[], str | None] | None:
        """The runner's ``stop``: the reason of a new request (None: none since the last), the
        requests remembered; a run log that cannot be written asks for one too. A request is
        new when its ``count`` or its reason differs from the last one's."""
        if stop is None and opened is None:
            return None

        def reason() -> str | None:
            failed = opened.stop() if opened is not None else None
            asked: Stop | str | None = (Stop(failed, how="log failed") if failed
                                        else stop() if stop is not None else None)
            if asked is None:
                return None
            request = asked if isinstance(asked, Stop) else Stop(str(asked))
            if self.stopped and (self.stopped[-1].count, self.stopped[-1].reason) == (
                    request.count, request.reason):
                return None  # asked already
            self.stopped.append(request)
            return request.reason

        return reason

    def result(self, outcome: Outcome, end_note: Callable[[], str | None] | None,
               limit: tuple[float, str], opened: LogWriter | None) -> RunResult:
        """The run's result, as its end record will say it."""
        link = self.chosen.link
        why = outcome.reason or ("the mission ended " + outcome.status.upper())
        if link is not None and link.lost:
            why += f" (Link.lost: {link.lost_reason or 'the link was lost'})"
        note = end_note() if end_note is not None else None
        if note:
            why += "; " + note
        signum = self.stopped[0].signal if self.stopped else None
        how = HOW.get(outcome.status, outcome.status)
        if outcome.status == "stopped" and self.stopped:
            how = self.stopped[0].how
        clock = self.clock
        return RunResult(
            mission=self.name, status=outcome.status, how=how, time=outcome.time,
            reason=outcome.reason, why=why, exit=int(run_exit(outcome.status, signum)),
            firings=self.player.fired, switched_off=tuple(outcome.switched_off),
            confirmed=outcome.confirmed, limit=limit[0], limit_from=limit[1],
            log=opened.path if opened is not None else None,
            vehicle_clock=((clock.vehicle(0.0), clock.vehicle(outcome.time))
                           if clock.origin else None),
            handled=tuple(self.catches.handled),
            stop_handler=(as_record(outcome.stop_handler, self.stop_watch)
                          if outcome.stop_handler is not None else None))
