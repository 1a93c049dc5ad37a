"""``mcl fmt`` on fleet files (mcl/formatter.py): the one layout, comments kept, the fleet
parsing to what it did; a CHANNEL too long for a line breaks before MESSAGES."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import printer
from mcl.formatter import format_text
from mcl.parser import parse_unit
from tests import strategies as S
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


# a fleet's text as tokens: the DELAY's '..' is one token (the missions' pattern reads two)
FLEET_TOKEN = re.compile(r"\.\.|" + S.TOKEN.pattern)
SEPARATORS = st.sampled_from([" ", "\n", "\n\n\n", "\t", " /* c{} */ ", "// c{}\n",
                              "\n  // c{}\n"])


@st.composite
def laid_out_fleets(draw: st.DrawFn) -> tuple[str, str]:
    """A random fleet of random Ictineu missions, then the same laid out with random blanks
    and numbered comments between its tokens."""
    count = draw(st.integers(1, 3))
    vehicles = "".join(
        f"VEHICLE v{i} {{\n"
        + printer.mission(draw(S.ictineu_missions(max_depth=2, max_calls=5))) + "}\n"
        for i in range(count))
    receivers = ", ".join(f"v{i}" for i in range(1, count)) or "v9"
    every = draw(st.sampled_from(["", " EVERY 2 s"]))
    lossy = draw(st.sampled_from(["", " LOSSY"]))
    channel = (f"CHANNEL c FROM v0 TO {receivers} "
               f"{draw(st.sampled_from(['ACOUSTIC', 'RADIO', 'TETHER']))} DELAY 1 s .. 3 s"
               f"{every}{lossy} MESSAGES m, n;\n")
    text = "FLEET f {\n" + channel + vehicles + "}\n"
    tokens = [m.group() for m in FLEET_TOKEN.finditer(text)]
    parts = [tokens[0]]
    for i, tok in enumerate(tokens[1:]):
        parts += [draw(SEPARATORS).replace("{}", str(i)), tok]
    return text, "".join(parts)


@pytest.mark.slow  # 60 random fleets
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(laid_out_fleets())
def test_random_fleet_layouts_and_comments(case: tuple[str, str]) -> None:
    plain, source = case
    text = format_text(source)
    assert _same(text, plain)
    assert format_text(text) == text
    assert COMMENT.findall(text) == COMMENT.findall(source)
