"""Generated missions for benchmarks and scale tests: realistic shapes, any size.

``survey(n)``: n task calls in legs of up to ten, each leg a TRY with a watcher, the whole
inside a TRY on the alarms (the dam mission's shape, repeated). ``fan(k)``: a PARALLEL AND of
k branches, each a short sequence with a timer (k independent monitors).
"""

from __future__ import annotations

import sys


def survey(n: int) -> str:
    """A mission of exactly n task calls (n >= 4)."""
    if n < 4:
        raise ValueError("survey needs at least 4 task calls")
    body_calls = n - 4  # StartLogs x2, Alarms, Surface around the legs
    legs = []
    while body_calls > 0:
        size = min(10, body_calls)
        # a leg: TRY { size-2 tasks } CATCH { watcher } DO { Surface() } uses size calls
        if size < 3:
            legs.append("; ".join(["Wait(1 s)"] * size))
            body_calls -= size
            continue
        inner = []
        for i in range(size - 2):
            inner.append(("GoTo((-2, %d, 2, 0 deg))" % i) if i % 3 == 0 else
                         "WallInspect([(%d, 1), (%d, 3)])" % (i, i) if i % 3 == 1 else
                         "Wait(2 s)")
        legs.append("TRY { " + "; ".join(inner) +
                    " } CATCH { KeepHeadDistException() } DO { Surface() }")
        body_calls -= size
    legs_text = ";\n        ".join(legs) if legs else "Wait(1 s)"
    if not legs:
        n += 1  # one filler call
    return (f"MISSION survey_{n} {{\n    StartLogs(enable);\n    TRY {{\n        {legs_text}\n"
            f"    }} CATCH {{\n        Alarms()\n    }} DO {{\n        Surface()\n    }};\n"
            f"    StartLogs(disable)\n}}\n")


def fan(k: int) -> str:
    """A PARALLEL AND of k branches, each a timer then a watcher bounded in time."""
    branches = [f"{{ Wait({i + 1} s); PARALLEL {{ KeepHeadDistException() }} OR "
                f"{{ Timeout({i + 2} s) }} }}" for i in range(k)]
    return f"MISSION fan_{k} {{\n    PARALLEL " + "\n    AND ".join(branches) + "\n}\n"


if __name__ == "__main__":
    kind, size = sys.argv[1], int(sys.argv[2])
    print(survey(size) if kind == "survey" else fan(size), end="")
