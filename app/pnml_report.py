"""``python -m app.pnml_report``: the state-space report of a P/T net given as PNML.

    python -m app.pnml_report MODEL.pnml|MODEL.tgz [--json] [--method auto|explicit|symbolic]
                              [--max-markings N]

A ``.tgz`` is a Model Checking Contest archive; its ``*/model.pnml`` is read. The report (how
many markings and arcs, bounds, deadlocks, dead transitions, 1-safety) is
:func:`petri.verification.pnml_report.analyse`'s. Its exit statuses (reported; a file that is not a
P/T net: invalid input; a method that cannot decide it: no verdict), the same as ``mclc
FILE.pnml``'s: docs/EXIT.md.
"""

from __future__ import annotations

import argparse
import json
import sys

from app.reports.pnml import pnml_text
from mission.exits import Exit
from petri.formats.pnml import PnmlError
from petri.verification import symbolic
from petri.verification.pnml_report import analyse, load_net


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.pnml_report",
                                     description="State-space report of a PNML P/T net.")
    parser.add_argument("model", help="a .pnml file or a Model Checking Contest .tgz")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--method", choices=("auto", "explicit", "symbolic"), default="auto")
    parser.add_argument("--max-markings", type=int, default=20_000_000)
    args = parser.parse_args(argv)
    try:
        net = load_net(args.model)
        report = analyse(net, method=args.method, max_markings=args.max_markings)
    except PnmlError as exc:
        print(exc, file=sys.stderr)
        return Exit.INVALID
    except (ValueError, symbolic.NotOneSafe, symbolic.SymbolicLimit) as exc:  # --method symbolic
        print(f"{args.model}: error: {exc}", file=sys.stderr)
        return Exit.UNDECIDED
    print(json.dumps(report, indent=2) if args.json else pnml_text(report))
    return Exit.OK


if __name__ == "__main__":
    sys.exit(main())
