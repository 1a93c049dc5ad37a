"""``mcl check``: compile and verify missions, exactly as ``mclc`` does (same options, same
report, same exit statuses: see ``app/mclc.py`` and README, "mclc")."""

from __future__ import annotations

import sys

from app import mclc


def main(argv: list[str] | None = None) -> int:
    """``mcl check ARGS`` is ``mclc ARGS``."""
    return mclc.main(argv)


if __name__ == "__main__":
    sys.exit(main())
