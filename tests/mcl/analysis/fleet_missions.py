"""Two-vehicle fleets for the fleet proof's tests, in the fleet language: a guide (asv) that
sends ``release`` and then a fix every 2 s for a minute, and a guided vehicle (uuv) that
holds its heading and distance (a latched behaviour) on the release, follows the fixes and,
when they stop, lets go and surfaces. Variants break it one way each."""

from __future__ import annotations

from diagnostics import Source
from mcl.fleet import CompiledFleet, compile_fleet_source

ASV = """
            Send(guide, release);
            PARALLEL { WHILE { Wait(2 s) } DO { Send(guide, fix) } } OR { Wait(1 min) }"""
UUV = """
            IF { Receive(guide, release, timeout = 5 min) } THEN {
                KeepHeadDist(enable, 0 deg, 2 m);
                IF { Receive(guide, fix, timeout = 10 s) } THEN {
                    Wait(1 s); KeepHeadDist(disable)
                } ELSE { KeepHeadDist(disable); Surface() }
            } ELSE { Wait(1 s) }"""
# the same vehicle with the surfacing for a silent guide removed
UUV_NO_SURFACING = UUV.replace("ELSE { KeepHeadDist(disable); Surface() }", "ELSE { Fail() }")
# a guide that may end without sending, and a vehicle that waits for ever (reliable link)
ASV_MAY_NOT_SEND = """
            IF { Surface() } THEN { Send(guide, release) } ELSE { Wait(1 s) }"""
ASV_ALWAYS_SENDS = ASV_MAY_NOT_SEND.replace("ELSE { Wait(1 s) }", "ELSE { Send(guide, release) }")
UUV_WAITS = """
            Receive(guide, release);
            Surface()"""


def fleet_text(asv: str = ASV, uuv: str = UUV, lossy: bool = True, every: bool = True) -> str:
    """The fleet; ``lossy``: its channel is LOSSY; ``every``: it has EVERY 2 s."""
    options = (" EVERY 2 s" if every else "") + (" LOSSY" if lossy else "")
    return f"""// a surface vehicle guides an underwater vehicle
FLEET mcm {{
    CHANNEL guide FROM asv TO uuv ACOUSTIC DELAY 1 s .. 3 s{options}
        MESSAGES release, fix;
    VEHICLE asv {{
        MISSION guide_to_mine {{{asv}
        }}
    }}
    VEHICLE uuv {{
        MISSION go_to_mine {{{uuv}
        }} ON STOP {{ Surface() }}
    }}
}}
"""


def fleet(asv: str = ASV, uuv: str = UUV, lossy: bool = True, every: bool = True
          ) -> CompiledFleet:
    return compile_fleet_source(Source("mcm.mcl", fleet_text(asv, uuv, lossy, every)))


def where(text: str, needle: str) -> str:
    """``mcm.mcl:LINE:COL`` of the first ``needle`` in a fleet's text."""
    before = text[:text.index(needle)]
    return f"mcm.mcl:{before.count(chr(10)) + 1}:{len(before) - before.rfind(chr(10))}"
