"""``python -m app.pnml_report``: the state-space report of a P/T net given as PNML.

    python -m app.pnml_report MODEL.pnml|MODEL.tgz [--json] [--method auto|explicit|symbolic]
                              [--max-markings N] [--max-memory SIZE]

A ``.tgz`` is a Model Checking Contest archive; its ``*/model.pnml`` is read in place (an archive
with an entry that is not a plain file or folder inside its folder is refused: invalid input).
The searches stay inside ``--max-memory`` (default 1 GiB), as ``mclc NET.pnml``'s do. The report (how
many markings and arcs, bounds, deadlocks, dead transitions, 1-safety) is
:func:`petri.verification.pnml_report.analyse`'s. Its exit statuses, the same as ``mclc
FILE.pnml``'s, come from ``mission.exits.Exit`` (docs/EXIT.md): reported; a file that is not a
P/T net or an option out of range: invalid input; ``--method symbolic`` on a net that is not
1-safe or past its time: no verdict; a bug of ours: internal error.
"""

from __future__ import annotations

import json
import sys
import traceback

from app.arguments import memory_size
from app.reports.pnml import pnml_text
from app import arguments
from mission.exits import Exit
from petri.formats.pnml import PnmlError
from petri.verification import symbolic
from petri.verification.pnml_report import MAX_BYTES, analyse, load_net


def main(argv: list[str] | None = None) -> int:
    parser = arguments.Parser(prog="python -m app.pnml_report",
                                     description="State-space report of a PNML P/T net.")
    parser.add_argument("model", help="a .pnml file or a Model Checking Contest .tgz")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--method", choices=("auto", "explicit", "symbolic"), default="auto")
    parser.add_argument("--max-markings", type=int, default=20_000_000, metavar="N",
                        help="stop the explicit search after N markings (1 to 2**31 - 1)")
    parser.add_argument("--max-memory", type=memory_size, default=MAX_BYTES, metavar="SIZE",
                        help="the memory the search may use, e.g. 512MiB, 4GiB (default "
                             "1GiB); past it the report says what it could not decide")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    args = parser.parse_args(argv)
    if not 1 <= args.max_markings < 2**31:  # invalid input, not a method that cannot decide
        parser.error(f"argument --max-markings: must lie between 1 and 2**31 - 1, got "
                     f"{args.max_markings}")
    try:
        net = load_net(args.model)
        report = analyse(net, method=args.method, max_markings=args.max_markings,
                         max_bytes=args.max_memory)
    except PnmlError as exc:
        print(exc, file=sys.stderr)
        return Exit.INVALID
    except (symbolic.NotOneSafe, symbolic.SymbolicLimit) as exc:  # --method symbolic
        print(f"{args.model}: error: {exc}", file=sys.stderr)
        return Exit.UNDECIDED
    except Exception as exc:  # a bug of ours: say so plainly, never a bare traceback
        if args.debug:
            traceback.print_exc()
        print(f"{args.model}: internal error: {type(exc).__name__}: {exc}\n"
              "  hint: this is a bug; rerun with --debug and report it", file=sys.stderr)
        return Exit.INTERNAL
    print(json.dumps(report, indent=2) if args.json else pnml_text(report))
    return Exit.OK


if __name__ == "__main__":
    sys.exit(main())
