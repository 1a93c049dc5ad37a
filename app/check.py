"""``mcl check``: compile and verify missions, exactly as ``mclc`` does (same options, same
report, same exit statuses: ``app/mclc.py``, README "mclc", docs/EXIT.md)."""

from __future__ import annotations

import sys

from app import mclc


def main(argv: list[str] | None = None) -> int:
    """``mcl check ARGS`` is ``mclc ARGS`` (its errors named ``mcl check``)."""
    return mclc.main(argv, prog="mcl check")


if __name__ == "__main__":
    sys.exit(main())
