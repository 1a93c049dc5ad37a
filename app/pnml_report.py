"""``python -m app.pnml_report``: the state-space report of a P/T net given as PNML.

    python -m app.pnml_report MODEL.pnml|MODEL.tgz [--json] [--method auto|explicit|symbolic]
                              [--max-markings N]

A ``.tgz`` is a Model Checking Contest archive; its ``*/model.pnml`` is read. The report (how
many markings and arcs, bounds, deadlocks, dead transitions, 1-safety) is
:func:`petri.verification.pnml_report.analyse`'s. Exit status: 0 reported, 1 the net could not be read or
the method could not decide it. (``mclc FILE.pnml`` gives the same report with mclc's statuses.)
"""

from __future__ import annotations

import argparse
import json
import sys

from petri.verification import symbolic
from petri.formats.pnml import PnmlError
from petri.verification.pnml_report import analyse, format_report, load_net


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
        return 1
    except (ValueError, symbolic.NotOneSafe, symbolic.SymbolicLimit) as exc:  # --method symbolic
        print(f"{args.model}: error: {exc}", file=sys.stderr)
        return 1
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
