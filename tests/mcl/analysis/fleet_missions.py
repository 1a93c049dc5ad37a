"""Two-vehicle fleets for the fleet proof's tests: a guide (asv) and a guided vehicle (uuv).

Until the fleet language compiles Send/Receive itself, the vehicles' missions are ordinary
MCL over a stand-in library whose tasks act as Send(guide, M) (an immediate task whose enable
of ``send_guide_M`` becomes the send action) and Receive(guide, M, timeout = ...) (a task
ending ok on the event ``guide.M``): the nets are those the fleet compiler makes."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from diagnostics import Source
from mcl import tasklib
from mcl.api import Compiled, compile_source
from petri.net import Action

TASKS = """
dofs x, y, z, yaw;
behaviour guide events release, fix;
behaviour send_guide_release;
behaviour send_guide_fix;
behaviour Dive drives z;
behaviour Surface drives z events surfaced;
task SendRelease() { start: enable send_guide_release; }
task SendFix() { start: enable send_guide_fix; }
task ReceiveRelease() { ok: guide.release; timeout: 5 min -> fail; }
task ReceiveReleaseForever() { ok: guide.release; }
task ReceiveFix() { ok: guide.fix; timeout: 10 s -> fail; }
task Dive(enable) { start: enable Dive; latch: Dive; }
task Dive(disable) { start: disable Dive; unlatch: Dive; }
task Surface() { start: enable Surface; ok: Surface.surfaced; timeout: 5 min -> fail;
                 stop: disable Surface; }
"""

ASV = """MISSION asv {
    SendRelease();
    PARALLEL { WHILE { Wait(2 s) } DO { SendFix() } } OR { Wait(1 min) }
}
"""
UUV = """MISSION uuv {
    IF { ReceiveRelease() } THEN {
        Dive(enable);
        IF { ReceiveFix() } THEN { Wait(1 s); Dive(disable) }
        ELSE { Dive(disable); Surface() }
    } ELSE { Wait(1 s) }
}
"""
# the same vehicle with the surfacing for a silent guide removed
UUV_NO_SURFACING = UUV.replace("ELSE { Dive(disable); Surface() }", "ELSE { Fail() }")
# a guide that may end without sending, and a vehicle that waits for ever on a reliable link
ASV_MAY_NOT_SEND = """MISSION asv {
    IF { Surface() } THEN { SendRelease() } ELSE { Wait(1 s) }
}
"""
UUV_WAITS = """MISSION uuv {
    ReceiveReleaseForever();
    Surface()
}
"""


@dataclass(frozen=True)
class Channel:
    name: str
    sender: str
    receivers: tuple[str, ...]
    lossy: bool
    messages: tuple[str, ...]


@dataclass
class Fleet:
    name: str
    vehicles: dict[str, Compiled] = field(default_factory=dict)
    channels: dict[str, Channel] = field(default_factory=dict)


def vehicle(name: str, text: str) -> Compiled:
    """A vehicle's mission compiled, its stand-in sends made send actions."""
    library = tasklib.load_sources([tasklib.shipped_source("core.tasks"),
                                    Source("fleet.tasks", TASKS)])
    compiled = compile_source(Source(f"{name}.mcl", text), library=library)
    net = compiled.net
    for i, tr in enumerate(net.transitions):
        actions = tuple(Action("send", a.behaviour.split("_")[1],
                               (("message", a.behaviour.split("_")[2]),))
                        if a.behaviour.startswith("send_") else a for a in tr.actions)
        net.transitions[i] = replace(tr, actions=actions)
    return compiled


def fleet(asv: str = ASV, uuv: str = UUV, lossy: bool = True) -> Fleet:
    return Fleet("mcm", {"asv": vehicle("asv", asv), "uuv": vehicle("uuv", uuv)},
                 {"guide": Channel("guide", "asv", ("uuv",), lossy, ("release", "fix"))})
