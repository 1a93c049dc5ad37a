"""The rules of mclc's SARIF report: what each property proved means, for a code-scanning page.

Every property of docs/LANGUAGE.md ("What mclc proves") is a rule with a one-line description
and a help text (what it means, how to mend a violation) and a link into the documents; a
deadline or battery that a run can break links docs/DURATION.md; an error or warning of the
parser or the checker is a rule named by its code, its help the hint it came with.

The links are absolute, as SARIF wants: under ``$MCL_DOCS_URI`` (a folder holding the
project's ``docs/``, e.g. the repository's ``docs`` folder on its forge), else under the
``Documentation`` URL of the installed package's metadata (``[project.urls]``); with neither,
a rule has its help text and no link (docs/CI.md).
"""

from __future__ import annotations

import os
from importlib import metadata

DISTRIBUTION = "mcl-auv"  # pyproject.toml's project name
PROVES = "LANGUAGE.md#what-mclc-proves"
MENDED_BY_A_RACE = " Race a loop with a Timeout (PARALLEL { WHILE ... } OR { Timeout(20 min) })."

# property: (what it says, how to read and mend a violation)
PROPERTIES: dict[str, tuple[str, str]] = {
    "one-safe": ("No place of the mission's net ever holds two tokens.",
                 "A violation is a bug of the compiler, not of the mission: report it."),
    "proper-completion": (
        "At the end, the mission's ok or fail place holds the only token.",
        "A violation is a bug of the compiler, not of the mission: report it."),
    "no-deadlock": ("No reachable state is stuck before the mission ends.",
                    "The steps show how the mission gets stuck."),
    "terminates": (
        "Every run ends, whatever the vehicle answers.",
        "A loop that goes round for as long as the vehicle keeps answering, or a task that "
        "waits for an event with no timeout, can run for ever: the steps show the run to the "
        "loop, then the loop." + MENDED_BY_A_RACE + " Give a waiting task a timeout = ..."),
    "can-end": (
        "From every reachable state the mission can still end by itself.",
        "A WHILE that cannot end: make its condition able to fail." + MENDED_BY_A_RACE),
    "no-zeno": (
        "No loop goes round without time passing.",
        "A loop of instant tasks (Wait(0 s)) would make the player spin: the steps show the "
        "loop. Add a Wait of a positive delay to it."),
    "instant-loop": (
        "No loop goes round with no mission time passing when the vehicle answers at once.",
        "A warning: a lap can be closed by events alone, and a vehicle that answers at once "
        "spins it until the player stops the mission. Add Wait(1 s) to the loop if it must "
        "not spin."),
    "behaviours-off-at-end": ("No behaviour is on when the mission ends.",
                              "The steps end with the behaviour still on: switch it off."),
    "behaviour-single-owner": (
        "No behaviour that drives a degree of freedom is held on by two tasks at once.",
        "Two tasks (or a task and a latch) hold the same behaviour: the steps show both."),
    "dof-exclusive": (
        "No two behaviours on together drive the same degree of freedom.",
        "The steps show both behaviours switched on: run them one after the other, or in "
        "branches that cannot overlap."),
    "no-disable-while-held": (
        "No firing switches off a behaviour that another task still holds on.",
        "The player would keep the behaviour on, so the line would not do what it says."),
    "stop-safe": (
        "A stop from outside, from any reachable state, ends the mission with every "
        "behaviour off.",
        "The steps show the state the stop comes in, and what stays on."),
    "stop-ends": (
        "The ON STOP handler ends by itself within its proved worst case.",
        "Give the handler's tasks timeouts."),
    "actions-match-behaviours": (
        "Each firing that turns a behaviour on or off sends the action that does it.",
        "A violation is a bug of a task library or the compiler: the step names it."),
    "no-dead-transitions": (
        "Every transition can fire.",
        "A warning only: templates have paths a given mission cannot take. Not reported in "
        "SARIF or GitHub annotations."),
}
DURATION = {
    "deadline": ("Every run ends within the deadline (mclc --deadline).",
                 "The critical path's longest step is where the time goes."),
    "battery": ("Every run needs less energy than the battery holds (mclc --battery).",
                "The critical path's longest step is where the energy goes."),
}


def docs_uri() -> str | None:
    """The absolute URI of the folder of the project's documents, or None if unknown."""
    configured = os.environ.get("MCL_DOCS_URI", "").strip()
    if configured:
        return configured.rstrip("/") + "/"
    try:
        urls: list[str] = metadata.metadata(DISTRIBUTION).get_all("Project-URL") or []
    except metadata.PackageNotFoundError:
        return None
    for entry in urls:
        label, _, url = entry.partition(",")
        if label.strip().lower() == "documentation" and url.strip():
            return url.strip().rstrip("/") + "/"
    return None


def rule(rule_id: str, level: str, message: str, hint: str) -> dict[str, object]:
    """The SARIF reporting descriptor of a rule: its descriptions, its help, its link."""
    if rule_id in PROPERTIES:
        short, help_text = PROPERTIES[rule_id]
        page = PROVES
    elif rule_id in DURATION:
        short, help_text = DURATION[rule_id]
        page = "DURATION.md"
    else:  # a diagnostic of the parser or the checker, named by its code
        short, help_text = message, hint or message
        page = "LANGUAGE.md"
    descriptor: dict[str, object] = {
        "id": rule_id,
        "name": "".join(w.capitalize() for w in rule_id.split("-")),
        "shortDescription": {"text": short},
        "fullDescription": {"text": f"{short} {help_text}"},
        "help": {"text": help_text, "markdown": f"**{short}**\n\n{help_text}"},
        "defaultConfiguration": {"level": "error" if level == "error" else "warning"},
        "properties": {"tags": ["mcl", "verification" if page == PROVES else "mission"]},
    }
    base = docs_uri()
    if base is not None:
        descriptor["helpUri"] = base + page
        descriptor["help"] = {"text": f"{help_text} See {base + page}",
                              "markdown": f"**{short}**\n\n{help_text}\n\n"
                                          f"[docs/{page}]({base + page})"}
    return descriptor
