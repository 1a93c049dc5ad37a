"""``mclc FLEET.mcl``, second part: the fleet's own properties (docs/METHODS.md, "Fleets:
what is proved"), after each vehicle's.

``--method`` chooses the route: ``explicit`` explores the product of the vehicles' nets and
channels; ``compositional`` proves each vehicle alone against its channels' contract;
``auto`` (default) takes the product when the vehicles alone bound it within
``--max-memory``, else the compositional route; ``structural`` (a single mission's route)
takes the compositional route for the fleet. ``--max-markings`` and ``--max-memory`` bound
every exploration.
"""

from __future__ import annotations

import argparse
from typing import Any

from mcl.fleet import CompiledFleet

from app.reports.fleet import fleet_text
from mission.exits import Exit

FLEET_METHOD = {"auto": "auto", "explicit": "explicit", "compositional": "compositional",
                "structural": "compositional"}


def vehicle_method(method: str) -> str:
    """The route each vehicle's own properties take when the fleet's is ``method``."""
    return "auto" if method == "compositional" else method


def prove_fleet(fleet: CompiledFleet, args: argparse.Namespace, fmt: str
                ) -> tuple[Exit, dict[str, Any]]:
    """The fleet's properties by the route ``args.method`` asks: the exit status and the
    JSON report (``FleetVerdict.to_json``); in text, printed."""
    # loaded here, not at the top: mclc starts faster when it only compiles
    from mcl.analysis.fleet_verification import verify_fleet

    verdict = verify_fleet(fleet, FLEET_METHOD[args.method], max_markings=args.max_markings,
                           max_bytes=args.max_memory)
    report = verdict.to_json()
    if fmt == "text":
        print(fleet_text(report))
    status = Exit.OK if verdict.ok else Exit.FAILED if verdict.failed else Exit.UNDECIDED
    return status, report
