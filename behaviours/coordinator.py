"""The coordinator (paper 002 §3.1, Figure 4): merges the enabled behaviours' responses.

Each degree of freedom goes to the highest-priority behaviour that asks for it, by a velocity
demand or a position setpoint (:class:`behaviours.base.Response`); the priorities are the
classes' own (``Behaviour.priority``, looked up by name in behaviours/registry.py). `mclc`
proves that a verified mission never enables two behaviours driving the same degree of
freedom, so in a verified mission the merge is a plain union; the priorities are the vehicle's
own last line of defence, and every overlap is counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from behaviours import registry
from behaviours.base import DOFS, Response

# Who wins an overlap, highest first (Surface over wall keeping over the motion along the wall
# over transits): derived from the registered classes' ``priority``, never kept by hand.
PRIORITY = registry.priority()


@dataclass
class Coordinator:
    overlaps: int = 0  # ticks in which two behaviours asked for the same degree of freedom
    last_owner: dict[str, str] = field(default_factory=dict)  # dof -> the behaviour given it
    last_setpoints: dict[str, float] = field(default_factory=dict)  # dof -> position setpoint

    def merge(self, responses: dict[str, Response]) -> dict[str, float]:
        """Velocity setpoints per degree of freedom (a free one, or one held by a position
        setpoint, is at zero velocity); the position setpoints of the same merge are left in
        :attr:`last_setpoints` (x, y, z m world frame, yaw rad), the owners in
        :attr:`last_owner`."""
        order = sorted(responses, key=lambda b: -registry.rank(b))  # stable: ties keep order
        velocities = {dof: 0.0 for dof in DOFS}
        positions: dict[str, float] = {}
        owner: dict[str, str] = {}
        contested = False
        for name in order:
            r = responses[name]
            for dof in dict.fromkeys([*r.demands, *r.setpoints]):
                if dof in owner:
                    contested = True
                    continue
                owner[dof] = name
                if dof in r.demands:
                    velocities[dof] = r.demands[dof]
                if dof in r.setpoints:
                    positions[dof] = r.setpoints[dof]
        self.overlaps += contested
        self.last_owner = owner
        self.last_setpoints = positions
        return velocities
