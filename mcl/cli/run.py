"""``mcl``: the operator's command. ``mcl check`` is ``mclc``; ``mcl run`` comes with the
real-time player (not in this version yet: it says so and exits 2)."""

from __future__ import annotations

import sys

from . import mclc

USAGE = """usage: mcl COMMAND ...

commands:
  check MISSION.mcl [options]   compile and verify (the same as mclc; see mclc --help)
  run MISSION.mcl               run a mission (not available in this version)
"""


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] in ("-h", "--help"):
        print(USAGE)
        return 0 if args else 2
    command, rest = args[0], args[1:]
    if command == "check":
        return mclc.main(rest)
    if command in ("run", "replay", "vehicle", "monitor"):
        print(f"mcl {command}: not available in this version: the player and the vehicle "
              "adapters are not built yet.\n  hint: 'mcl check MISSION.mcl' (or mclc) "
              "compiles and verifies a mission", file=sys.stderr)
        return 2
    print(f"mcl: unknown command {command!r}\n\n{USAGE}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
