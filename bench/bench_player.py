"""Benchmark: the real-time player's event -> action latency and firing rate, with peers.

What is measured, in process, on the same net, with the same events, in the same run:

* latency: from the moment ``handle_event`` is called to the moment the first action record
  reaches an observer (the order that would go to the vehicle), median and p99 over many
  events;
* the whole ``handle_event`` call (the event's firings and every immediate firing after it);
* fired transitions per second (firings / time spent in ``handle_event``).

Implementations, each driven through the same small interface (``start``, ``handle_event``,
observers receiving ``Record``):

* ``petri.execution.player``: the project's player (candidates re-examined by place, heap by index);
* ``naive rescan``: the same rules in plain Python, rescanning every transition after each
  firing (the textbook loop);
* ``pm4py``: the same rules on pm4py's own semantics (``pm4py.objects.petri_net.semantics``:
  ``enabled_transitions`` / ``is_enabled`` / ``execute``) on the net read back from the PNML
  that ``mclc --pnml`` writes.

Every peer must fire exactly the same transitions as the player for the same events (checked:
a peer that disagrees is reported and its figures are not shown).

Workloads: a looping ``WHILE { A() } DO { B() }`` (each event ends one task and starts the
next, 20,000 events), and the dam inspection mission of the paper, run to the end again and
again (``dam``: every behaviour does its job; ``dam leak``: the alarm aborts the survey, the
most firings per event).

Targets: median latency under 100 us, p99 under 1 ms.

    python bench/bench_player.py [--events 20000] [--runs 2000]
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import subprocess
import sys
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))

from mcl.api import compile_file
from petri.net import Net
from petri.execution.player import Player, Record
from petri.semantics import Semantics

MCLC = str(Path(sys.executable).parent / "mclc")
DAM = REPO / "missions" / "dam_inspection.mcl"
LOOP_TASKS = """
behaviour Alpha events ok, fail;
behaviour Beta  events ok, fail;
task A() { start: enable Alpha; ok: Alpha.ok; fail: Alpha.fail; stop: disable Alpha; }
task B() { start: enable Beta;  ok: Beta.ok;  fail: Beta.fail;  stop: disable Beta; }
"""
LOOP_MISSION = "MISSION loop {\n    WHILE { A() } DO { B() }\n}\n"
TARGET_MEDIAN_US, TARGET_P99_US = 100.0, 1000.0


# -- the peers ------------------------------------------------------------------------------
class NaivePlayer:
    """The player's rules (petri/semantics.py), done the obvious way: after every firing,
    rescan every transition for the enabled immediate one of lowest rank. No timers (none
    fall due in these workloads)."""

    name = "naive rescan"

    def __init__(self, net: Net, observers: list[Callable[[Record], None]]):
        self.net = net
        self.rules = Semantics(net)
        self.observers = observers
        self.marking = self.rules.initial()
        self.waiting = self.rules.waiting
        self.fired = 0

    def enabled(self, t: int) -> bool:
        return self.rules.enabled(self.marking, t)

    def fire(self, t: int, now: float, cause: str) -> None:
        tr = self.net.transitions[t]
        self.rules.fire(self.marking, t)
        self.fired += 1
        self.emit(now, "fire", {"transition": tr.name, "cause": cause})
        for a in tr.actions:
            self.emit(now, "action", {"action": a.kind, "behaviour": a.behaviour})

    def emit(self, now: float, kind: str, data: dict[str, Any]) -> None:
        record = Record(now, kind, data)
        for observe in self.observers:
            observe(record)

    def settle(self, now: float) -> None:
        rules = self.rules
        for _ in range(1_000_000):
            ready = [rules.rank[t] for t in range(len(self.net.transitions))
                     if rules.immediate[t] and self.enabled(t)]
            if not ready:
                return
            self.fire(min(ready)[1], now, "immediate")

    def start(self, now: float) -> None:
        self.settle(now)

    def handle_event(self, event: str, now: float) -> int:
        waiting = [t for t in self.waiting.get(event, []) if self.enabled(t)]
        count = 0
        for t in waiting:
            if self.enabled(t):
                self.fire(t, now, event)
                count += 1
        self.settle(now)
        return count


class Pm4pyPlayer(NaivePlayer):
    """The same rules on pm4py's semantics and marking, on the net read from our PNML."""

    name = "pm4py semantics"

    _read: ClassVar[dict[Path, tuple[Any, Any, list[Any]]]] = {}  # each PNML read once

    def __init__(self, net: Net, observers: list[Callable[[Record], None]], pnml: Path):
        super().__init__(net, observers)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            import pm4py
            from pm4py.objects.petri_net import semantics
        self.semantics = semantics
        if pnml not in self._read:
            with warnings.catch_warnings():  # "imported without a final marking"
                warnings.simplefilter("ignore")
                pn, marking, _ = pm4py.read_pnml(str(pnml))
            # PNML transition ids in document order are the net's transition order
            tag = "{http://www.pnml.org/version-2009/grammar/pnml}transition"
            ids = [t.get("id") for t in ET.parse(pnml).getroot().iter(tag)]
            by_id = {t.name: t for t in pn.transitions}
            self._read[pnml] = (pn, marking, [by_id[i] for i in ids])
        self.pn, initial, self.pm_transitions = self._read[pnml]
        self.pm_marking = copy.copy(initial)
        self.index = {t: i for i, t in enumerate(self.pm_transitions)}

    def enabled(self, t: int) -> bool:
        return bool(self.semantics.is_enabled(self.pm_transitions[t], self.pn, self.pm_marking))

    def fire(self, t: int, now: float, cause: str) -> None:
        self.pm_marking = self.semantics.execute(self.pm_transitions[t], self.pn,
                                                 self.pm_marking)
        tr = self.net.transitions[t]
        self.fired += 1
        self.emit(now, "fire", {"transition": tr.name, "cause": cause})
        for a in tr.actions:
            self.emit(now, "action", {"action": a.kind, "behaviour": a.behaviour})

    def settle(self, now: float) -> None:
        transitions = self.net.transitions
        while True:
            enabled = self.semantics.enabled_transitions(self.pn, self.pm_marking)
            ready = [self.rules.rank[self.index[t]] for t in enabled
                     if transitions[self.index[t]].immediate]
            if not ready:
                return
            self.fire(min(ready)[1], now, "immediate")


# -- measuring ------------------------------------------------------------------------------
@dataclass
class Probe:
    """An observer that notes when the first action after an event arrives."""

    armed: bool = False
    at: int = 0
    fired: list[str] = field(default_factory=list)

    def __call__(self, record: Record) -> None:
        if record.kind == "action" and self.armed:
            self.at = time.perf_counter_ns()
            self.armed = False
        elif record.kind == "fire":
            self.fired.append(record.data["transition"])


@dataclass
class Figures:
    latency_ns: list[int] = field(default_factory=list)
    handle_ns: list[int] = field(default_factory=list)
    firings: int = 0
    sequence: list[str] = field(default_factory=list)


Factory = Callable[[Net, list[Callable[[Record], None]]], Any]


def drive(make: Factory, net: Net, scripts: list[list[str]], figures: Figures) -> None:
    """Start a player per script and feed it the script's events, one per simulated second."""
    for events in scripts:
        probe = Probe()
        player = make(net, [probe])
        player.start(0.0)
        for i, event in enumerate(events, start=1):
            before = player.fired
            probe.armed = True
            t0 = time.perf_counter_ns()
            player.handle_event(event, float(i))
            t1 = time.perf_counter_ns()
            figures.handle_ns.append(t1 - t0)
            figures.firings += player.fired - before
            if not probe.armed:  # an action went out
                figures.latency_ns.append(probe.at - t0)
        figures.sequence.extend(probe.fired)


def pct(values: list[int], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] / 1e3  # us


def pnml_of(mission: Path, tasks: list[Path], out: Path) -> Path:
    args = [MCLC, str(mission), "--no-verify", "--pnml", str(out)]
    for t in tasks:
        args += ["--tasks", str(t)]
    subprocess.run(args, check=True, capture_output=True, timeout=120)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--events", type=int, default=20_000, help="events for the WHILE loop")
    ap.add_argument("--runs", type=int, default=2_000, help="runs of the dam mission")
    ap.add_argument("--peer-share", type=float, default=0.25,
                    help="fraction of the workload given to the (slow) peers")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        (tmp / "loop.tasks").write_text(LOOP_TASKS)
        (tmp / "loop.mcl").write_text(LOOP_MISSION)
        loop_net = compile_file(str(tmp / "loop.mcl"), [str(tmp / "loop.tasks")]).net
        dam_net = compile_file(str(DAM)).net
        loop_pnml = pnml_of(tmp / "loop.mcl", [tmp / "loop.tasks"], tmp / "loop.pnml")
        dam_pnml = pnml_of(DAM, [], tmp / "dam.pnml")

        loop_events = ["Alpha.ok" if i % 2 == 0 else "Beta.ok" for i in range(args.events)]
        dam_ok = ["GoTo.reached", "AchieveHeadDist.achieved", "WallInspection.done",
                  "GoTo.reached"]
        dam_leak = ["GoTo.reached", "AchieveHeadDist.achieved", "Alarms.leak",
                    "Surface.surfaced"]
        workloads = [
            ("WHILE loop", loop_net, loop_pnml, lambda n: [loop_events[:n]], args.events),
            ("dam", dam_net, dam_pnml, lambda n: [dam_ok] * n, args.runs),
            ("dam leak", dam_net, dam_pnml, lambda n: [dam_leak] * n, args.runs),
        ]
        implementations: list[tuple[str, Callable[[Net, Path], Factory], float]] = [
            ("petri.execution.player", lambda net, pnml: lambda n, obs: Player(n, observers=obs), 1.0),
            ("naive rescan", lambda net, pnml: lambda n, obs: NaivePlayer(n, obs),
             args.peer_share),
            ("pm4py semantics",
             lambda net, pnml: (lambda n, obs, _p=pnml: Pm4pyPlayer(n, obs, _p)),
             args.peer_share),
        ]

        print(f"{'workload':<11} {'implementation':<16} {'events':>7} "
              f"{'latency med':>11} {'p99':>8} {'handle med':>10} {'p99':>8} "
              f"{'firings/s':>11} {'med ratio':>9} {'rate ratio':>10}")
        print("-" * 110)
        verdicts = []
        for label, net, pnml, scripts, size in workloads:
            ours: Figures | None = None
            for impl, factory, share in implementations:
                n = max(1, int(size * share))
                # the same events for everyone when comparing sequences
                figures = Figures()
                make = factory(net, pnml)
                drive(make, net, scripts(n), figures)
                if ours is None:
                    ours = figures
                    reference = figures.sequence
                else:
                    m = len(figures.sequence)
                    if figures.sequence != reference[:m]:
                        first = next(i for i, (a, b) in enumerate(zip(figures.sequence,
                                                                      reference)) if a != b)
                        print(f"{label:<11} {impl:<16} DISAGREES with petri.execution.player at firing "
                              f"{first}: {figures.sequence[first]} vs {reference[first]}")
                        continue
                rate = figures.firings / (sum(figures.handle_ns) / 1e9)
                med = pct(figures.latency_ns, 0.5)
                p99 = pct(figures.latency_ns, 0.99)
                hmed = pct(figures.handle_ns, 0.5)
                hp99 = pct(figures.handle_ns, 0.99)
                if figures is ours:
                    ratio_med, ratio_rate = "1.0", "1.0"
                    ours_med, ours_rate = med, rate
                    verdicts.append((label, med, p99))
                else:
                    ratio_med = f"{med / ours_med:.1f}x"
                    ratio_rate = f"{ours_rate / rate:.1f}x"
                print(f"{label:<11} {impl:<16} {len(figures.handle_ns):>7} "
                      f"{med:>9.1f}us {p99:>6.1f}us {hmed:>8.1f}us {hp99:>6.1f}us "
                      f"{rate:>11,.0f} {ratio_med:>9} {ratio_rate:>10}")
            print()

    print("ratios: a peer's median latency / the player's, and the player's firing rate / "
          "the peer's (above 1: the player is faster)")
    print(f"targets: median latency under {TARGET_MEDIAN_US:g} us, p99 under "
          f"{TARGET_P99_US:g} us (petri.execution.player)")
    for label, med, p99 in verdicts:
        ok = med < TARGET_MEDIAN_US and p99 < TARGET_P99_US
        print(f"  {label:<11} median {med:7.1f} us  p99 {p99:7.1f} us  "
              f"{'met' if ok else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
