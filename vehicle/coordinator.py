"""The coordinator (paper 002 §3.1, Figure 4): merges the enabled behaviours' responses.

Each degree of freedom takes the demand of the highest-priority behaviour that drives it.
`mclc` proves that a verified mission never enables two behaviours driving the same degree of
freedom, so in a verified mission the merge is a plain union; the priorities are the vehicle's
own last line of defence, and every overlap is counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from behaviours import DOFS, Response

# Surfacing wins over everything; wall keeping over the motion along the wall over transits.
PRIORITY = ("Surface", "AchieveHeadDist", "WallInspection", "GoTo")


@dataclass
class Coordinator:
    overlaps: int = 0  # ticks in which two behaviours asked for the same degree of freedom
    last_owner: dict[str, str] = field(default_factory=dict)

    def merge(self, responses: dict[str, Response]) -> dict[str, float]:
        """Velocity setpoints per degree of freedom; a free one is held at zero velocity."""
        order = sorted(responses, key=lambda b: PRIORITY.index(b) if b in PRIORITY else 99)
        setpoints = {dof: 0.0 for dof in DOFS}
        owner: dict[str, str] = {}
        contested = False
        for name in order:
            for dof, value in responses[name].demands.items():
                if dof in owner:
                    contested = True
                    continue
                owner[dof] = name
                setpoints[dof] = value
        self.overlaps += contested
        self.last_owner = owner
        return setpoints
