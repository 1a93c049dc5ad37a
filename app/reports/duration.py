"""The duration report of ``mclc``: the proved bounds (mcl/analysis/duration.py) as text and
JSON, and what ``--deadline``, ``--battery`` and ``--reserve`` conclude (docs/DURATION.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from mcl.analysis.duration import Durations, Step, analyse, json_number
from mcl.checker import Checked
from mcl.quantities import parse_battery, parse_deadline, parse_reserve, seconds_text, wh_text

INF = math.inf


def step_text(s: Step) -> str:
    """One step of a path on one line: where, what, how it ends, how long it takes."""
    return f"line {s.line}: {s.text} {s.ending} ({seconds_text(s.seconds)})"


def path_text(d: Durations, indent: str = "  ") -> list[str]:
    """The critical path, up to its first unbounded step (what follows never comes)."""
    out = []
    for s in d.critical_path:
        out.append(indent + step_text(s))
        if not math.isfinite(s.seconds):
            break
    return out


@dataclass
class Verdict:
    """What ``--deadline``, ``--battery`` and ``--reserve`` conclude."""

    failures: list[str]
    lines: list[str]
    report: dict[str, Any]


def judge(d: Durations, deadline: float | None = None, battery_wh: float | None = None,
          reserve: float | None = None) -> Verdict:
    """The text and JSON of the bounds, and the checks asked for (each failure one line)."""
    report = d.to_json()
    lines = [f"  duration: best {seconds_text(d.best)}, worst {seconds_text(d.worst)} "
             "(proved: timeouts and timers only)"]
    if d.estimate is not None:
        lines.append(f"  estimate (not proved): {seconds_text(d.estimate)}")
    failures: list[str] = []
    if deadline is not None:
        report["deadline"] = {"seconds": deadline, "holds": d.worst <= deadline}
        if d.worst > deadline:
            failures.append(f"deadline {seconds_text(deadline)}: some run can take "
                            f"{seconds_text(d.worst)}" if math.isfinite(d.worst) else
                            f"deadline {seconds_text(deadline)}: some run can last for ever"
                            + "".join(f" ({step_text(s)})" for s in d.unbounded[:1]))
        else:
            lines.append(f"  deadline {seconds_text(deadline)} holds for every run")
    if d.energy is not None:
        lines.append(f"  energy: worst {wh_text(d.energy.worst_wh)}")
    if battery_wh is not None:
        worst = d.energy.worst_wh if d.energy is not None else INF
        usable = battery_wh * (1 - (reserve or 0.0))
        margin = battery_wh - worst
        report["battery"] = {"wh": battery_wh, "worst_wh": json_number(worst),
                             "margin_wh": json_number(margin), "reserve": reserve,
                             "usable_wh": usable, "holds": worst <= usable}
        if d.energy is None:
            failures.append("--battery: no task library declares the power of any behaviour "
                            "('behaviour NAME ... power N W;')")
        elif worst > usable:
            what = (f"the {reserve:.0%} reserve ({battery_wh - usable:g} Wh)" if reserve
                    else "the battery")
            failures.append(f"battery {battery_wh:g} Wh: the worst case {wh_text(worst)} eats "
                            f"into {what}")
        else:
            lines.append(f"  battery {battery_wh:g} Wh: margin {wh_text(margin)}"
                         + (f", reserve {reserve:.0%} kept" if reserve else ""))
    if not math.isfinite(d.worst):
        lines.append("  unbounded by:")
        lines += [f"    line {s.line}: {s.text} {s.ending}" for s in d.unbounded[:1]]
        if d.loops:
            lines.append("  loops that can go round for ever (unless a race bounds them):")
            lines += [f"    line {s.line}: {s.text}" for s in d.loops]
    if failures:
        lines += ["  critical path (worst case):"] + path_text(d, "    ")
    report["failures"] = failures
    return Verdict(failures, lines, report)


@dataclass(frozen=True)
class Limits:
    """``mclc --deadline/--battery/--reserve``, parsed (None: not asked)."""

    deadline: float | None = None
    battery_wh: float | None = None
    reserve: float | None = None

    @property
    def asked(self) -> bool:
        return any(x is not None for x in (self.deadline, self.battery_wh, self.reserve))


def parse_limits(deadline: str | None, battery: str | None, reserve: str | None) -> Limits:
    """The three options; ValueError with one clear line for a bad value."""
    if reserve is not None and battery is None:
        raise ValueError(f"--reserve {reserve!r} needs --battery WH (the reserve is a share "
                         "of it), e.g. --battery 800Wh --reserve 20%")
    return Limits(None if deadline is None else parse_deadline(deadline),
                  None if battery is None else parse_battery(battery),
                  None if reserve is None else parse_reserve(reserve))


def check(checked: Checked, limits: Limits) -> Verdict:
    """What mclc calls: the bounds of the checked mission against the limits asked."""
    return judge(analyse(checked), limits.deadline, limits.battery_wh, limits.reserve)
