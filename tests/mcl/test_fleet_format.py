"""``mcl fmt`` on fleet files (mcl/formatter.py): the one layout, comments kept, the fleet
parsing to what it did; a CHANNEL too long for a line breaks before MESSAGES."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from diagnostics import Source
from mcl.formatter import format_text
from mcl.parser import parse_unit
from tests.support import MISSIONS, cli, write

RELAY = MISSIONS / "fleet_relay.mcl"
COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)

UGLY = """FLEET  x{CHANNEL a FROM p TO q,r RADIO DELAY 1 s..2s EVERY 1s LOSSY MESSAGES m,n ;
// the leader
VEHICLE p{USES "ictineu";PARAM a=1 m;PARAM bb = 2 m; MISSION{Send(a,m)}ON STOP{Surface()}}


VEHICLE q{MISSION m{Wait(1 s);Receive(a, m, timeout=1 s)}}  /* the end */ }"""

LAID_OUT = """FLEET x {
    CHANNEL a FROM p TO q, r RADIO DELAY 1 s .. 2 s EVERY 1 s LOSSY MESSAGES m, n;
    // the leader
    VEHICLE p {
        USES "ictineu";
        PARAM a  = 1 m;
        PARAM bb = 2 m;
        MISSION {
            Send(a, m)
        } ON STOP {
            Surface()
        }
    }

    VEHICLE q {
        MISSION m {
            Wait(1 s);
            Receive(a, m, timeout = 1 s)
        }
    } /* the end */
}
"""


def _same(a: str, b: str) -> bool:
    return parse_unit(Source("a", a)) == parse_unit(Source("b", b))


def test_a_fleet_is_laid_out_vehicle_by_vehicle() -> None:
    text = format_text(UGLY)
    assert text == LAID_OUT
    assert format_text(text) == text and _same(text, UGLY)


def test_a_long_channel_breaks_before_its_messages() -> None:
    names = ", ".join(f"message{i}" for i in range(12))
    text = format_text(UGLY.replace("MESSAGES m,n", f"MESSAGES m,n, {names}"))
    line = next(i for i, s in enumerate(text.splitlines()) if "CHANNEL" in s)
    lines = text.splitlines()
    assert lines[line].endswith("LOSSY")
    assert lines[line + 1] == f"        MESSAGES m, n, {names};"
    assert format_text(text) == text


def test_the_shipped_fleet_is_in_the_layout_with_its_comments() -> None:
    source = RELAY.read_text("utf-8")
    assert format_text(source, str(RELAY)) == source
    assert len(COMMENT.findall(source)) >= 5


@pytest.mark.slow  # two runs of the command
def test_mcl_fmt_rewrites_a_fleet_file(tmp_path: Path) -> None:
    path = write(tmp_path, UGLY, "x.mcl")
    proc = cli("mcl", "fmt", "--check", str(path))
    assert proc.returncode == 1 and str(path) in proc.stdout + proc.stderr
    assert cli("mcl", "fmt", str(path)).returncode == 0
    assert path.read_text() == LAID_OUT
