"""Durations, energies and shares as people write and read them: ``45min``, ``800Wh``, ``20%``.

Parsing the limits a mission is checked against (``mclc --deadline/--battery/--reserve``, or
the same from Python), each refused with one clear line naming the option; and showing
seconds and watt-hours in reports and in the duration analysis' own texts.
"""

from __future__ import annotations

import math

DURATION_UNITS = {"s": 1.0, "sec": 1.0, "ms": 0.001, "min": 60.0, "h": 3600.0}
ENERGY_UNITS = {"Wh": 1.0, "kWh": 1000.0}
SHARE_UNITS = {"%": 0.01}


def parse_quantity(text: str, units: dict[str, float], what: str, example: str) -> float:
    """``45min``, ``1.5 h``, ``120Wh``... into base units; ValueError with one clear line
    that starts with ``what`` (e.g. ``--deadline``) and gives ``example``."""
    raw = text.strip()
    number = raw.rstrip("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ% ")
    unit = raw[len(number):].strip()
    if unit not in units:
        raise ValueError(f"{what} {text!r}: give a unit ({', '.join(units)}), e.g. {example}")
    try:
        value = float(number)
    except ValueError:
        raise ValueError(f"{what} {text!r}: not a number, e.g. {example}") from None
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{what} {text!r}: must be finite and not negative, e.g. {example}")
    return value * units[unit]


def parse_deadline(text: str) -> float:
    """Seconds."""
    return parse_quantity(text, DURATION_UNITS, "--deadline", "--deadline 45min")


def parse_battery(text: str) -> float:
    """Watt-hours."""
    value = parse_quantity(text, ENERGY_UNITS, "--battery", "--battery 800Wh")
    if value == 0:
        raise ValueError(f"--battery {text!r}: must be above 0 Wh, e.g. --battery 800Wh")
    return value


def parse_reserve(text: str) -> float:
    """A fraction in [0, 1)."""
    value = parse_quantity(text, SHARE_UNITS, "--reserve", "--reserve 20%")
    if value >= 1:
        raise ValueError(f"--reserve {text!r}: must be below 100%, e.g. --reserve 20%")
    return value


def seconds_text(s: float) -> str:
    """``90 s``, ``300 s = 5 min``, or ``unbounded``."""
    if not math.isfinite(s):
        return "unbounded"
    if s < 120:
        return f"{s:g} s"
    return f"{s:g} s = {s / 60:.4g} min"


def wh_text(x: float) -> str:
    """``1.5 Wh`` (four significant figures), or ``unbounded``."""
    return f"{x:.4g} Wh" if math.isfinite(x) else "unbounded"
