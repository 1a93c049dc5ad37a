"""How far along the running tasks of a run are, read off its records: since when each runs,
its proved bound and the time left of it, and what its behaviours say of their progress
(waypoint k of n, metres to go: behaviours/base.py, ``Behaviour.progress_report``, as the
vehicle adapter's ``progress()`` gives it).

:class:`TaskProgress` is a player observer that needs only the net and the records (not the
player): ``mcl run``'s timeline prints its report at a bounded rate, so that a long survey
shows its progress between its start and its end; :class:`ProgressLog` writes it into the
run log once a minute (``progress`` records), so that a finished run's view and MCAP file
show it too. The running tasks are those whose block
has started and not ended (mission/blocks.py); a task's behaviours are those its actions
enabled and did not disable.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from mission.blocks import RUNNING, BlockStates, Key
from petri.execution.player import Record
from petri.execution.status import task_bounds
from petri.net import Net
from petri.semantics import block_of


class TaskProgress:
    """A player observer (append it to ``player.observers``): the running task calls and
    how far along each is (:meth:`report`)."""

    def __init__(self, net: Net, progress: Callable[[], dict[str, Any]] | None = None,
                 params: Mapping[str, Any] | None = None):
        self.blocks = BlockStates(net)
        self.calls: dict[Key, str] = {
            ("task", t.origin.line, t.origin.col): block_of(t.name)
            for t in net.transitions if t.origin is not None and t.origin.kind == "task"}
        self.bounds = task_bounds(net, params)
        self.progress = progress
        self.since: dict[str, float] = {}  # running task call -> mission time it started
        self.behaviour_task: dict[str, str] = {}  # behaviour on -> the task that enabled it

    def __call__(self, record: Record) -> None:
        self.blocks(record)
        d = record.data
        if record.kind == "action" and isinstance(d.get("behaviour"), str):
            if d.get("action") == "disable":
                self.behaviour_task.pop(d["behaviour"], None)
            else:
                self.behaviour_task[d["behaviour"]] = str(d.get("task", ""))
        if record.kind != "fire":
            return
        t = record.t - (self.blocks.start or 0.0)
        running = {self.calls[k] for k, state in self.blocks.current.items()
                   if state == RUNNING and k in self.calls}
        for call in list(self.since):
            if call not in running:
                del self.since[call]
        for call in running:
            self.since.setdefault(call, t)

    def report(self, t: float) -> list[dict[str, Any]]:
        """The running tasks at mission time ``t``, in the mission status's form
        (petri/execution/status.py): task, since, bound and time left, progress."""
        told = self.progress() if self.progress is not None else {}
        out: list[dict[str, Any]] = []
        for call, since in sorted(self.since.items(), key=lambda kv: kv[1]):
            entry: dict[str, Any] = {"task": call, "since": round(since, 3)}
            bound = self.bounds.get(call)
            if bound is not None:
                entry["bound"] = bound
                entry["left"] = round(max(0.0, since + bound - t), 1)
            for behaviour, task in self.behaviour_task.items():
                if task == call and isinstance(told.get(behaviour), dict):
                    entry["progress"] = told[behaviour]
            out.append(entry)
        return out


PROGRESS_EVERY = 60.0  # mission s between two progress records of a long task


class ProgressLog:
    """A player observer told the mission time every round (``tick``): every
    :data:`PROGRESS_EVERY` s of mission time, each task that has run that long and whose
    behaviours say how far along they are, as :meth:`TaskProgress.report` gives it, goes to
    ``write(t, report)`` (the run log's :meth:`~mission.logwriter.LogWriter.progress`)."""

    def __init__(self, net: Net, progress: Callable[[], dict[str, Any]],
                 write: Callable[[float, dict[str, Any]], None],
                 every: float = PROGRESS_EVERY) -> None:
        self.tasks = TaskProgress(net, progress)
        self.write, self.every = write, every
        self.last = 0.0  # mission time of the last report written

    def __call__(self, record: Record) -> None:
        self.tasks(record)

    def tick(self, t: float) -> None:
        if t - self.last < self.every:
            return
        long = [r for r in self.tasks.report(t)
                if t - r["since"] >= self.every and "progress" in r]
        if long:
            self.last = t
        for report in long:
            self.write(t, report)
