"""behaviours/coordinator.py on its own: the merge of the enabled behaviours' responses.

Written against the rule the module states, not against examples only: each degree of
freedom goes to the highest-ranked behaviour that asks for it (by a velocity demand or a
position setpoint; ties keep the order given), a free one is at zero velocity, and a tick in
which two behaviours ask for one degree of freedom is counted once. Hypothesis draws the
responses (registered names, one the registry does not know, demands and setpoints).
"""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from behaviours import registry
from behaviours.base import DOFS, Response
from behaviours.coordinator import PRIORITY, Coordinator

NAMES = ["GoTo", "WallInspection", "AchieveHeadDist", "Surface", "KeepAltitude", "Alarms",
         "Mystery"]
SPEEDS = st.floats(-2.0, 2.0, allow_nan=False)
RESPONSES = st.builds(Response, st.dictionaries(st.sampled_from(DOFS), SPEEDS),
                      st.dictionaries(st.sampled_from(DOFS), SPEEDS))


def test_priority_is_the_registry_s_highest_first() -> None:
    assert PRIORITY == registry.priority()
    ranks = [registry.rank(name) for name in PRIORITY]
    assert ranks == sorted(ranks, reverse=True) and all(r > 0 for r in ranks)
    assert registry.rank("Mystery") == 0


def test_a_tie_goes_to_the_behaviour_given_first() -> None:
    assert registry.rank("Alarms") == registry.rank("StartLogs") == 0
    c = Coordinator()
    out = c.merge({"Mystery": Response({"x": 1.0}), "Other": Response({"x": 2.0})})
    assert out["x"] == 1.0 and c.last_owner == {"x": "Mystery"} and c.overlaps == 1
    out = c.merge({"Other": Response({"x": 2.0}), "Mystery": Response({"x": 1.0})})
    assert out["x"] == 2.0 and c.last_owner == {"x": "Other"} and c.overlaps == 2


def test_one_behaviour_may_give_a_demand_and_a_setpoint_on_one_degree_of_freedom() -> None:
    c = Coordinator()
    out = c.merge({"GoTo": Response({"z": 0.2}, {"z": 5.0})})
    assert out["z"] == 0.2 and c.last_setpoints == {"z": 5.0} and c.overlaps == 0


@given(st.dictionaries(st.sampled_from(NAMES), RESPONSES, max_size=5))
def test_each_degree_of_freedom_goes_to_the_highest_ranked_asker(
        responses: dict[str, Response]) -> None:
    c = Coordinator()
    out = c.merge(responses)
    assert set(out) == set(DOFS)
    contested = False
    for dof in DOFS:
        askers = [n for n, r in responses.items() if dof in r.demands or dof in r.setpoints]
        contested |= len(askers) > 1
        if not askers:
            assert out[dof] == 0.0 and dof not in c.last_owner
            assert dof not in c.last_setpoints
            continue
        best = max(registry.rank(n) for n in askers)
        owner = next(n for n in askers if registry.rank(n) == best)  # the first of the best
        assert c.last_owner[dof] == owner
        assert out[dof] == responses[owner].demands.get(dof, 0.0)
        assert c.last_setpoints.get(dof) == responses[owner].setpoints.get(dof)
    assert c.overlaps == int(contested)
