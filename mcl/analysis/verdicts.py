"""The verdicts mclc keeps between calls: a mission verified once is not verified again until
its text, its task library, its parameters, the options or the code that verifies change.

A verification (mcl/analysis/verification.py) is a function of the compiled mission — its net
and the checked mission, themselves functions of the source (its name and text), the task
library, the parameters' values and, for a fleet's vehicle, its channels — of the options (the
method, the marking limit, the memory budget) and of the code that compiles and verifies (the
``mcl``, ``petri``, ``aal`` and ``diagnostics`` packages). :func:`verified` keys an entry of the
cache (mcl/cache.py) by all of these: what the mission is made from as :func:`canonical` bytes
(:func:`mission_bytes`), the options, and the packages' sources, so an entry is what verifying
that key's inputs gives. A call that
finds its entry loads the report (JSON text and two flags: no numpy, no search); one that does
not verifies and stores it. The entry is named by the mission file's absolute path: writing
one replaces that file's entry under an older key, so the cache holds one verdict per file,
for the :data:`KEEP` files verified last. A mission of more than :data:`MAX_TRANSITIONS` transitions is verified every call.

The report holds ``"cached": true`` when it came from the cache (its ``seconds`` are those of
the verification that made it). The explicit route's engine (numba or numpy) is not in the
key: both give the same verdicts (tests/petri/verification/test_explore_engines.py).
"""

from __future__ import annotations

import io
import json
import os
import pickle
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mcl import cache

if TYPE_CHECKING:
    from mcl.api import Compiled
    from petri.verification.verdict import Verdict

# Larger missions are verified every call. The limit was set when a mission's key was its net
# and checked mission serialised (about 20 us a transition: the 10,000-waypoint lawnmower,
# 110,026 transitions, 2.3 s to key against 2.2 s to verify); the key is now what the mission
# is made from (mission_bytes, a few ms), and the limit is left as it was.
MAX_TRANSITIONS = 50_000
KEEP = 500  # verdicts kept: those of the files verified last
FORMAT = "verdict 1"  # bump when the entry's layout or the report's meaning changes
# The code a verdict is computed by: mcl and the packages below it that the verification
# imports (docs/ARCHITECTURE.md: imports point down).
VERIFIER_CODE = tuple(Path(__file__).resolve().parents[2] / name
                      for name in ("mcl", "petri", "aal", "diagnostics"))


@dataclass
class Report:
    """What mclc reports of a verification: the JSON of the verdict
    (:meth:`~petri.verification.verdict.Verdict.to_json`), whether every property holds, and
    whether one fails."""

    report: dict[str, Any]
    ok: bool
    failed: bool

    @classmethod
    def of(cls, verdict: Verdict) -> Report:
        """The report of a verdict, as plain JSON values (nothing that needs numpy to load)."""
        return cls(json.loads(json.dumps(verdict.to_json(), default=plain)), verdict.ok,
                   verdict.failed)


def plain(value: Any) -> Any:
    """A numpy number of a report as the Python number it holds (json's ``default``)."""
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"not JSON: {type(value).__name__}")


def verified(compiled: Compiled, method: str, max_markings: int, max_bytes: int,
             part: str = "") -> Report:
    """The report of ``verify_mission(compiled, method, max_markings, max_bytes)``, from the
    cache when this mission, these options and this code were verified before. ``part`` names
    the mission within its file when a file holds several (a fleet's vehicle), so that each
    keeps an entry of its own."""

    made: list[Report] = []  # the report verified by this call, if it was

    def build() -> Report:
        # Loaded here, not at the top: it imports numpy (about a third of mclc's start-up),
        # which a call answered from the cache never needs.
        from mcl.analysis.verification import verify_mission

        made.append(Report.of(verify_mission(compiled, method, max_markings=max_markings,
                                             max_bytes=max_bytes)))
        return made[0]

    def parts() -> list[str | bytes]:
        return [FORMAT, method, str(max_markings), str(max_bytes), mission_bytes(compiled),
                cache.code_digest(VERIFIER_CODE)]

    if len(compiled.net.transitions) > MAX_TRANSITIONS:
        return build()  # its key would cost what verifying it does
    place = f"{os.path.abspath(compiled.source.name)}\0{part}"
    where = cache.SHA256(place.encode()).hexdigest()[:16]
    report = cache.cached(f"verdict-{where}", parts, build)
    if made:
        cache.prune("verdict-", KEEP)
        return report
    return Report({**report.report, "cached": True}, report.ok, report.failed)


def mission_bytes(compiled: Compiled) -> bytes:
    """What the compiled mission is made from, as :func:`canonical` bytes: the source's name
    and text, the task library, the parameters' values and, for a fleet's vehicle, its
    channels. Checking and compiling are functions of these (and of the code, in the key
    beside), so they key the verdict as the net and the checked mission would, at a fraction
    of the cost (a thousand latched tasks: 5 ms against 160 ms for the net and the checked
    mission themselves)."""
    checked = compiled.checked
    return canonical((compiled.source.name, compiled.source.text, checked.library,
                      checked.params, checked.fleet))


def canonical(value: object) -> bytes:
    """``value`` pickled without pickle's memo: each object is written out wherever it
    occurs, so the bytes say what the objects hold, not which of them happen to be shared
    (which differs between a library built and one loaded from the cache). A cyclic value
    raises ValueError (the cache is then left aside)."""
    out = io.BytesIO()
    pickler = pickle.Pickler(out, protocol=pickle.HIGHEST_PROTOCOL)
    pickler.fast = True  # no memo
    pickler.dump(value)
    return out.getvalue()
